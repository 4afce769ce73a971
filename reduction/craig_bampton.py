"""Craig–Bampton reduction on PETSc/SLEPc with one factorisation of K_ii (eq. 5–9).

The reduced coordinates are ordered ``q = (q_c, η)``: the ``n_c`` interface
(gear) DOF first, in the order given by ``interface_dofs``, then the ``n_CM``
fixed-interface modal amplitudes (docs/architecture.md). The basis

    T = [[Ψ, Φ],      rows of the interior DOF
         [I, 0]]      rows of the interface DOF           # eq. (8), columns swapped

is kept as a distributed dense PETSc matrix with the row layout of ``M``/``K``;
it is never gathered on one process. ``M_r = Tᵀ M T`` and ``K_r = Tᵀ K T`` are
small dense NumPy arrays, identical on every rank.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np
from petsc4py import PETSc
from slepc4py import SLEPc

from fem.dense import dense_projection
from fem.eigen import shift_invert_eps
from reduction.interface import interface_columns, interface_eliminated

log = logging.getLogger(__name__)

#: Relative residual above which the static-mode solve is declared failed.
PSI_RESIDUAL_TOL = 1e-8
#: Most refinement steps of the static modes with an approximate (BLR) factor.
PSI_REFINE_STEPS = 10
#: Factorisations of K_ii for the shift-invert (``factor`` of :func:`craig_bampton`).
FACTORS = ("lu", "cholesky")


@dataclass
class CBResult:
    """Output of :func:`craig_bampton`.

    Attributes
    ----------
    T : PETSc.Mat
        Distributed dense basis, ``n × n_r``, same row layout as ``M``; columns
        ``(q_c, η)``.
    M_r, K_r : ndarray (n_r, n_r)
        Reduced mass [kg-like] and stiffness [N/m-like] matrices, symmetric,
        identical on all ranks.
    interface_dofs : ndarray of int
        Global indices of the interface DOF, in the column order of ``T``.
    n_cm : int
        Number of fixed-interface modes kept.
    fixed_interface_hz : ndarray (n_cm,)
        Frequencies of the kept fixed-interface modes (eq. 6) [Hz].
    psi_residual : float
        ``‖K_ii Ψ + K_ic‖_F / ‖K_ic‖_F`` of the static modes (eq. 7).
    timings : dict
        Wall time of each phase [s] (``eigensolve``, ``eigenvectors`` (mass-normalised
        into T), ``static_modes``, ``projection``, ``total``), maxima over ranks.
    factor_stats : dict
        MUMPS figures of the factorisation of ``K_ii``: ``entries`` (INFOG(29), entries
        of the factors, sum over ranks; with BLR the compressed count), ``memory_mib_max_rank``
        and ``memory_mib_total`` (INFOG(21), INFOG(22): memory used during the
        factorisation, MB as MUMPS reports it).
    """

    T: PETSc.Mat
    M_r: np.ndarray
    K_r: np.ndarray
    interface_dofs: np.ndarray
    n_cm: int
    fixed_interface_hz: np.ndarray
    psi_residual: float
    timings: dict = field(default_factory=dict)
    factor_stats: dict = field(default_factory=dict)

    @property
    def n_r(self) -> int:
        """Number of reduced coordinates ``n_c + n_CM``."""
        return self.M_r.shape[0]


def cutoff_from_speed(
    rpm_max: float, n_teeth: int, n_mesh_harmonics: int, safety: float = 1.5
) -> float:
    """Frequency cut-off for the fixed-interface modes [Hz].

    The highest mesh-harmonic frequency at top speed, ``n_mesh_harmonics · Z ·
    rpm_max / 60``, times ``safety`` (Sect. 4.1: the internal excitation sets the
    frequency range the ROM must cover).

    Parameters
    ----------
    rpm_max : float
        Top shaft speed [rpm], > 0.
    n_teeth : int
        Tooth count Z of the gear whose mesh frequency is used, >= 1.
    n_mesh_harmonics : int
        Highest mesh harmonic kept (3 for H_3Z), >= 1.
    safety : float
        Multiplier >= 1.

    Returns
    -------
    float
        Cut-off frequency [Hz].
    """
    if not (math.isfinite(rpm_max) and rpm_max > 0):
        raise ValueError(f"rpm_max = {rpm_max}: must be a finite number > 0")
    if int(n_teeth) != n_teeth or n_teeth < 1:
        raise ValueError(f"n_teeth = {n_teeth}: must be an integer >= 1")
    if int(n_mesh_harmonics) != n_mesh_harmonics or n_mesh_harmonics < 1:
        raise ValueError(f"n_mesh_harmonics = {n_mesh_harmonics}: must be an integer >= 1")
    if not (math.isfinite(safety) and safety >= 1.0):
        raise ValueError(f"safety = {safety}: must be a finite number >= 1")
    return float(safety * n_mesh_harmonics * n_teeth * rpm_max / 60.0)


def _check_inputs(M, K, interface_dofs, n_modes, f_cut_hz) -> np.ndarray:
    n, n2 = K.getSize()
    if n != n2:
        raise ValueError(f"K.size = {(n, n2)}: must be square")
    if M.getSize() != (n, n):
        raise ValueError(f"M.size = {M.getSize()}: must equal K.size {(n, n)}")
    if M.getOwnershipRange() != K.getOwnershipRange():
        raise ValueError("M and K must have the same row distribution")
    dofs = np.asarray(interface_dofs)
    if dofs.ndim != 1 or dofs.size == 0 or not np.issubdtype(dofs.dtype, np.integer):
        raise ValueError(f"interface_dofs = {interface_dofs!r}: must be a non-empty 1-D int array")
    if dofs.min() < 0 or dofs.max() >= n:
        raise ValueError(f"interface_dofs = {dofs.tolist()}: entries must lie in [0, {n - 1}]")
    if np.unique(dofs).size != dofs.size:
        raise ValueError(f"interface_dofs = {dofs.tolist()}: entries must be distinct")
    n_i = n - dofs.size
    if (n_modes is None) == (f_cut_hz is None):
        raise ValueError(
            f"n_modes = {n_modes}, f_cut_hz = {f_cut_hz}: give exactly one of the two"
        )
    if n_modes is not None and (int(n_modes) != n_modes or not 1 <= n_modes <= n_i - 1):
        raise ValueError(f"n_modes = {n_modes}: must be an integer in [1, {n_i - 1}]")
    if f_cut_hz is not None and not (math.isfinite(f_cut_hz) and f_cut_hz > 0):
        raise ValueError(f"f_cut_hz = {f_cut_hz}: must be a finite number > 0")
    return dofs.astype(np.int64)


def _make_eps(K_ii: PETSc.Mat, M_ii: PETSc.Mat, tol: float, factor: str = "cholesky",
              blr_tol: float = 0.0, out_of_core: bool = False) -> SLEPc.EPS:
    """Krylov–Schur, shift-and-invert at σ = 0, MUMPS LU (or LDLᵀ: ``factor =
    "cholesky"``) of K_ii, with block low-rank compression at ``blr_tol`` (0: full
    rank) and the factor out of core if asked; set up, i.e. factored. PETSc options with
    the prefix ``cb_`` override these."""
    eps = shift_invert_eps(K_ii, M_ii, 0.0, tol, 500)
    eps.setOptionsPrefix("cb_")
    # No purification (one more solve per eigenvector): the null space of M̃ is the
    # interface, whose entries _fill_modes zeroes (measured: basis within 2.9e-15)
    eps.setPurify(False)
    pc = eps.getST().getKSP().getPC()
    if factor == "cholesky":
        pc.setType(PETSc.PC.Type.CHOLESKY)
        pc.setFactorSolverType("mumps")
    opts = PETSc.Options()
    added = []
    want = []  # MUMPS reads its ICNTL/CNTL from the options when it factors
    if blr_tol > 0:
        want += [("cb_st_mat_mumps_icntl_35", 1), ("cb_st_mat_mumps_cntl_7", blr_tol)]
    if out_of_core:
        want.append(("cb_st_mat_mumps_icntl_22", 1))
    for key, val in want:
        if not opts.hasName(key):
            opts.setValue(key, val)
            added.append(key)
    try:
        eps.setFromOptions()
        eps.setUp()
    finally:
        for key in added:
            opts.delValue(key)
    return eps


#: Margin of the estimated mode count below a cut-off (:func:`_next_nev`).
NEV_MARGIN = 1.15


def _next_nev(lam: np.ndarray, lam_cut: float, nev: int, n_max: int) -> int:
    """Pairs to ask for when all ``lam`` (ascending, all below ``lam_cut``) are: the count
    below the cut-off extrapolated by the power law ``k ∝ f^p`` fitted to the upper half of
    the spectrum found (Weyl's law: p = 3 for a solid, 2 for a plate, 1 for a beam),
    times :data:`NEV_MARGIN`; at least ``nev + 16``, at most ``4 nev`` (an estimate from
    a few low modes can overshoot) and ``n_max``."""
    f = np.sqrt(np.maximum(lam, 0.0))
    k = np.arange(1, f.size + 1, dtype=float)
    half = slice(f.size // 2, None)
    ok = f[half] > 0
    p = 2.0
    if np.count_nonzero(ok) >= 4 and f[half][ok][-1] > f[half][ok][0]:
        p = float(np.polyfit(np.log(f[half][ok]), np.log(k[half][ok]), 1)[0])
    p = min(max(p, 1.0), 3.0)
    est = NEV_MARGIN * f.size * (math.sqrt(lam_cut) / f[-1]) ** p
    return int(min(n_max, 4 * nev, max(nev + 16, math.ceil(est))))


def _solve_modes(eps: SLEPc.EPS, n_i: int, n_modes, f_cut_hz) -> int:
    """Run the eigensolve; return how many of the converged pairs to keep."""
    if n_modes is not None:
        # a few extra pairs so that no copy of a repeated eigenvalue is missed
        eps.setDimensions(min(int(n_modes) + max(5, int(n_modes) // 10), n_i - 1))
        eps.solve()
        nconv = eps.getConverged()
        if nconv < n_modes:
            raise RuntimeError(
                f"SLEPc converged {nconv} of the {n_modes} requested fixed-interface modes"
            )
        return int(n_modes)
    lam_cut = (2.0 * math.pi * f_cut_hz) ** 2
    nev = min(16, n_i - 1)
    while True:
        eps.setDimensions(nev)
        eps.solve()  # same ST, same factorisation: only the Krylov space grows
        nconv = eps.getConverged()
        if nconv < nev:
            raise RuntimeError(f"SLEPc converged {nconv} of {nev} fixed-interface modes")
        lam = np.sort([eps.getEigenvalue(j).real for j in range(nconv)])
        n_below = int(np.count_nonzero(lam <= lam_cut))
        if n_below < nconv or nev >= n_i - 1:
            if n_below == 0:
                raise ValueError(
                    f"f_cut_hz = {f_cut_hz}: below the first fixed-interface mode "
                    f"({math.sqrt(lam.min()) / (2 * math.pi):.6g} Hz); no mode would be kept"
                )
            return n_below
        nev = _next_nev(lam, lam_cut, nev, n_i - 1)
        log.debug("cut-off %.6g Hz not reached, asking for %d modes", f_cut_hz, nev)


def craig_bampton(
    M: PETSc.Mat,
    K: PETSc.Mat,
    interface_dofs,
    n_modes: int | None = None,
    f_cut_hz: float | None = None,
    comm=None,
    eps_tol: float = 1e-12,
    factor: str = "cholesky",
    blr_tol: float = 0.0,
    out_of_core: bool = False,
) -> CBResult:
    """Craig–Bampton reduction with one MUMPS factorisation of K_ii (eq. 5–9).

    The fixed-interface modes (eq. 6) come from SLEPc Krylov–Schur with
    shift-and-invert at σ = 0, whose ST factors ``K_ii`` with MUMPS LU; the
    static constraint modes ``Ψ = −K_ii⁻¹ K_ic`` (eq. 7) reuse that factor
    (``MatMatSolve`` on the dense block of the interface columns, all at once).
    Φ is mass-normalised (``Φᵀ M_ii Φ = I``).

    Parameters
    ----------
    M, K : PETSc.Mat
        Distributed (AIJ) mass [kg] and stiffness [N/m] matrices, symmetric,
        same row layout; ``K_ii`` must be non-singular (the interface must
        restrain every rigid-body motion of the interior).
    interface_dofs : array of int
        Global indices of the retained (gear) DOF; their order is the order of
        the first ``n_c`` reduced coordinates. Same array on every rank.
    n_modes : int, optional
        Number ``n_CM`` of fixed-interface modes, in [1, n_i − 1].
    f_cut_hz : float, optional
        Keep every fixed-interface mode below this frequency [Hz] (see
        :func:`cutoff_from_speed`). Exactly one of ``n_modes``/``f_cut_hz``.
    comm : PETSc.Comm or mpi4py communicator, optional
        Only checked against the communicator of ``K``, which is the one used.
    eps_tol : float
        SLEPc relative residual tolerance of the eigenpairs.
    factor : {"cholesky", "lu"}
        MUMPS factorisation of ``K_ii``: LDLᵀ (default since branch h9-scale; ``K_ii`` is
        symmetric positive definite) or LU, the same modes to 1e-13, LDLᵀ with half the
        factor entries (docs/scale.md).
    blr_tol : float
        MUMPS block low-rank compression threshold (``CNTL(7)``), 0 = full rank. The
        shift-invert then uses an approximate factor: the eigenpairs are those of a
        perturbed K_ii (measured frequency error in docs/scale.md) and the static
        modes are refined with the exact K_ii to the usual residual.
    out_of_core : bool
        MUMPS keeps the factor on disk (``ICNTL(22) = 1``), in the folder named by the
        environment variable ``MUMPS_OOC_TMPDIR`` (MUMPS's default /tmp), and only the
        active fronts in memory: the same solves, every one reading the factor back.

    Returns
    -------
    CBResult
    """
    t_start = time.perf_counter()
    dofs = _check_inputs(M, K, interface_dofs, n_modes, f_cut_hz)
    if factor not in FACTORS:
        raise ValueError(f"factor = {factor!r}: must be one of {FACTORS}")
    if not (math.isfinite(blr_tol) and 0.0 <= blr_tol < 1e-2):
        raise ValueError(f"blr_tol = {blr_tol}: must be 0 (full rank) or in (0, 1e-2)")
    if out_of_core:
        _check_ooc_dir()
    pcomm = K.getComm()
    if comm is not None:
        size = comm.getSize() if hasattr(comm, "getSize") else comm.Get_size()
        if size != pcomm.getSize():
            raise ValueError(f"comm size = {size}: must equal that of K ({pcomm.getSize()})")
    mpi = pcomm.tompi4py()
    n = K.getSize()[0]
    n_c = dofs.size
    n_i = n - n_c
    r0, r1 = K.getOwnershipRange()
    iface_pos = dofs[(dofs >= r0) & (dofs < r1)] - r0  # owned interface rows, local
    with interface_eliminated(K, M, dofs) as saved_K:  # K̃, M̃: eq. (5) without copies
        # --- fixed-interface modes, eq. (6)
        t0 = time.perf_counter()
        eps = _make_eps(K, M, eps_tol, factor, blr_tol, out_of_core)
        n_cm = _solve_modes(eps, n_i, n_modes, f_cut_hz)
        lam, order = _kept_eigenvalues(eps, n_cm)
        fi_hz = np.sqrt(lam) / (2.0 * math.pi)
        _log_modes(n_cm, fi_hz, f_cut_hz)
        t_eig = time.perf_counter() - t0
        # --- T: local rows of the full numbering, columns (q_c, η)
        n_r = n_c + n_cm
        T = PETSc.Mat().createDense(((r1 - r0, n), (PETSc.DECIDE, n_r)), comm=pcomm)
        T.setUp()
        Tl = T.getDenseArray()
        Tl[:] = 0.0
        t0 = time.perf_counter()
        _fill_modes(eps, order, M, iface_pos, Tl[:, n_c:])
        t_vec = time.perf_counter() - t0
        # --- static constraint modes, eq. (7), from the same MUMPS factor
        t0 = time.perf_counter()
        F = eps.getST().getKSP().getPC().getFactorMatrix()
        stats = _factor_stats(F)
        B = interface_columns(K, dofs, saved_K)
        X, psi_res = _static_modes(F, K, B)
        Tl[:, :n_c] = X.getDenseArray()
        Tl[iface_pos, :] = 0.0
        for k, d in enumerate(dofs):
            if r0 <= d < r1:
                Tl[d - r0, k] = 1.0
        T.assemble()
        for obj in (X, B, F):  # F: only this reference, the factor stays with eps
            obj.destroy()
        eps.destroy()  # the factor and the Krylov basis go before the projection
        t_psi = time.perf_counter() - t0

    # --- Galerkin projection, eq. (9), with K and M restored
    t0 = time.perf_counter()
    M_r = dense_projection(M, T)
    K_r = dense_projection(K, T)
    t_proj = time.perf_counter() - t0

    timings = {
        "eigensolve": t_eig,
        "eigenvectors": t_vec,
        "static_modes": t_psi,
        "projection": t_proj,
        "total": time.perf_counter() - t_start,
    }
    timings = {k: mpi.allreduce(v, op=_max_op()) for k, v in timings.items()}
    log.info(
        "Craig-Bampton: n = %d, n_c = %d, n_r = %d, psi residual %.2e, %.3f s",
        n, n_c, n_r, psi_res, timings["total"],
    )
    return CBResult(T, M_r, K_r, dofs, n_cm, fi_hz, float(psi_res), timings, stats)


def _kept_eigenvalues(eps: SLEPc.EPS, n_cm: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n_cm`` smallest converged eigenvalues (ascending) and their indices in
    ``eps``; refuses a rigid-body motion of the interior."""
    lam = np.array([eps.getEigenvalue(j).real for j in range(eps.getConverged())])
    order = np.argsort(lam, kind="stable")[:n_cm]
    lam = lam[order]
    if lam[0] <= 1e-9 * lam[-1]:  # rigid-body motion of the interior: K_ii singular
        raise RuntimeError(
            f"fixed-interface eigenvalue {lam[0]:.3e} ~ 0 (largest kept {lam[-1]:.3e}): "
            "K_ii is singular, the interface DOF do not restrain every rigid-body motion"
        )
    return lam, order


def _log_modes(n_cm: int, fi_hz: np.ndarray, f_cut_hz) -> None:
    if f_cut_hz is not None:
        log.info(
            "Craig-Bampton: n_CM = %d fixed-interface modes below f_cut = %.6g Hz "
            "(highest kept %.6g Hz)", n_cm, f_cut_hz, fi_hz[-1],
        )
    else:
        log.info(
            "Craig-Bampton: n_CM = %d fixed-interface modes (user), up to %.6g Hz",
            n_cm, fi_hz[-1],
        )


def _fill_modes(eps: SLEPc.EPS, order: np.ndarray, M: PETSc.Mat, iface_pos: np.ndarray,
                out: np.ndarray) -> None:
    """Mass-normalised eigenvectors Φ (``Φᵀ M_ii Φ = I``, interface rows 0) into the local
    rows ``out`` (n_loc × n_cm), each with a partition-independent sign (sum >= 0)."""
    x = M.createVecRight()
    y = M.createVecLeft()
    for k, j in enumerate(order):
        eps.getEigenvector(int(j), x)
        x.getArray()[iface_pos] = 0.0  # the start vector's interface part (no purification)
        M.mult(x, y)
        mnorm = x.dot(y)
        sign = -1.0 if x.sum() < 0 else 1.0
        x.scale(sign / math.sqrt(mnorm))
        out[:, k] = x.getArray()
    x.destroy()
    y.destroy()


def _static_modes(F: PETSc.Mat, K: PETSc.Mat, B: PETSc.Mat) -> tuple[PETSc.Mat, float]:
    """Ψ = −K̃⁻¹ B (eq. 7) with the factor ``F`` of ``K̃``, refined with ``K̃`` itself when
    the factor is approximate (BLR); refuses a residual >= PSI_RESIDUAL_TOL."""
    X = B.duplicate()
    F.matSolve(B, X)
    X.scale(-1.0)  # Ψ = −K_ii⁻¹ K_ic
    nb = B.norm(PETSc.NormType.FROBENIUS)
    R, psi_res = _psi_residual(K, X, B, nb)
    steps = 0
    while not psi_res < PSI_RESIDUAL_TOL and steps < PSI_REFINE_STEPS:
        # iterative refinement with the approximate factor: X -= F⁻¹ (K_ii X + K_ic)
        D = X.duplicate()
        F.matSolve(R, D)
        X.axpy(-1.0, D)
        D.destroy()
        R.destroy()
        R, psi_res = _psi_residual(K, X, B, nb)
        steps += 1
    R.destroy()
    if steps:
        log.info("static modes: %d refinement steps (approximate factor), residual %.2e",
                 steps, psi_res)
    if not psi_res < PSI_RESIDUAL_TOL:
        raise RuntimeError(
            f"static modes: relative residual {psi_res:.3e} >= {PSI_RESIDUAL_TOL:g} "
            "(K_ii singular or ill-conditioned?)"
        )
    return X, psi_res


def _check_ooc_dir() -> None:
    """Refuse a ``MUMPS_OOC_TMPDIR`` that is not a writable folder (MUMPS would fail in
    the middle of the factorisation)."""
    import os

    d = os.environ.get("MUMPS_OOC_TMPDIR", "/tmp")
    if not (os.path.isdir(d) and os.access(d, os.W_OK | os.X_OK)):
        raise ValueError(f"MUMPS_OOC_TMPDIR = {d!r}: the out-of-core factor needs an existing, "
                         "writable folder (environment variable; default /tmp)")


def _factor_stats(F: PETSc.Mat) -> dict:
    """MUMPS's own figures of the factor ``F`` (empty for another solver)."""
    try:
        blr = F.getMumpsIcntl(35) > 0
        entries = F.getMumpsInfog(29)
        if blr:  # INFOG(35): entries of the BLR factors (negative: in millions)
            e = F.getMumpsInfog(35)
            entries = e if e >= 0 else -e * 1_000_000
        out = {"entries": int(entries), "memory_mib_max_rank": int(F.getMumpsInfog(21)),
               "memory_mib_total": int(F.getMumpsInfog(22)), "blr": bool(blr),
               "out_of_core": F.getMumpsIcntl(22) > 0}
    except (AttributeError, PETSc.Error):
        return {}
    log.info("MUMPS factor of K_ii: %.4g entries%s, %d MB max per rank, %d MB in all",
             out["entries"], " (BLR)" if blr else "", out["memory_mib_max_rank"],
             out["memory_mib_total"])
    return out


def _psi_residual(K_ii: PETSc.Mat, X: PETSc.Mat, B: PETSc.Mat, nb: float):
    """``R = K_ii X + B`` and ``‖R‖_F / ‖B‖_F`` (Ψ = X solves K_ii Ψ = −K_ic, B = K_ic)."""
    R = K_ii.matMult(X)
    R.axpy(1.0, B)
    return R, (R.norm(PETSc.NormType.FROBENIUS) / nb if nb > 0 else 0.0)


def _max_op():
    from mpi4py import MPI

    return MPI.MAX
