"""Validation of a ROM against the full FE model, both coupled by k̄_m (Fig. 9)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from fem.eigen import shift_invert_eps

log = logging.getLogger(__name__)

#: Modes compared beyond those of the ROM below the check frequency (:func:`validate_to`).
CHECK_MARGIN = 2


@dataclass
class Validation:
    """Coupled eigenfrequencies of the full model and of the ROM (Fig. 9).

    Attributes
    ----------
    full_hz, rom_hz : ndarray (n_check,)
        Lowest coupled frequencies (eq. 17 and its full-model counterpart) [Hz].
    relative_error : ndarray (n_check,)
        ``|f_rom − f_full| / max(f_full, f_1)``, ``f_1`` the first non-zero full
        frequency (so rigid modes, f = 0, get a finite error).
    validity_hz : float
        Largest ``f_full[k]`` such that modes ``0..k`` all have an error below
        ``tol``; 0 if the first mode fails. When every checked mode passes it is
        the last checked frequency (a lower bound of the true validity).
    tol : float
        Relative tolerance used.
    """

    full_hz: np.ndarray
    rom_hz: np.ndarray
    relative_error: np.ndarray
    validity_hz: float
    tol: float


def mesh_coupling_block(G, km_mean) -> np.ndarray:
    """The dense ``Σ_e k̄_e g_e g_eᵀ`` on the gear DOF (n_c × n_c), ``G`` (n_c,) or
    (n_c, E) (one column per mesh) and ``km_mean`` a number or one per mesh [N/m]; with one
    mesh exactly ``k̄ G Gᵀ``."""
    G = np.asarray(G, dtype=float)
    G = G.reshape(-1, 1) if G.ndim == 1 else G
    km = np.asarray(km_mean, dtype=float)
    km = np.full(G.shape[1], float(km)) if km.ndim == 0 else km
    if G.ndim != 2 or km.shape != (G.shape[1],):
        raise ValueError(f"G.shape = {G.shape}, km_mean = {km_mean}: G must be (n_c,) or "
                         "(n_c, n_meshes) and km_mean a number or one per mesh")
    block = km[0] * np.outer(G[:, 0], G[:, 0])
    for e in range(1, G.shape[1]):
        block = block + km[e] * np.outer(G[:, e], G[:, e])
    return block


def add_mesh_coupling(K: PETSc.Mat, gear_dofs, G, km_mean) -> PETSc.Mat:
    """Return ``K + Σ_e k̄_e g_e g_eᵀ``, g_e = column e of G scattered on the gear DOF
    (one dense n_c × n_c block, :func:`mesh_coupling_block`)."""
    dofs = np.asarray(gear_dofs, dtype=PETSc.IntType)
    block = mesh_coupling_block(G, km_mean)
    if block.shape != (dofs.size, dofs.size):
        raise ValueError(f"G has {block.shape[0]} rows: must equal len(gear_dofs) = "
                         f"{dofs.size}")
    A = PETSc.Mat().createAIJ(K.getSizes(), comm=K.getComm())
    A.setPreallocationNNZ(dofs.size)
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    if K.getComm().getRank() == 0:
        A.setValues(dofs, dofs, block.ravel(), addv=True)
    A.assemble()
    Kc = K.copy()
    Kc.axpy(1.0, A, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    A.destroy()
    return Kc


def full_coupled_frequencies(
    M: PETSc.Mat, Kc: PETSc.Mat, n: int, shift: float, tol: float = 1e-10
) -> np.ndarray:
    """Lowest ``n`` frequencies [Hz] of ``(Kc, M)`` by SLEPc shift-invert at ``shift``."""
    eps = shift_invert_eps(Kc, M, shift, tol, 500)
    eps.setOptionsPrefix("validate_")
    # Slack beyond n: a Krylov space from one start vector can miss a copy of
    # an exactly repeated eigenvalue (rigid modes); extra wanted pairs prevent it.
    n_full = Kc.getSize()[0]
    eps.setDimensions(min(n + max(6, n // 5), n_full - 1))
    eps.setFromOptions()
    eps.solve()
    nconv = eps.getConverged()
    if nconv < n:
        raise RuntimeError(f"full-model eigensolve converged {nconv} of {n} modes")
    lam = np.sort([eps.getEigenvalue(j).real for j in range(nconv)])[:n]
    eps.destroy()
    scale = max(abs(lam).max(), np.finfo(float).tiny)
    lam = np.where(lam < 1e-9 * scale, 0.0, lam)
    return np.sqrt(lam) / (2.0 * math.pi)


def compare(full_hz, rom_hz, tol: float) -> Validation:
    """Relative error per mode and validity frequency (Fig. 9)."""
    full_hz = np.asarray(full_hz, dtype=float)
    rom_hz = np.asarray(rom_hz, dtype=float)
    elastic = full_hz[full_hz > 0]
    f1 = elastic[0] if elastic.size else 1.0
    err = np.abs(rom_hz - full_hz) / np.maximum(full_hz, f1)
    bad = np.flatnonzero(err >= tol)
    k = bad[0] if bad.size else full_hz.size
    validity = float(full_hz[k - 1]) if k > 0 else 0.0
    return Validation(full_hz, rom_hz, err, validity, float(tol))


def validate_rom(
    rom,
    M: PETSc.Mat,
    K: PETSc.Mat,
    gear_dofs,
    G,
    km_mean,
    n_check: int,
    tol: float = 1e-3,
) -> Validation:
    """Compare the coupled frequencies of a ROM with the full model's (Fig. 9).

    The full model gets the same coupling as eq. (17): ``K + Σ_e k̄_e g_e g_eᵀ`` with
    g_e the column of G of mesh e on the gear DOF (:func:`add_mesh_coupling`); its lowest
    ``n_check`` modes are computed by SLEPc shift-invert at a negative shift
    ``−0.1 ω²`` (ω the first non-zero ROM frequency, an upper bound of the
    full model's), which keeps the factorised matrix positive definite even
    with rigid-body modes.

    Parameters
    ----------
    rom : ROM
        Reduced model (its ``frequencies_hz`` are compared).
    M, K : PETSc.Mat
        Full mass [kg] and stiffness [N/m] (uncoupled).
    gear_dofs : array of int (n_c,)
        Global indices of the gear DOF (6 per gear body), in the order of ``G``'s rows.
    G : array (n_c,) or (n_c, E)
        Projection vector of each mesh on the gear DOF (eq. 11).
    km_mean : float or array (E,)
        Mean mesh stiffness [N/m], shared or one per mesh.
    n_check : int
        Number of lowest modes compared, in [1, n_r].
    tol : float
        Relative tolerance defining the validity frequency, in (0, 1).
    """
    n_r = rom.frequencies_hz.size
    if int(n_check) != n_check or not 1 <= n_check <= n_r:
        raise ValueError(f"n_check = {n_check}: must be an integer in [1, {n_r}]")
    if not 0 < tol < 1:
        raise ValueError(f"tol = {tol}: must lie in (0, 1)")
    if not np.all(np.isfinite(km_mean) & (np.asarray(km_mean) >= 0)):
        raise ValueError(f"km_mean = {km_mean}: must be a finite number >= 0 [N/m]")
    f_el = rom.frequencies_hz[rom.frequencies_hz > 0]
    shift = -0.1 * (2.0 * math.pi * f_el[0]) ** 2 if f_el.size else -1.0
    Kc = add_mesh_coupling(K, gear_dofs, G, km_mean)
    full = full_coupled_frequencies(M, Kc, int(n_check), shift)
    Kc.destroy()
    v = compare(full, rom.frequencies_hz[: int(n_check)], tol)
    log.info(
        "ROM validation: %d modes, max relative error %.2e, valid to %.6g Hz (tol %g)",
        n_check, v.relative_error.max(), v.validity_hz, tol,
    )
    return v


def modes_to_check(rom_hz, f_check: float, margin: int = CHECK_MARGIN) -> int:
    """How many of the lowest coupled modes a check up to ``f_check`` [Hz] compares: the
    ROM's modes at or below it plus ``margin`` (at most all of them).

    The k-th ROM frequency bounds the full model's k-th from above (Rayleigh–Ritz: the
    ROM is a Galerkin projection), so the full model has at least as many modes below
    ``f_check``; ``margin`` covers the ones the ROM puts just above it.
    """
    f = np.sort(np.asarray(rom_hz, dtype=float))
    if not (math.isfinite(f_check) and f_check > 0):
        raise ValueError(f"f_check = {f_check}: must be a finite number > 0 [Hz]")
    if int(margin) != margin or margin < 1:
        raise ValueError(f"margin = {margin}: must be an integer >= 1")
    return int(min(np.count_nonzero(f <= f_check) + margin, f.size))


def validate_to(rom, M: PETSc.Mat, K: PETSc.Mat, gear_dofs, G, km_mean, f_check: float,
                tol: float = 1e-3) -> Validation:
    """:func:`validate_rom` of every coupled mode up to ``f_check`` [Hz].

    Compares :func:`modes_to_check` modes; when they all pass and the last full-model
    frequency is still below ``f_check`` (the full model has more modes there than the
    ROM puts below it), compares twice as many beyond the ROM's count, up to all ``n_r``.
    The result's ``validity_hz`` reaches ``f_check`` exactly when every full-model mode
    up to it is matched within ``tol``.
    """
    n_r = rom.frequencies_hz.size
    margin = CHECK_MARGIN
    while True:
        n = modes_to_check(rom.frequencies_hz, f_check, margin)
        v = validate_rom(rom, M, K, gear_dofs, G, km_mean, n, tol)
        if v.validity_hz < v.full_hz[-1] or v.full_hz[-1] >= f_check or n >= n_r:
            return v
        margin *= 2
        log.info("ROM check: %d modes end at %.6g Hz below %.6g Hz; comparing more",
                 n, v.full_hz[-1], f_check)
