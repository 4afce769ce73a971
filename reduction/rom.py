"""The reduced-order model handed to ``study``/``hbm`` (docs/architecture.md)."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from reduction.coupled import check_xi, coupled_modes, mesh_energy_of, modal_damping
from reduction.craig_bampton import CBResult
from reduction.validate import Validation

log = logging.getLogger(__name__)


def gear_body_dof_names(n_bodies: int) -> tuple[str, ...]:
    """Names of the 6 DOF of ``n_bodies`` gear bodies, the paper's q_c numbering carried
    on: body k (from 0) has ``u{3k+1} u{3k+2} u{3k+3} theta{3k+1} theta{3k+2}
    theta{3k+3}``; two bodies give the paper's ``u1 … theta6`` (eq. 11)."""
    if isinstance(n_bodies, bool) or int(n_bodies) != n_bodies or n_bodies < 1:
        raise ValueError(f"n_bodies = {n_bodies!r}: must be an integer >= 1")
    return tuple(f"{q}{3 * k + j}" for k in range(int(n_bodies)) for q in ("u", "theta")
                 for j in (1, 2, 3))


@dataclass
class ROM:
    """Craig–Bampton reduced model with coordinates ``q = (q_c, η)``.

    Attributes
    ----------
    M, K, C : ndarray (n_r, n_r)
        Reduced mass [kg], stiffness without mesh coupling [N/m] and modal
        damping of the coupled model (eq. 19) [N·s/m].
    G : ndarray (n_r, E)
        Projection vector of each of the E gear meshes (eq. 11), zero past the gear DOF.
    gear_dof_names : tuple of str
        Names of the first ``n_c`` coordinates.
    n_cm : int
        Number of fixed-interface modes.
    frequencies_hz : ndarray (n_r,)
        Coupled frequencies (eq. 17) [Hz], ascending; rigid modes exactly 0.
    mesh_energy : ndarray (n_r,)
        Mesh energy of each coupled mode (eq. 31), in [0, 1].
    fixed_interface_hz : ndarray (n_cm,)
        Fixed-interface frequencies (eq. 6) [Hz].
    km_mean : float or ndarray (E,)
        Mean mesh stiffness used for eq. (17) [N/m], one per mesh or shared.
    xi : ndarray (n_r,)
        Modal damping ratio per coupled mode.
    gear_dofs : ndarray of int (n_c,)
        Global indices of the gear DOF in the FE unknowns.
    validation : Validation or None
        Comparison with the full model (Fig. 9), once computed.
    T : PETSc.Mat or None
        Distributed basis (``n × n_r`` dense) for :func:`reduction.reconstruct`;
        None after :func:`reduction.load_rom` (use ``load_basis``).
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    G: np.ndarray
    gear_dof_names: tuple
    n_cm: int
    frequencies_hz: np.ndarray
    mesh_energy: np.ndarray
    fixed_interface_hz: np.ndarray
    km_mean: float | np.ndarray
    xi: np.ndarray
    gear_dofs: np.ndarray
    validation: Validation | None = None
    T: PETSc.Mat | None = None

    @property
    def n_r(self) -> int:
        """Number of reduced coordinates."""
        return self.M.shape[0]

    @property
    def n_c(self) -> int:
        """Number of physical (gear) coordinates."""
        return len(self.gear_dof_names)

    @property
    def n_meshes(self) -> int:
        """Number of gear meshes (columns of ``G``)."""
        return self.G.shape[1]


def build_rom(
    cb: CBResult,
    G_gear,
    km_mean,
    xi=0.05,
    gear_dof_names: tuple | None = None,
) -> ROM:
    """Assemble the :class:`ROM` from a Craig–Bampton result.

    Parameters
    ----------
    cb : CBResult
        Output of :func:`reduction.craig_bampton`.
    G_gear : array (n_c,) or (n_c, E)
        Projection vector of each gear mesh on the gear DOF (eq. 11), in the order of
        ``cb.interface_dofs``; padded with zeros to n_r rows.
    km_mean : float or array (E,)
        Mean mesh stiffness k̄_m of each mesh [N/m] (eq. 17), >= 0.
    xi : float or array (n_r,)
        Modal damping ratio(s) of the coupled modes (eq. 18), default 5 %.
    gear_dof_names : tuple of str, optional
        Defaults to :func:`gear_body_dof_names` (the paper's ``u1 … theta6`` for two bodies)
        when n_c is a multiple of 6, else ``c0, c1 …``.
    """
    n_c = cb.interface_dofs.size
    G_gear = np.asarray(G_gear, dtype=float)
    if G_gear.ndim == 1:
        G_gear = G_gear.reshape(-1, 1)
    if G_gear.ndim != 2 or G_gear.shape[0] != n_c or G_gear.shape[1] < 1:
        raise ValueError(f"G.shape = {G_gear.shape}: must be (n_c,) or (n_c, n_meshes) "
                         f"with n_c = {n_c}")
    if gear_dof_names is None:
        gear_dof_names = gear_body_dof_names(n_c // 6) if n_c % 6 == 0 else \
            tuple(f"c{k}" for k in range(n_c))
    if len(gear_dof_names) != n_c:
        raise ValueError(f"len(gear_dof_names) = {len(gear_dof_names)}: must equal {n_c}")
    G = np.zeros((cb.n_r, G_gear.shape[1]))
    G[:n_c] = G_gear
    xi_arr = np.array(check_xi(xi, cb.n_r))
    modes = coupled_modes(cb.M_r, cb.K_r, G, km_mean)
    C = modal_damping(cb.M_r, cb.K_r, G, km_mean, xi_arr)
    rho = mesh_energy_of(modes, cb.K_r, G, km_mean)
    log.info(
        "ROM: n_r = %d, %d mesh(es), coupled modes %.4g..%.4g Hz, max mesh energy %.3f at "
        "%.4g Hz", cb.n_r, G.shape[1], modes.frequencies_hz[0], modes.frequencies_hz[-1],
        rho.max(), modes.frequencies_hz[int(np.argmax(rho))],
    )
    km = np.asarray(km_mean, dtype=float)
    return ROM(
        M=cb.M_r, K=cb.K_r, C=C, G=G, gear_dof_names=tuple(gear_dof_names), n_cm=cb.n_cm,
        frequencies_hz=modes.frequencies_hz, mesh_energy=rho,
        fixed_interface_hz=cb.fixed_interface_hz,
        km_mean=float(km) if km.ndim == 0 else km.copy(), xi=xi_arr,
        gear_dofs=cb.interface_dofs.copy(), T=cb.T,
    )
