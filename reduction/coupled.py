"""The reduced model with the gears coupled by the mean mesh stiffness (eq. 17–19, 31).

Everything here is dense NumPy on the small ``n_r × n_r`` reduced matrices.

Gear meshes: ``G`` holds one line-of-action direction per mesh, shape ``(n_r, E)`` (a
1-D ``(n_r,)`` array is one mesh), and ``km_mean`` one mean mesh stiffness per mesh (a
scalar is shared by all). The coupling is the sum over the meshes
``Σ_e k̄_e g_e g_eᵀ`` (eq. 17 per mesh); with one mesh every function performs the very
same floating-point operations as the one-mesh formula ``k̄ G Gᵀ``.

Rigid-body modes: a coupled mode whose eigenvalue ω² is below
``RIGID_TOL · max|ω²|`` is treated as rigid: its ω is set to exactly 0, so the
modal damping (eq. 18) gives it no damping (``2 ξ ω = 0``: a rigid motion has
no restoring force to scale a viscous term from), and its mesh energy (eq. 31,
0/0) is set to 0 (a rigid mode of the coupled system does not strain the mesh).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

log = logging.getLogger(__name__)

#: ω² below this fraction of the largest |ω²| counts as a rigid-body mode.
RIGID_TOL = 1e-9


def _check_square(name: str, A: np.ndarray) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"{name}.shape = {A.shape}: must be square (n_r, n_r)")
    if not np.all(np.isfinite(A)):
        raise ValueError(f"{name}: contains non-finite entries")
    return A


def _check_g(G, n_r: int) -> np.ndarray:
    """``G`` as ``(n_r, E)`` floats, one column per mesh (a 1-D ``G`` is one mesh)."""
    G = np.asarray(G, dtype=float)
    shape = G.shape
    if G.ndim == 1:
        G = G.reshape(-1, 1)
    if G.ndim != 2 or G.shape[0] != n_r or G.shape[1] < 1:
        raise ValueError(f"G.shape = {shape}: must be (n_r,) or (n_r, n_meshes) with "
                         f"n_r = {n_r}")
    if not np.all(np.isfinite(G)):
        raise ValueError("G: contains non-finite entries")
    return G


def _check_km(km_mean, n_meshes: int) -> np.ndarray:
    """One mean mesh stiffness per mesh, ``(n_meshes,)`` (a scalar is shared)."""
    km = np.asarray(km_mean, dtype=float)
    if km.ndim == 0:
        km = np.full(n_meshes, float(km))
    if km.shape != (n_meshes,):
        raise ValueError(f"km_mean = {km_mean}: must be a number or {n_meshes} numbers, one "
                         "per mesh [N/m]")
    if not np.all(np.isfinite(km) & (km >= 0)):
        raise ValueError(f"km_mean = {km_mean}: must be a finite number >= 0 [N/m]")
    return km


def direction(G: np.ndarray, mesh: int) -> np.ndarray:
    """Column ``mesh`` of a checked ``(n_r, E)`` ``G`` as a contiguous vector (the same
    memory layout as a one-mesh 1-D G, so the same BLAS kernels run on it)."""
    return np.ascontiguousarray(G[:, mesh])


def couple(K_r: np.ndarray, G, km_mean) -> np.ndarray:
    """Coupled stiffness ``K_r + Σ_e k̄_e g_e g_eᵀ`` (eq. 17, one term per mesh) [N/m].

    Parameters
    ----------
    K_r : ndarray (n_r, n_r)
        Reduced stiffness without gear coupling.
    G : array (n_r,) or (n_r, E)
        Projection vector of each mesh (eq. 11), zero past the gear DOF.
    km_mean : float or array (E,)
        Mean mesh stiffness k̄_e of each mesh [N/m], >= 0.
    """
    K_r = _check_square("K_r", K_r)
    G = _check_g(G, K_r.shape[0])
    km = _check_km(km_mean, G.shape[1])
    Kc = K_r
    for e in range(G.shape[1]):
        g = direction(G, e)
        Kc = Kc + km[e] * np.outer(g, g)
    return Kc


@dataclass
class CoupledModes:
    """Modes of the coupled reduced model (eq. 17).

    Attributes
    ----------
    omega2 : ndarray (n_r,)
        Eigenvalues ω² [rad²/s²], ascending, rigid ones set to exactly 0.
    phi : ndarray (n_r, n_r)
        Mass-normalised eigenvectors (columns), ``φᵀ M_r φ = I``.
    rigid : ndarray of bool (n_r,)
        Modes treated as rigid.
    """

    omega2: np.ndarray
    phi: np.ndarray
    rigid: np.ndarray

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Natural frequencies [Hz]."""
        return np.sqrt(self.omega2) / (2.0 * math.pi)


