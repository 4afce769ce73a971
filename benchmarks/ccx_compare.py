"""CalculiX ``*FREQUENCY`` against the project's eigen-solve on one live gmsh tet10 mesh:
the same mesh, materials, clamps and number of modes, time and peak memory of each.

Used by ``bench_reduction`` (clamped box) and ``bench_scale`` (the pump at the scaling
sizes, ``--calculix``). CalculiX runs as a child process (``fem.calculix``, one thread);
its peak memory is the children's ``ru_maxrss`` of this process, so call
:func:`compare` at most once per process when that figure matters. The project side
is the Craig–Bampton eigen-solve (``reduction.craig_bampton._make_eps``: SLEPc
Krylov–Schur, shift-invert at 0, MUMPS LU) of the model ``fem.build_model`` makes of
the same mesh with the same clamps (quadrature degree 2, CalculiX's C3D10 rule); its
memory is the peak resident memory above the level before the FE model was built.
"""
from __future__ import annotations

import logging
import math
import resource
import statistics
import time

import numpy as np

from benchmarks.common import reset_peak, status_kib

log = logging.getLogger(__name__)


def _cpu(who: int) -> float:
    ru = resource.getrusage(who)
    return ru.ru_utime + ru.ru_stime


def slepc_frequencies(K, M, n_modes: int, factor: str = "lu") -> np.ndarray:
    """Lowest ``n_modes`` frequencies [Hz] with the reduction's eigen-solver settings."""
    from reduction.craig_bampton import _make_eps

    eps = _make_eps(K, M, 1e-10, factor)
    eps.setDimensions(n_modes)
    eps.solve()
    if eps.getConverged() < n_modes:
        raise RuntimeError(f"SLEPc converged {eps.getConverged()} of {n_modes} modes")
    lam = np.sort([eps.getEigenvalue(j).real for j in range(eps.getConverged())])[:n_modes]
    eps.destroy()
    return np.sqrt(lam) / (2 * math.pi)


def compare(materials: dict, clamps: list[str], n_modes: int, repeats: int = 1,
            scipy_eigsh: bool = False, factors: tuple[str, ...] = ("lu",)) -> dict:
    """CalculiX and the project on the live gmsh model (tet10, physical groups named);
    finalises nothing: the caller owns the gmsh session, which this function needs only
    until the mesh is loaded into DOLFINx.

    Parameters
    ----------
    materials : dict[str, fem.Material]
        Volume group -> material.
    clamps : list of str
        Surface groups fixed in x, y, z.
    n_modes : int
        Modes of both solvers.
    repeats : int
        Runs of each solver (median time).
    scipy_eigsh : bool
        Also time ``scipy.sparse.linalg.eigsh`` (shift-invert at 0) on the same matrices.
    factors : tuple of str
        MUMPS factorisations of the project's eigen-solve (``"lu"``, ``"cholesky"``); the
        first gives the ``slepc_*`` figures, each one ``by_factor[name]``.

    Returns
    -------
    dict
        ``n_dof``, ``n_modes``, ``slepc_s``, ``ccx_s`` (deck writing + ccx process),
        their CPU times ``slepc_cpu_s``, ``ccx_cpu_s`` (the ccx process only),
        ``ccx_over_slepc``, ``max_rel_freq_diff_ccx``, ``ccx_peak_rss_mib``,
        ``slepc_peak_extra_rss_mib`` (model assembly + eigen-solve), ``model_rss_mib``
        (resident memory of the FE model), ``by_factor`` (per factorisation: time, CPU
        time, peak memory above the model (first factorisation only), frequency
        difference from CalculiX), optionally
        ``eigsh_s`` and ``eigsh_over_slepc``.
    """
    import gmsh

    import fem
    from fem import calculix

    groups = fem.gmsh_physical_groups(gmsh.model)
    t_ccx, cpu_ccx = [], []
    for _ in range(repeats):
        c0 = _cpu(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        f_ccx = calculix.run_frequency(gmsh.model, materials, groups, clamps, n_modes,
                                       timeout=3600.0)
        t_ccx.append(time.perf_counter() - t0)
        cpu_ccx.append(_cpu(resource.RUSAGE_CHILDREN) - c0)
    ccx_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    fe_mesh = fem.load_gmsh_mesh(gmsh.model)
    reset = reset_peak()
    base = status_kib("VmRSS")
    spec = fem.ModelSpec()
    for c in clamps:
        spec.add_clamp(c)
    m = fem.build_model(fe_mesh, materials, spec, quadrature_degree=2)
    n = int(m.K.getSize()[0])
    model_rss = (status_kib("VmRSS") - base) / 1024.0
    by_factor = {}
    for factor in factors:
        # only the first solve's peak is its own: the allocator keeps what an earlier
        # solve freed, so a later one grows into it (measured: +14 MiB after LU)
        first = not by_factor
        base_f = status_kib("VmRSS")
        t_slepc, cpu_slepc = [], []
        for _ in range(repeats):
            c0 = time.process_time()
            t0 = time.perf_counter()
            f = slepc_frequencies(m.K, m.M, n_modes, factor)
            t_slepc.append(time.perf_counter() - t0)
            cpu_slepc.append(time.process_time() - c0)
        by_factor[factor] = {
            "s": statistics.median(t_slepc), "cpu_s": statistics.median(cpu_slepc),
            "peak_extra_rss_mib": ((status_kib("VmHWM") - base_f) / 1024.0
                                   if reset and first else None),
            "max_rel_freq_diff_ccx": float(np.max(np.abs(f / f_ccx - 1)))}
        if factor == factors[0]:
            f_first = f
    first = by_factor[factors[0]]
    peak_extra = (model_rss + first["peak_extra_rss_mib"]
                  if first["peak_extra_rss_mib"] is not None else None)
    ts, tc = first["s"], statistics.median(t_ccx)
    rec = {"n_dof": n, "n_modes": n_modes, "repeats": repeats, "slepc_s": ts, "ccx_s": tc,
           "ccx_over_slepc": tc / ts, "slepc_cpu_s": first["cpu_s"],
           "ccx_cpu_s": statistics.median(cpu_ccx),
           "max_rel_freq_diff_ccx": first["max_rel_freq_diff_ccx"],
           "highest_hz": float(f_first[-1]), "ccx_peak_rss_mib": ccx_peak,
           "slepc_peak_extra_rss_mib": peak_extra, "model_rss_mib": model_rss,
           "by_factor": by_factor,
           "note": "ccx time includes writing the deck and the ccx process (1 thread)"}
    if scipy_eigsh:
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla

        mats = []
        for A in (m.K, m.M):
            ia, ja, a = A.getValuesCSR()
            mats.append(sp.csr_matrix((a.copy(), ja.copy(), ia.copy()), shape=A.getSize()))
        t_eigsh = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            spla.eigsh(mats[0], k=n_modes, M=mats[1], sigma=0.0, which="LM", tol=1e-10,
                       return_eigenvectors=False)
            t_eigsh.append(time.perf_counter() - t0)
        rec["eigsh_s"] = statistics.median(t_eigsh)
        rec["eigsh_over_slepc"] = rec["eigsh_s"] / ts
    log.info("ccx n=%d n_modes=%d: slepc %.3f s (+%s MiB), ccx %.3f s (%.0f MiB), "
             "max rel. diff %.1e", n, n_modes, ts, peak_extra, tc, ccx_peak,
             rec["max_rel_freq_diff_ccx"])
    return rec
