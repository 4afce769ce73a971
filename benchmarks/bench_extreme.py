"""Stiff and extreme cases of the HBM: each is solved and verified, or refused.

Every case builds a problem at one extreme of a parameter (mesh stiffness,
damping, backlash, static load, transmission error, speed, harmonic count, AFT
grid, ROM size, units), traces a branch or solves points, and records:

* the outcome: ``solved`` (every returned point below the tolerance, its
  uncondensed residual re-checked by :func:`hbm.full_residual`) or
  ``refused`` (a ``ValueError``/``ConvergenceError``, or a branch that stopped
  with its reason, whose message is kept);
* a reference error against an independent result: time integration from the
  HBM state (:func:`hbm.shooting_error`), the quasi-static pointwise solution,
  the dense (non-modal) condensation, a doubled harmonic count or AFT grid, or
  the same problem in SI units.

Run: ``.venv/bin/python -m benchmarks.bench_extreme [--quick]``.
Writes ``benchmarks/results/extreme.json`` (atomically).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Callable

import numpy as np

import hbm
from benchmarks.common import write_json
from hbm.examples import Geared3, synthetic_rom

log = logging.getLogger("bench_extreme")
RPM = hbm.RPM_TO_RAD_S

# ---------------------------------------------------------------- references
def max_point_shooting(pb: hbm.HBMProblem, br: hbm.Branch, method: str = "DOP853",
                       n: int = 1) -> float:
    """Shooting error at the ``n`` points of largest dynamic mesh load."""
    errs = []
    for i in np.argsort(br.element(0).mesh_load_std)[::-1][:n]:
        pt = pb.point(br.unknowns[i], br.omega[i])
        errs.append(hbm.shooting_error(pb, pt, method=method).relative)
    return float(max(errs))


# ---------------------------------------------------------------- case runner
COLUMNS = ["case", "parameter", "outcome", "points", "max residual", "full residual",
           "reference", "reference error", "cond. estimate", "wall time (s)", "reason/message"]


def _row(case, param, outcome, points, res, full, ref, ref_err, cond, seconds, msg):
    return [case, param, outcome, int(points), float(res), float(full), ref, float(ref_err),
            float(cond), round(float(seconds), 3), msg]


def branch_row(case: str, param: str, pb: hbm.HBMProblem, lo: float, hi: float,
               reference: Callable[[hbm.HBMProblem, hbm.Branch], tuple[str, float]] | None,
               **kw) -> list:
    """Trace ``lo -> hi`` rpm, re-check every point, run the reference."""
    t0 = time.perf_counter()
    try:
        br = hbm.trace(pb, lo, hi, stability=False, **kw)
    except (ValueError, hbm.ConvergenceError) as exc:
        return _row(case, param, "refused", 0, np.nan, np.nan, "-", np.nan, np.nan,
                    time.perf_counter() - t0, f"{type(exc).__name__}: {exc}")
    seconds = time.perf_counter() - t0
    if len(br) == 0:
        return _row(case, param, "refused", 0, np.nan, np.nan, "-", np.nan, np.nan, seconds,
                    f"{br.status}: {br.message}")
    full = max(hbm.full_residual(pb, pb.point(u, w)) for u, w in zip(br.unknowns, br.omega,
                                                                       strict=True))
    ref, err = reference(pb, br) if reference else ("-", np.nan)
    outcome = "solved" if br.status == "completed" else f"stopped ({br.status})"
    msg = br.message + (f"; {br.step_cuts} step cuts, {br.secant_retries} secant retries"
                        if br.step_cuts else "")
    return _row(case, param, outcome, len(br), br.residual.max(), full, ref, err,
                br.max_condition, seconds, msg)


def points_row(case: str, param: str, pb: hbm.HBMProblem, rpms,
               reference: Callable[[hbm.HBMProblem, list], tuple[str, float]] | None) -> list:
    """Newton solves at fixed speeds, re-check, reference."""
    t0 = time.perf_counter()
    try:
        pts = [pb.solve(r) for r in rpms]
    except (ValueError, hbm.ConvergenceError) as exc:
        return _row(case, param, "refused", 0, np.nan, np.nan, "-", np.nan,
                    getattr(exc, "condition", np.nan), time.perf_counter() - t0,
                    f"{type(exc).__name__}: {exc}")
    seconds = time.perf_counter() - t0
    full = max(hbm.full_residual(pb, p) for p in pts)
    ref, err = reference(pb, pts) if reference else ("-", np.nan)
    return _row(case, param, "solved", len(pts), max(p.residual for p in pts), full, ref, err,
                np.nan, seconds, f"{len(pts)} Newton solves")


def _shoot(method="DOP853", n=1):
    return lambda pb, br: (f"time integration ({method})",
                           max_point_shooting(pb, br, method, n))


# ---------------------------------------------------------------- the cases
def case_stiffness(quick: bool) -> list:
    rows = []
    for km in [1e6, 1e7, 1e8, 1e9, 1e10, 1e11]:
        mdl = Geared3(km=km)
        r = mdl.mesh_rpm()
        ratio = km / mdl.kb
        rows.append(branch_row("mesh stiffness", f"km = {km:.0e} N/m (km/kb = {ratio:.0e})",
                               mdl.problem(), 0.6 * r, 1.4 * r, _shoot()))
    for cond in ("gear", "none"):
        mdl = Geared3(km=1e11, condensation=cond)
        r = mdl.mesh_rpm()
        rows.append(branch_row(f"mesh stiffness, condensation {cond}", "km = 1e11 N/m",
                               mdl.problem(), 0.6 * r, 1.4 * r, _shoot()))
    return rows


def case_damping(quick: bool) -> list:
    rows = []
    for z in [0.001, 0.005, 0.02, 0.05, 0.2]:
        mdl = Geared3(zeta=z, te=3e-6)
        r = mdl.mesh_rpm()
        kw = {"max_step": 1.0} if z < 0.005 else {}     # |Delta| ~ 500 L: longer arcs
        rows.append(branch_row("modal damping", f"zeta = {z:g}" + (" (max_step 1)" if kw else ""),
                               mdl.problem(), 0.6 * r, 1.4 * r, _shoot(), max_points=20000, **kw))
    return rows


def case_backlash(quick: bool) -> list:
    rows = []
    for b in [1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 5e-3]:
        mdl = Geared3(b=b, te=5e-6)
        r = mdl.mesh_rpm()
        rows.append(branch_row("backlash", f"b = {b * 1e6:g} um", mdl.problem(), 0.6 * r,
                               1.4 * r, _shoot(), max_points=20000))
    return rows


def case_static_load(quick: bool) -> list:
    rows = []
    for t in [47.0, 1.0, 1e-2, 1e-4, 0.0]:
        mdl = Geared3(torque=t, te=20e-6, b=10e-6)
        r = mdl.mesh_rpm()
        rows.append(branch_row("static load (rattle, te 20 um > b 10 um)",
                               f"torque = {t:g} N m", mdl.problem(), 0.6 * r, 1.4 * r, _shoot(),
                               max_points=20000))
    return rows


def case_te(quick: bool) -> list:
    rows = []
    for te in [1e-6, 1e-5, 1e-4, 1e-3]:
        mdl = Geared3(te=te, harmonics=30)
        r = mdl.mesh_rpm()
        rows.append(branch_row("transmission error", f"te = {te * 1e6:g} um (static 10 um)",
                               mdl.problem(), 0.6 * r, 1.4 * r, _shoot(), max_points=20000))
    return rows


def case_speed(quick: bool) -> list:
    rows = []
    mdl = Geared3(te=20e-6, harmonics=60)
    pb = mdl.problem()
    r = mdl.mesh_rpm()

    def quasi(pb, pts):
        ref = hbm.quasi_static_delta(pb)
        d = pb.E @ pb.delta_real(pts[0].unknowns)
        return "quasi-static pointwise", float(np.max(np.abs(d - ref)) / np.ptp(ref))

    for rpm in [1e-6, 1e-3, 1.0]:
        rows.append(points_row("speed near zero", f"{rpm:g} rpm ({rpm / r:.1e} x resonance)",
                               pb, [rpm], quasi))
    for fac in [10.0, 100.0, 1000.0]:
        rows.append(points_row("speed at the top", f"{fac * r:.4g} rpm ({fac:g} x resonance)",
                               pb, [fac * r], lambda pb, pts: (
                                   "time integration", hbm.shooting_error(
                                       pb, pts[0]).relative)))
    rows.append(branch_row("speed range", f"{0.05 * r:.3g} -> {20 * r:.4g} rpm",
                           Geared3(te=5e-6, harmonics=30).problem(), 0.05 * r, 20 * r, _shoot(),
                           max_points=20000))
    return rows


def _impacting(harmonics: int, n_time: int | None = None) -> tuple[hbm.HBMProblem, float]:
    mdl = Geared3(te=20e-6, harmonics=harmonics, n_time=n_time)
    return mdl.problem(), 0.9 * mdl.mesh_rpm()


def case_harmonics(quick: bool) -> list:
    rows = []
    for h in [60, 100, 150, 250]:
        pb, rpm = _impacting(h)
        pb2, _ = _impacting(2 * h)

        def conv(pb, pts, pb2=pb2, rpm=rpm):
            p2 = pb2.solve(rpm, tol=1e-10)
            n2 = pb2.harmonics.n_time
            d2 = pb2.E @ pb2.delta_real(p2.unknowns)
            d1 = pb.fine_grid(n2)[0] @ pb.delta_real(pts[0].unknowns)
            conv_err = np.max(np.abs(d1 - d2)) / (0.5 * np.ptp(d2))
            shoot = hbm.shooting_error(pb, pts[0]).relative
            return f"time integration (H vs 2H: {conv_err:.1e})", float(shoot)

        rows.append(points_row("harmonic count", f"H = {h} (n_real = {2 * h + 1})", pb, [rpm],
                               conv))
    pb, rpm = _impacting(60)
    rows.append(branch_row("harmonic count, branch", "H = 60", pb, 0.8 * rpm, 1.3 * rpm,
                           _shoot()))
    return rows


def case_aft(quick: bool) -> list:
    rows = []
    base, rpm = _impacting(30)
    pt0 = base.solve(rpm)
    d0 = base.E @ base.delta_real(pt0.unknowns)
    for n in [4096, 16384, 65536]:
        pb, _ = _impacting(30, n_time=n)

        def ref(pb, pts, n=n):
            d = pb.fine_grid(base.harmonics.n_time)[0] @ pb.delta_real(pts[0].unknowns)
            return (f"default n_time = {base.harmonics.n_time} / time integration",
                    float(max(np.max(np.abs(d - d0)) / (0.5 * np.ptp(d0)),
                              hbm.shooting_error(pb, pts[0]).relative)))

        rows.append(points_row("AFT grid", f"n_time = {n} (H = 30)", pb, [rpm], ref))
    return rows


def case_rom(quick: bool) -> list:
    rows = []
    sizes = [300] if quick else [300, 500]
    for n_cm in sizes:
        for clustered in (False, True):
            label = "clustered" if clustered else "separated"
            pb = synthetic_rom(n_cm, clustered)

            def dense(pb, br):
                errs = []
                for i in np.linspace(0, len(br) - 1, 4).astype(int):
                    (h, d), _ = pb.scheme.receptance(br.omega[i])
                    h, d, g = h[0, 0], d[0], pb.directions[0]
                    z, _ = pb.dynamic_stiffness(br.omega[i])
                    f, _ = pb.forcing(br.omega[i])
                    x = np.linalg.solve(z, np.stack([np.broadcast_to(g, f.shape), f], -1))
                    hd, dd = x[..., 0] @ g, x[..., 1] @ g
                    errs.append(max(np.max(np.abs(h - hd)) / np.max(np.abs(hd)),
                                    np.max(np.abs(d - dd)) / np.max(np.abs(dd))))
                return "dense solve of h_k, d_k", float(max(errs))

            path = "modal sums" if pb.modal else "dense solves"
            rows.append(branch_row(f"ROM n_CM = {n_cm}, {label}", f"{12 + n_cm} DOF, {path}",
                                   pb, 4500.0, 7000.0, dense, max_points=1500))
    if not quick:
        pb = synthetic_rom(300, True, modal=False)
        rows.append(branch_row("ROM n_CM = 300, clustered, non-modal C", "312 DOF, dense solves",
                               pb, 4500.0, 7000.0, None, max_points=1500))
    return rows


def case_units(quick: bool) -> list:
    rows = []
    units = [(1.0, 1.0, "m, N"), (1e-6, 1.0, "um, N"), (1e3, 1e6, "km, MN"),
             (1e-3, 1e6, "mm, MN"), (1e-6, 1e-6, "um, uN")]
    for cond in ("loa", "gear", "none"):
        held: dict[str, hbm.Branch] = {}
        for ell, phi, name in units:
            mdl = Geared3(km=1e9, te=5e-6, length_unit=ell, force_unit=phi, condensation=cond)
            r = Geared3(km=1e9).mesh_rpm()

            def cmp(pb, br, ell=ell, held=held):
                if "si" not in held:
                    held["si"] = br
                    return "SI run (this row)", 0.0
                si = held["si"]
                if len(br) != len(si):
                    return f"SI run ({len(si)} points)", float("inf")
                e = np.max(np.abs(br.element(0).coefficients * ell - si.element(0).coefficients))
                return "SI run", float(max(e / np.max(np.abs(si.element(0).coefficients)),
                                           np.max(np.abs(br.rpm - si.rpm)) / br.rpm.max()))

            rows.append(branch_row(f"units, condensation {cond}", name, mdl.problem(), 0.6 * r,
                                   1.4 * r, cmp))
    return rows


def case_continuation(quick: bool) -> list:
    rows = []
    mdl = Geared3(te=5e-6)
    r = mdl.mesh_rpm()
    for it in [1, 2]:
        rows.append(branch_row("continuation, corrector limited", f"max_iter = {it}",
                               mdl.problem(), 0.6 * r, 1.4 * r, None, max_iter=it))
    # a solver breakdown past 9000 rpm (non-finite residual): stop, keep the points
    pb = mdl.problem()
    scaled = pb.scaled

    def broken(x, omega, jacobian=True, law=1.0):
        out = scaled(x, omega, jacobian, law)
        if omega > 9000 * RPM:
            return (out[0] * np.nan, *out[1:]) if jacobian else out * np.nan
        return out

    pb.scaled = broken
    rows.append(branch_row("continuation, solver breakdown", "NaN residual > 9000 rpm", pb,
                           0.6 * r, 1.4 * r, None))
    pb.scaled = scaled
    for fallback in (False, True):
        rows.append(branch_row("start point where Newton fails", f"start_fallback = {fallback}",
                               Geared3(torque=47.0, te=20e-6).problem(), 0.6 * r, 1.4 * r,
                               _shoot() if fallback else None, start_fallback=fallback))
    return rows


def case_refusals(quick: bool) -> list:
    rows = []

    def attempt(case, param, build):
        t0 = time.perf_counter()
        try:
            build()
            rows.append(_row(case, param, "accepted (unexpected)", 0, np.nan, np.nan, "-",
                             np.nan, np.nan, time.perf_counter() - t0, ""))
        except (ValueError, hbm.ConvergenceError) as exc:
            rows.append(_row(case, param, "refused", 0, np.nan, np.nan, "-", np.nan,
                             getattr(exc, "condition", np.nan), time.perf_counter() - t0,
                             f"{type(exc).__name__}: {exc}"))

    attempt("zero backlash", "b = 0", lambda: Geared3(b=0.0).problem())
    attempt("stiffness fluctuation > mean", "k1 = 1.2 km", lambda: Geared3(k_ratio=1.2).problem())
    attempt("zero speed", "0 rpm", lambda: Geared3().problem().solve(0.0))
    attempt("AFT grid too coarse", "n_time = 40, H = 20",
            lambda: Geared3(n_time=40).problem())

    def free_rattle():
        system = hbm.LinearSystem([[1.0]], [[0.0]], [[0.0]])
        mesh = hbm.GearMesh([1.0], 1, {0: 1e8}, backlash=1e-5)
        pb = hbm.HBMProblem(system, [mesh], hbm.Excitation(1), hbm.HarmonicSet.build(1, 10))
        return pb.solve(100.0)

    t0 = time.perf_counter()
    pt = free_rattle()
    rows.append(_row("free pair, no load, no damping", "F = 0, C = 0", "solved", 1,
                     pt.residual, np.nan, "-", np.nan, np.nan, time.perf_counter() - t0,
                     f"rest in the backlash, Delta = {pt.coefficients[0, 0].real:.3g} m (one of "
                     "the continuum |Delta| <= b; not unique)"))
    return rows


CASES = [case_stiffness, case_damping, case_backlash, case_static_load, case_te, case_speed,
         case_harmonics, case_aft, case_rom, case_units, case_continuation, case_refusals]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller ROM sizes")
    parser.add_argument("--only", default="", help="comma-separated case function names")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    rows = []
    t0 = time.perf_counter()
    for case in CASES:
        if args.only and case.__name__ not in args.only.split(","):
            continue
        t = time.perf_counter()
        new = case(args.quick)
        rows += new
        for row in new:
            log.warning("%s | %s | %s | %s pts | res %.2g | ref %.2g | %.2f s | %s", row[0],
                        row[1], row[2], row[3], row[4], row[7], row[9], row[10][:120])
        log.warning("%s: %.1f s", case.__name__, time.perf_counter() - t)
    n_solved = sum(r[2] == "solved" for r in rows)
    n_refused = sum(r[2].startswith(("refused", "stopped")) for r in rows)
    summary = (f"{len(rows)} extreme cases: {n_solved} solved with every point below the "
               f"tolerance and re-checked on the uncondensed equations, {n_refused} refused or "
               f"stopped with their reason; total {time.perf_counter() - t0:.0f} s.")
    payload = {
        "command": " ".join([".venv/bin/python -m benchmarks.bench_extreme",
                             *(sys.argv[1:] if argv is None else argv)]),
        "summary": summary,
        "tables": [{"title": "Extreme cases (hbm)", "columns": COLUMNS, "rows": rows}],
    }
    if not args.only:
        path = write_json("extreme", payload)
        log.warning("wrote %s", path)
    log.warning(summary)


if __name__ == "__main__":
    main()