def coupled_modes(M_r: np.ndarray, K_r: np.ndarray, G, km_mean) -> CoupledModes:
    """Solve eq. (17): ``(K_r + Σ_e k̄_e g_e g_eᵀ − ω² M_r) φ = 0`` with mass-normalised
    φ (``G``, ``km_mean`` as in :func:`couple`)."""
    M_r = _check_square("M_r", M_r)
    Kc = couple(K_r, G, km_mean)
    if M_r.shape != Kc.shape:
        raise ValueError(f"M_r.shape = {M_r.shape}: must equal K_r.shape = {Kc.shape}")
    lam, phi = sla.eigh(Kc, M_r)  # eigh normalises φᵀ M_r φ = I
    scale = max(np.abs(lam).max(), np.finfo(float).tiny)
    rigid = lam < RIGID_TOL * scale
    if np.any(lam[rigid] < -1e-6 * scale):
        raise ValueError(
            f"K_r + Σ km g gᵀ has a negative eigenvalue {lam.min():.3e}: must be positive "
            "semi-definite"
        )
    lam = np.where(rigid, 0.0, lam)
    if rigid.any():
        log.info("coupled ROM: %d rigid-body mode(s) (ω set to 0)", int(rigid.sum()))
    return CoupledModes(lam, phi, rigid)


def check_xi(xi, n_r: int) -> np.ndarray:
    """Modal damping ratios ξ (dimensionless, in [0, 1)) as an array of ``n_r``: a scalar
    broadcast, or one per coupled mode; refused otherwise, naming ``xi``."""
    xi_arr = np.broadcast_to(np.asarray(xi, dtype=float), (n_r,)) if np.ndim(xi) == 0 else (
        np.asarray(xi, dtype=float)
    )
    if xi_arr.shape != (n_r,):
        raise ValueError(f"xi.shape = {np.shape(xi)}: must be scalar or ({n_r},)")
    if not np.all(np.isfinite(xi_arr)) or np.any(xi_arr < 0) or np.any(xi_arr >= 1):
        raise ValueError(f"xi = {xi}: every ratio must lie in [0, 1)")
    return xi_arr


def modal_damping(M_r: np.ndarray, K_r: np.ndarray, G, km_mean, xi=0.05) -> np.ndarray:
    """Modal damping matrix of the coupled ROM (eq. 17–19) [N·s/m].

    ``C_r = M_r Φ_r diag(2 ξ_j ω_j) Φ_rᵀ M_r`` with Φ_r the mass-normalised
    modes of eq. (17); rigid modes (ω = 0) get no damping.

    Parameters
    ----------
    M_r, K_r : ndarray (n_r, n_r)
        Reduced mass and (uncoupled) stiffness.
    G : array (n_r,) or (n_r, E)
        Projection vector of each mesh (eq. 11).
    km_mean : float or array (E,)
        Mean mesh stiffness of each mesh [N/m].
    xi : float or array (n_r,)
        Damping ratio per coupled mode (ascending frequency order), in [0, 1).
    """
    modes = coupled_modes(M_r, K_r, G, km_mean)
    xi_arr = check_xi(xi, modes.omega2.size)
    c_modal = 2.0 * xi_arr * np.sqrt(modes.omega2)  # eq. (18)
    A = M_r @ modes.phi
    C = (A * c_modal) @ A.T  # eq. (19)
    return 0.5 * (C + C.T)


