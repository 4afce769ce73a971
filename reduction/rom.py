"""The reduced-order model handed to ``study``/``hbm`` (docs/architecture.md)."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from reduction.coupled import _check_xi, _mesh_energy_of, coupled_modes, modal_damping
from reduction.craig_bampton import CBResult
from reduction.validate import Validation

log = logging.getLogger(__name__)

#: Names of the 12 gear DOF in the paper's order q_c (eq. 11).
GEAR_DOF_NAMES = (
    "u1", "u2", "u3", "theta1", "theta2", "theta3",
    "u4", "u5", "u6", "theta4", "theta5", "theta6",
)


@dataclass
class ROM:
    """Craig–Bampton reduced model with coordinates ``q = (q_c, η)``.

    Attributes
    ----------
    M, K, C : ndarray (n_r, n_r)
        Reduced mass [kg], stiffness without mesh coupling [N/m] and modal
        damping of the coupled model (eq. 19) [N·s/m].
    G : ndarray (n_r,)
        Projection vector (eq. 11), zero past the gear DOF.
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
    km_mean : float
        Mean mesh stiffness used for eq. (17) [N/m].
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
    km_mean: float
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


def build_rom(
    cb: CBResult,
    G_gear,
    km_mean: float,
    xi=0.05,
    gear_dof_names: tuple | None = None,
) -> ROM:
    """Assemble the :class:`ROM` from a Craig–Bampton result.

    Parameters
    ----------
    cb : CBResult
        Output of :func:`reduction.craig_bampton`.
    G_gear : array (n_c,)
        Projection vector on the gear DOF (eq. 11), in the order of
        ``cb.interface_dofs``; padded with zeros to n_r.
    km_mean : float
        Mean mesh stiffness k̄_m [N/m] (eq. 17), >= 0.
    xi : float or array (n_r,)
        Modal damping ratio(s) of the coupled modes (eq. 18), default 5 %.
    gear_dof_names : tuple of str, optional
        Defaults to the paper's ``u1 … theta6`` when n_c = 12, else ``c0, c1 …``.
    """
    n_c = cb.interface_dofs.size
    G_gear = np.asarray(G_gear, dtype=float).ravel()
    if G_gear.size != n_c:
        raise ValueError(f"G.size = {G_gear.size}: must equal n_c = {n_c}")
    if gear_dof_names is None:
        gear_dof_names = GEAR_DOF_NAMES if n_c == 12 else tuple(f"c{k}" for k in range(n_c))
    if len(gear_dof_names) != n_c:
        raise ValueError(f"len(gear_dof_names) = {len(gear_dof_names)}: must equal {n_c}")
    G = np.zeros(cb.n_r)
    G[:n_c] = G_gear
    xi_arr = np.array(_check_xi(xi, cb.n_r))
    modes = coupled_modes(cb.M_r, cb.K_r, G, km_mean)
    C = modal_damping(cb.M_r, cb.K_r, G, km_mean, xi_arr)
    rho = _mesh_energy_of(modes, cb.K_r, G, km_mean)
    log.info(
        "ROM: n_r = %d, coupled modes %.4g..%.4g Hz, max mesh energy %.3f at %.4g Hz",
        cb.n_r, modes.frequencies_hz[0], modes.frequencies_hz[-1], rho.max(),
        modes.frequencies_hz[int(np.argmax(rho))],
    )
    return ROM(
        M=cb.M_r, K=cb.K_r, C=C, G=G, gear_dof_names=tuple(gear_dof_names), n_cm=cb.n_cm,
        frequencies_hz=modes.frequencies_hz, mesh_energy=rho,
        fixed_interface_hz=cb.fixed_interface_hz, km_mean=float(km_mean), xi=xi_arr,
        gear_dofs=cb.interface_dofs.copy(), T=cb.T,
    )