def mesh_energy(M_r: np.ndarray, K_r: np.ndarray, G, km_mean) -> np.ndarray:
    """Mesh energy ρ_j of every coupled mode (eq. 31), in [0, 1].

    ``ρ_j = Σ_e k̄_e (g_eᵀφ_j)² / φ_jᵀ (K_r + Σ_e k̄_e g_e g_eᵀ) φ_j``: the share of the
    mode's strain energy stored in all the meshes; 0 for rigid modes. Ordered like the
    coupled frequencies (ascending).
    """
    modes = coupled_modes(M_r, K_r, G, km_mean)
    return mesh_energy_of(modes, K_r, G, km_mean)


def dynamic_factor(M_r: np.ndarray, K_r: np.ndarray, G, km_mean,
                   f_hz: np.ndarray, xi=0.05, mesh: int = 0) -> np.ndarray:
    """Linear dynamic factor D(f) of one mesh (docs/theory.md T.32), dimensionless.

    ``D = |k̄ gᵀ (K_r + Σ_e k̄_e g_e g_eᵀ − ω² M_r + iω C_r)⁻¹ g − 1|``, ω = 2πf, g and
    k̄ those of mesh ``mesh``: the dynamic mesh force per unit TE excitation ``k̄ e`` of
    the linear system (every mesh coupled), ``C_r`` the modal damping of eq. (18–19)
    with ratio ``xi``. Its peak is the resonance the TE excites; how far the peak moves
    when k̄ is halved says how much stiffness the mesh supplies (T.33).

    Parameters
    ----------
    M_r, K_r, G, km_mean
        As for :func:`modal_damping` (SI).
    f_hz : array
        Frequencies [Hz].
    xi : float or array (n_r,)
        Modal damping ratio.
    mesh : int
        Column of ``G`` whose factor is computed.
    """
    G = _check_g(G, _check_square("K_r", K_r).shape[0])
    km = _check_km(km_mean, G.shape[1])
    if not 0 <= mesh < G.shape[1]:
        raise ValueError(f"mesh = {mesh}: must be in [0, {G.shape[1] - 1}]")
    g, k = direction(G, mesh), float(km[mesh])
    C = modal_damping(M_r, K_r, G, km, xi)
    Kc = couple(K_r, G, km)
    out = np.empty(np.size(f_hz))
    for i, f in enumerate(np.asarray(f_hz, dtype=float).ravel()):
        w = 2.0 * np.pi * f
        x = np.linalg.solve(Kc - w * w * M_r + 1j * w * C, g)
        out[i] = abs(k * (g @ x) - 1.0)                                   # (T.32)
    return out


def mesh_softening(M_r: np.ndarray, K_r: np.ndarray, G, km_mean,
                   xi=0.05, points: int = 1201, f_min: float = 0.0,
                   mesh: int = 0) -> tuple[float, float]:
    """Peak of the dynamic factor and its shift when k̄ is halved (T.33).

    Returns ``(f_peak [Hz], f_half / f_peak)``: the frequency of the largest D(f) of mesh
    ``mesh`` (:func:`dynamic_factor`) near the mode with most mesh energy (eq. 31) among
    those at or above ``f_min`` [Hz], searched on ``points`` frequencies from 0.25 to 1.75
    times that mode's, and the ratio of the peak with every ``k̄`` halved to it. A single
    mode of mesh energy ρ gives ``√(1 − ρ/2)``: 0.92 for ρ = 0.32, 0.75 for ρ = 0.87.
    """
    modes = coupled_modes(M_r, K_r, G, km_mean)
    rho = mesh_energy_of(modes, K_r, G, km_mean)
    rho = np.where(modes.frequencies_hz >= f_min, rho, 0.0)
    f_top = float(modes.frequencies_hz[int(np.argmax(rho))])
    if not f_top > 0.0:
        raise ValueError("mesh_softening: no mode with mesh energy")
    grid = np.linspace(0.25 * f_top, 1.75 * f_top, points)
    f_peak = grid[int(np.argmax(dynamic_factor(M_r, K_r, G, km_mean, grid, xi, mesh)))]
    half = 0.5 * np.asarray(km_mean, dtype=float)
    f_half = grid[int(np.argmax(dynamic_factor(M_r, K_r, G, half, grid, xi, mesh)))]
    return float(f_peak), float(f_half / f_peak)


def mesh_energy_of(modes: CoupledModes, K_r, G, km_mean) -> np.ndarray:
    """Share ρ_j of each coupled mode's strain energy stored in the meshes (in [0, 1], 0
    for rigid-body modes), from already computed ``modes`` (K_r in N/m, G in m per unit
    DOF, km_mean in N/m, one per mesh or shared)."""
    G = _check_g(G, modes.phi.shape[0])
    km = _check_km(km_mean, G.shape[1])
    num = km[0] * (direction(G, 0) @ modes.phi) ** 2
    for e in range(1, G.shape[1]):
        num = num + km[e] * (direction(G, e) @ modes.phi) ** 2
    den = np.einsum("ij,ij->j", modes.phi, couple(K_r, G, km) @ modes.phi)
    rho = np.zeros_like(num)
    ok = ~modes.rigid
    rho[ok] = num[ok] / den[ok]
    return np.clip(rho, 0.0, 1.0)


@dataclass
class Campbell:
    """Campbell-diagram data (Fig. 8).

    Attributes
    ----------
    rpm : ndarray (n_rpm,)
        Speed grid [rpm].
    orders : ndarray (n_orders,)
        Excitation orders (multiples of the shaft speed, e.g. Z, 2Z, 3Z, 2, 4).
    order_hz : ndarray (n_orders, n_rpm)
        Excitation frequency ``order · rpm / 60`` [Hz].
    frequencies_hz, mesh_energy : ndarray (n_modes,)
        Horizontal lines: mode frequency [Hz] and its mesh energy.
    crossings : ndarray (n_cross, 5)
        Rows ``(mode index, order, rpm, frequency_hz, mesh_energy)`` where
        ``order · rpm / 60 = f_j`` inside the speed range.
    """

    rpm: np.ndarray
    orders: np.ndarray
    order_hz: np.ndarray
    frequencies_hz: np.ndarray
    mesh_energy: np.ndarray
    crossings: np.ndarray


def campbell(
    frequencies_hz, mesh_energy, rpm_range, orders, n_rpm: int = 200
) -> Campbell:
    """Campbell-diagram data: each mode against each excitation order (Fig. 8).

    Parameters
    ----------
    frequencies_hz : array (n_modes,)
        Coupled mode frequencies [Hz], >= 0.
    mesh_energy : array (n_modes,)
        Mesh energy of each mode, in [0, 1].
    rpm_range : (float, float)
        Speed range [rpm], 0 <= lo < hi.
    orders : sequence of float
        Excitation orders, > 0 (H_Z = Z, H_2Z = 2Z, ...).
    n_rpm : int
        Points of the speed grid, >= 2.
    """
    f = np.asarray(frequencies_hz, dtype=float).ravel()
    rho = np.asarray(mesh_energy, dtype=float).ravel()
    if f.shape != rho.shape:
        raise ValueError(f"mesh_energy.shape = {rho.shape}: must equal frequencies {f.shape}")
    if np.any(~np.isfinite(f)) or np.any(f < 0):
        raise ValueError("frequencies_hz: must be finite and >= 0")
    if np.any(rho < 0) or np.any(rho > 1):
        raise ValueError("mesh_energy: must lie in [0, 1]")
    lo, hi = (float(v) for v in rpm_range)
    if not (0 <= lo < hi and math.isfinite(hi)):
        raise ValueError(f"rpm_range = {rpm_range}: must satisfy 0 <= lo < hi < inf")
    o = np.asarray(orders, dtype=float).ravel()
    if o.size == 0 or np.any(~(o > 0)) or np.any(~np.isfinite(o)):
        raise ValueError(f"orders = {orders}: must be a non-empty list of numbers > 0")
    if int(n_rpm) < 2:
        raise ValueError(f"n_rpm = {n_rpm}: must be >= 2")
    rpm = np.linspace(lo, hi, int(n_rpm))
    rows = []
    for j, fj in enumerate(f):
        for ok in o:
            r = 60.0 * fj / ok  # order · rpm / 60 = f_j
            if lo <= r <= hi and fj > 0:
                rows.append((j, ok, r, fj, rho[j]))
    cross = np.array(rows, dtype=float).reshape(-1, 5)
    return Campbell(rpm, o, np.outer(o, rpm) / 60.0, f, rho, cross)
