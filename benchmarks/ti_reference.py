"""Reference time integrations of the pump ROM, one per checked speed.

For a scene (default the shipped ``scenes/pump.toml``) and a list of speeds, the
ROM is integrated in time (:func:`benchmarks.bench_verify.steady_state`: DOP853,
rtol 1e-10, in the coupled modes of eq. 17, whole fundamental periods until the
period-to-period change of the mesh-load std/RMS/p2p is below 1e-9) from an HBM
point at that speed. The HBM start uses a rich harmonic set (12 mesh harmonics,
sideband order 3, contiguous: every shaft order 0..924) so that it starts close to
the attractor; it is the Newton solution at that speed from the nearest point of a
saved branch of that set (``--branch``), or from the linear response without one.

Per speed the reference keeps the std, RMS and peak-to-peak of the mesh load on
``samples`` equally spaced times of the last period, the contact class, the
periods integrated, the complex Fourier coefficients of Delta of the last period
(shaft harmonics 0..``--harmonics``-1, ``Delta = Re sum_k c_k exp(i k w0 t)``) and the
seconds. Where the HBM curve is multivalued the integration settles on one of the
coexisting orbits: every distinct HBM solution at that speed (one per monotone
piece of the saved branch through it) is solved and the one nearest to the
integrated Delta (relative L2 over the harmonics) is recorded as the attractor.

The file ``benchmarks/results/ti_reference_pump.json`` is keyed by the scene path,
the ROM stage-cache key and a hash of the physics the HBM problem adds to the ROM
(mesh stiffness, transmission error, load, external forcing, damping, gear), so a
stale reference is refused (:func:`load_reference`). It is rewritten (atomically)
after every speed.

Run (one background process, a few minutes per speed)::

    nice -n 5 .venv/bin/python -m benchmarks.ti_reference \
        --cache /work/main/.cache/.geardyn-cache --branch benchmarks/results/br_12_3.npz
"""
from __future__ import annotations

import argparse
import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.bench_verify import (
    PUMP_SCENE,
    contact_class,
    hbm_load,
    initial_state,
    load_metrics,
    modal_model,
    steady_state,
)
from benchmarks.common import RESULTS, machine
from core.files import atomic_write

log = logging.getLogger("ti_reference")
ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = RESULTS / "ti_reference_pump.json"
DEFAULT_SPEEDS = (852.0, 1007.0, 1200.0, 1390.0, 1600.0, 2218.0, 2504.0, 2970.0, 3500.0,
                  4500.0, 6875.0)
#: the start set: every shaft order up to 12 Z + 3 max(e) (docs/convergence.md)
START_SET = {"hbm.mesh_harmonics": 12, "hbm.sideband_order": 3,
             "hbm.harmonic_set": "contiguous"}
FORMAT = 1
#: a reference stopped by the wall-time limit before repeating to 1e-9 is kept ("settled")
#: if its uncertainty (:func:`uncertainty`) is below this, 1e-2 of the 1e-3 target
ACCEPT_UNCERTAINTY = 1e-5


# --------------------------------------------------------------------------- key

def reference_key(scene_path: Path, cache_dir: Path) -> dict[str, str | None]:
    """What a reference depends on: the scene path (relative to the repository), the
    ROM stage-cache key, the SHA-256 of that cache entry's ``rom.h5`` (None if the ROM is
    not in the cache) and a hash of the HBM physics on top of the ROM.

    Computing the keys hashes inputs and sources only; nothing is built.
    """
    import study
    from study.pipeline import Pipeline, hbm_inputs
    from study.pipeline.cache import stage_key

    scene_path = Path(scene_path).resolve()
    scene = study.load_scene(scene_path)
    pl = Pipeline(scene, cache_dir.parent / "ti-reference", cache_dir=cache_dir, progress=False)
    physics = {k: v for k, v in hbm_inputs(scene).items() if k not in ("hbm", "continuation")}
    try:
        rel = str(scene_path.relative_to(ROOT))
    except ValueError:
        rel = str(scene_path)
    rom_key = pl.rom_key()
    return {"scene": rel, "rom_key": rom_key, "rom_sha256": rom_sha256(cache_dir, rom_key),
            "rom_fingerprint": rom_fingerprint(cache_dir, rom_key),
            "physics_key": stage_key("physics", physics, "")}


def rom_sha256(cache_dir: Path, rom_key: str) -> str | None:
    """SHA-256 of ``rom.h5`` recorded in the manifest of the cache entry of ``rom_key``."""
    manifest = Path(cache_dir) / "rom" / rom_key[:24] / "manifest.json"
    try:
        m = json.loads(manifest.read_text())
    except (OSError, ValueError):
        return None
    if m.get("key") != rom_key:
        return None
    return m.get("files", {}).get("rom.h5", {}).get("sha256")


#: frequencies of the receptances in the ROM fingerprint [Hz], and its tolerance
FINGERPRINT_HZ = (370.0, 1300.0, 4100.0, 9700.0)
FINGERPRINT_RTOL = 1e-8
FINGERPRINT_PROJECTIONS = 6


def rom_fingerprint(cache_dir: Path, rom_key: str) -> list[float] | None:
    """What the dynamics see of the ROM in the cache entry of ``rom_key``, or None.

    The receptances ``H(f) = B_g (K - w^2 M + i w C)^-1 [B_g; B_n]^T`` from the gear DOF
    and the load-node rows (``nodes.h5``) to the gear DOF, at :data:`FINGERPRINT_HZ`,
    each contracted with fixed pseudo-random vectors (real and imaginary parts; SI
    receptances, m/N and rad/(N·m) mixed, so compare them relatively). They do
    not depend on the basis of the reduced space (order, signs or mixing of the component
    modes), so two ROMs that differ only in round-off or in the eigen-solver's choice of
    eigenvectors have equal fingerprints to ~1e-12.
    """
    import h5py

    folder = Path(cache_dir) / "rom" / rom_key[:24]
    try:
        with h5py.File(folder / "rom.h5", "r") as f:
            M, K, C = (f[f"rom/{n}"][()] for n in ("M", "K", "C"))
            n_gear = f["rom/gear_dofs"].shape[0]       # physical, first in q (theory §4)
        with h5py.File(folder / "nodes.h5", "r") as f:
            rows = f["basis_rows"][()]
    except (OSError, KeyError):
        return None
    bg = np.eye(M.shape[0])[:n_gear]
    b_in = np.vstack([bg, rows])
    rng = np.random.default_rng(20261124)
    u = rng.standard_normal((FINGERPRINT_PROJECTIONS, bg.shape[0]))
    v = rng.standard_normal((FINGERPRINT_PROJECTIONS, b_in.shape[0]))
    out = []
    for hz in FINGERPRINT_HZ:
        w = 2.0 * np.pi * hz
        H = bg @ np.linalg.solve(K - w * w * M + 1j * w * C, b_in.T)
        z = np.einsum("pi,ij,pj->p", u, H, v)
        out += [*z.real, *z.imag]
    return [float(x) for x in out]


def same_fingerprint(a: list[float] | None, b: list[float] | None,
                     rtol: float = FINGERPRINT_RTOL) -> bool:
    """True if both fingerprints exist and agree to ``rtol`` of their largest entry,
    frequency by frequency."""
    if a is None or b is None or len(a) != len(b):
        return False
    x = np.reshape(a, (len(FINGERPRINT_HZ), -1))
    y = np.reshape(b, (len(FINGERPRINT_HZ), -1))
    scale = np.maximum(np.abs(x).max(axis=1), np.abs(y).max(axis=1))
    return bool(np.all(np.abs(x - y).max(axis=1) <= rtol * scale))


class StaleReference(ValueError):
    """The reference was computed for another scene, ROM or physics."""


def check_key(got: dict, key: dict, where: str = "reference") -> None:
    """Refuse a reference key ``got`` that does not match the current ``key``.

    Scene and physics key must be equal. The ROM key must be equal too, unless both
    keys carry the same ``rom_sha256`` (the ROM key hashes the source of the ROM stage as
    well, and a change of a comment there rebuilds a byte-identical ROM) or the same
    ``rom_fingerprint`` to ``FINGERPRINT_RTOL`` (a change of the reduction that moves
    the ROM by round-off, or picks other eigenvectors of the same space).

    Raises
    ------
    StaleReference
        Naming the first field that differs.
    """
    for name in ("scene", "physics_key"):
        if got.get(name) != key[name]:
            raise StaleReference(
                f"{where}: key.{name} = {str(got.get(name))[:16]!r} does not match the current "
                f"{str(key[name])[:16]!r}: recompute the reference "
                "(python -m benchmarks.ti_reference)")
    if got.get("rom_key") == key["rom_key"]:
        return
    same_rom = got.get("rom_sha256") is not None and got.get("rom_sha256") == key.get(
        "rom_sha256")
    if not same_rom and same_fingerprint(got.get("rom_fingerprint"), key.get("rom_fingerprint")):
        log.info("%s: ROM key %s and ROM file differ from the current ones, the ROM's "
                 "receptances agree to %g: accepted", where, str(got["rom_key"])[:12],
                 FINGERPRINT_RTOL)
        return
    if not same_rom:
        raise StaleReference(
            f"{where}: key.rom_key = {str(got.get('rom_key'))[:16]!r} does not match the current "
            f"{str(key['rom_key'])[:16]!r} and the ROM file differs (rom_sha256 "
            f"{str(got.get('rom_sha256'))[:12]!r} vs {str(key.get('rom_sha256'))[:12]!r}): "
            "recompute the reference (python -m benchmarks.ti_reference)")
    log.info("%s: ROM key %s differs from the current %s, the ROM file is the same (sha256 "
             "%s): accepted", where, got["rom_key"][:12], key["rom_key"][:12],
             got["rom_sha256"][:12])


def load_reference(path: Path, key: dict[str, str | None]) -> dict[str, Any]:
    """Read a reference file and check it was made for ``key`` (:func:`reference_key`,
    :func:`check_key`).

    Returns the payload with ``speeds`` as a list of records sorted by rpm; complex
    coefficients are rebuilt as ``coefficients`` (complex array) in each record, and
    ``accepted`` is recomputed (:func:`settled`).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    StaleReference
        If the file's format, scene, physics or ROM differ from ``key``.
    """
    path = Path(path)
    data = json.loads(path.read_text())
    if data.get("format") != FORMAT:
        raise StaleReference(f"{path}: format = {data.get('format')!r}, expected {FORMAT}")
    check_key(data.get("key", {}), key, str(path))
    for rec in data["speeds"]:
        rec["accepted"] = settled(rec)
        c = rec["delta_coefficients"]
        rec["coefficients"] = np.asarray(c["re"]) + 1j * np.asarray(c["im"])
    data["speeds"].sort(key=lambda r: r["rpm"])
    return data


# --------------------------------------------------------------------------- branches

def monotone_pieces(rpm: np.ndarray) -> list[np.ndarray]:
    """Indices of the pieces of a branch along which the speed is monotone (split at
    every reversal of the speed; the turning point belongs to both pieces)."""
    rpm = np.asarray(rpm, dtype=float)
    if rpm.size < 2:
        return [np.arange(rpm.size)]
    d = np.sign(np.diff(rpm))
    # a zero step keeps the previous direction
    for i in range(1, d.size):
        if d[i] == 0:
            d[i] = d[i - 1]
    turns = np.flatnonzero(d[1:] * d[:-1] < 0) + 1
    bounds = [0, *turns.tolist(), rpm.size - 1]
    return [np.arange(a, b + 1) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def crossing_starts(rpm: np.ndarray, target: float) -> list[int]:
    """For each monotone piece whose speed span contains ``target``, the index of its
    point nearest to it (the overall nearest point if no piece spans it)."""
    rpm = np.asarray(rpm, dtype=float)
    out = []
    for piece in monotone_pieces(rpm):
        r = rpm[piece]
        if r.min() <= target <= r.max():
            out.append(int(piece[np.argmin(np.abs(r - target))]))
    if not out:
        out = [int(np.argmin(np.abs(rpm - target)))]
    return sorted(set(out))


def remaining_drift(changes: list[float], last: int = 8) -> float:
    """Bound on how far the load statistics still move after the last period, from
    the period-to-period relative changes: a geometric tail ``c r / (1 - r)`` with the
    ratio ``r`` of the last ``last`` changes (inf if they do not decrease)."""
    c = np.asarray(changes[-last:], dtype=float)
    if c.size < 3 or np.any(c <= 0):
        return float("inf")
    r = float(np.exp(np.polyfit(np.arange(c.size), np.log(c), 1)[0]))
    return float(c[-1] * r / (1 - r)) if r < 1 else float("inf")


def uncertainty(changes: list[float], last: int = 8) -> float:
    """How far the load statistics of the last period may be from the settled ones: the
    largest of the last ``last`` period-to-period changes (the jitter of an integration at
    its round-off floor, 1e-8..1e-6 at rtol 1e-10 with impacts) and, where those changes
    decrease, the geometric bound on the drift still to come (:func:`remaining_drift`)."""
    if not changes:
        return float("inf")
    jitter = float(np.max(changes[-last:]))
    drift = remaining_drift(changes, last)
    return max(jitter, drift) if np.isfinite(drift) else jitter


def settled(record: dict) -> bool:
    """True if the reference repeats to 1e-9 or its uncertainty is < ACCEPT_UNCERTAINTY."""
    return bool(record["converged"]
                or uncertainty(record.get("load_changes") or []) < ACCEPT_UNCERTAINTY)


def delta_distance(c: np.ndarray, ref: np.ndarray) -> float:
    """Relative L2 distance between two sets of Delta coefficients by shaft harmonic
    (the shorter one padded with zeros)."""
    n = max(c.size, ref.size)
    a = np.zeros(n, complex)
    b = np.zeros(n, complex)
    a[:c.size], b[:ref.size] = c, ref
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300))


def fourier_coefficients(x: np.ndarray, n_harmonics: int) -> np.ndarray:
    """Coefficients ``c_k`` (k < n_harmonics) of ``x = Re sum_k c_k exp(i k w0 t)`` from
    ``N > 2 n_harmonics`` equally spaced samples of one period."""
    n = x.size
    if n <= 2 * n_harmonics:
        raise ValueError(f"samples = {n}: must be > 2 * harmonics = {2 * n_harmonics}")
    c = np.fft.rfft(x)[:n_harmonics] * (2.0 / n)
    c[0] /= 2
    return c


def harmonic_vector(problem, point) -> np.ndarray:
    """Delta coefficients of an HBM point on the shaft harmonics 0..max index."""
    hs = problem.harmonics
    out = np.zeros(hs.max_index * hs.integer_ratio + 1, complex)
    out[np.asarray(hs.indices) * hs.integer_ratio] = point.coefficients[0]
    return out


@dataclass
class SavedBranch:
    """A branch saved as ``.npz`` (rpm, u: unknowns, stable), of the start set."""

    rpm: np.ndarray
    unknowns: np.ndarray
    stable: np.ndarray

    @classmethod
    def read(cls, path: Path) -> SavedBranch:
        z = np.load(path)
        stable = z["stable"] if "stable" in z.files else np.ones(z["rpm"].size, bool)
        return cls(rpm=z["rpm"], unknowns=z["u"], stable=np.asarray(stable, bool))


# --------------------------------------------------------------------------- one speed

def hbm_candidates(problem, branch: SavedBranch | None, rpm: float) -> list[dict]:
    """The distinct HBM solutions at ``rpm``: Newton from the nearest point of every
    monotone piece of ``branch`` through it (or from the linear response)."""
    from hbm import ConvergenceError

    starts = crossing_starts(branch.rpm, rpm) if branch is not None else [None]
    out: list[dict] = []
    for i in starts:
        x0 = None if i is None else branch.unknowns[i]
        try:
            pt = problem.solve(rpm, x0=x0, tol=1e-10)
        except ConvergenceError as exc:
            log.warning("%.0f rpm: no HBM solution from branch point %s (%s)", rpm, i, exc)
            continue
        vec = harmonic_vector(problem, pt)
        if any(delta_distance(vec, c["vector"]) < 1e-6 for c in out):
            continue
        out.append({"point": pt, "vector": vec, "branch_index": i,
                    "branch_rpm": None if i is None else float(branch.rpm[i]),
                    "stable": None if i is None else bool(branch.stable[i])})
    if not out:
        raise RuntimeError(f"{rpm} rpm: no HBM solution of the start set")
    return out


def reference_speed(problem, branch: SavedBranch | None, rpm: float, n_harmonics: int,
                    max_periods: int, max_seconds: float | None) -> dict:
    """Time integration at ``rpm`` from the (first stable) HBM solution there."""
    cands = hbm_candidates(problem, branch, rpm)
    start = next((c for c in cands if c["stable"] in (True, None)), cands[0])
    mm = modal_model(problem, rpm)
    step = problem.steps[0]
    samples = step * int(np.ceil(8192 / step))
    ss = steady_state(mm, initial_state(problem, start["point"], mm), rtol=1e-10,
                      tol_periodic=1e-9, samples=samples, max_periods=max_periods,
                      max_seconds=max_seconds)
    metrics = load_metrics(ss.load)
    coeffs = fourier_coefficients(ss.delta, n_harmonics)
    ti_vec = fourier_coefficients(ss.delta, samples // 2 - 1)
    for c in cands:
        c["distance"] = delta_distance(c["vector"], ti_vec)
        c["std"] = load_metrics(hbm_load(problem, c["point"], samples))["std"]
    near = min(cands, key=lambda c: c["distance"])
    unc = uncertainty(ss.load_changes)
    accepted = bool(ss.converged or unc < ACCEPT_UNCERTAINTY)
    log.info("%.0f rpm: %d periods, %.0f s, std %.9g N, class %d, load change %.2g "
             "(uncertainty %.2g)%s; %d HBM solution(s), nearest (distance %.2g) std %.9g N",
             rpm, ss.periods, ss.seconds, metrics["std"], contact_class(mm, ss.delta, ss.t),
             ss.load_change, unc, "" if accepted else " NOT SETTLED", len(cands),
             near["distance"], near["std"])
    return {
        "rpm": float(rpm), **metrics, "contact": contact_class(mm, ss.delta, ss.t),
        "periods": ss.periods, "seconds": ss.seconds, "n_rhs": ss.n_rhs,
        "state_change": ss.change, "load_change": ss.load_change,
        "uncertainty": unc if np.isfinite(unc) else None,
        "load_changes": [float(f"{c:.3g}") for c in ss.load_changes],
        "converged": bool(ss.converged), "accepted": accepted, "samples": samples,
        "n_modes": mm.n_modes,
        "delta_coefficients": {"harmonics": n_harmonics,
                               "re": _round(coeffs.real), "im": _round(coeffs.imag)},
        "start": {"branch_index": start["branch_index"], "branch_rpm": start["branch_rpm"],
                  "std": start["std"], "distance": start["distance"]},
        "hbm_solutions": [{"branch_index": c["branch_index"], "branch_rpm": c["branch_rpm"],
                           "stable": c["stable"], "std": c["std"], "distance": c["distance"]}
                          for c in cands],
        "attractor": cands.index(near),
    }


def _round(x: np.ndarray) -> list[float]:
    """12 significant digits (the integration is good to ~1e-10)."""
    return [float(f"{v:.12g}") for v in x]


# --------------------------------------------------------------------------- file

def write_reference(path: Path, key: dict, records: list[dict], settings: dict) -> None:
    """Write the reference atomically, with a table for BENCHMARKS.md."""
    records = sorted(records, key=lambda r: r["rpm"])
    names = {0: "permanent", 1: "single-sided", 2: "double-sided"}
    rows = []
    for r in records:
        att = r["hbm_solutions"][r["attractor"]]
        unc = r.get("uncertainty")
        rows.append([r["rpm"], r["std"], r["rms"], r["p2p"], names[r["contact"]], r["periods"],
                     r["load_change"], "-" if unc is None else unc,
                     "yes" if r["accepted"] else "no", r["seconds"], len(r["hbm_solutions"]),
                     att["std"], abs(att["std"] - r["std"]) / r["std"], att["distance"]])
    payload = {
        "benchmark": "ti_reference_pump", "format": FORMAT, "key": key, "machine": machine(),
        "command": ".venv/bin/python -m benchmarks.ti_reference",
        "summary": ("Reference time integrations of the pump ROM (DOP853, rtol 1e-10, all "
                    "coupled modes, to a period-to-period change of the mesh-load statistics "
                    "< 1e-9, or stopped by the wall-time limit with an uncertainty < "
                    f"{ACCEPT_UNCERTAINTY:g}: the largest of the last 8 per-period changes of "
                    "std/RMS/p2p and the geometric bound on a decreasing drift) started on "
                    "the HBM solution of the "
                    "12/3 contiguous set. 'HBM 12/3 std' is the HBM solution at that speed "
                    "nearest to the integrated orbit (distance: relative L2 of Delta), with "
                    "the HBM code of the time the reference was made (the current code's "
                    "errors: the 'converged' section)."),
        "settings": settings,
        "tables": [{"title": "reference mesh load per speed",
                    "columns": ["rpm", "std N", "rms N", "p2p N", "contact", "periods",
                                "load change", "uncertainty", "settled", "s",
                                "HBM solutions", "HBM 12/3 std N (run-time code)",
                                "12/3 err std", "distance"],
                    "rows": rows}],
        "speeds": records,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "w") as fh:
        json.dump(payload, fh, indent=1)
        fh.write("\n")


def main(argv: list[str] | None = None) -> dict:
    import study
    from study.pipeline import Pipeline

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, default=PUMP_SCENE)
    ap.add_argument("--rpm", type=float, nargs="+", default=list(DEFAULT_SPEEDS))
    ap.add_argument("--cache", type=Path, default=ROOT / "out" / ".geardyn-cache",
                    help="pipeline stage cache holding the ROM")
    ap.add_argument("--branch", type=Path, default=None,
                    help=".npz branch of the start set (rpm, u, stable)")
    ap.add_argument("--harmonics", type=int, default=1000,
                    help="shaft harmonics of Delta kept")
    ap.add_argument("--max-periods", type=int, default=400)
    ap.add_argument("--max-seconds", type=float, default=1200.0,
                    help="per speed, wall time")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--keep", action="store_true",
                    help="keep the records of other speeds of a current --out")
    ap.add_argument("--relabel", action="store_true",
                    help="only recompute the settled flags and table of --out")
    args = ap.parse_args(argv)
    for name in ("harmonics", "max_periods"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name.replace('_', '-')} = {getattr(args, name)}: must be >= 1")
    if any(not r > 0 for r in args.rpm):
        raise ValueError(f"--rpm = {args.rpm}: must be > 0")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    key = reference_key(args.scene, args.cache)
    if args.relabel:
        raw = json.loads(args.out.read_text())
        if raw["key"].get("rom_sha256") is None:       # files written before rom_sha256
            raw["key"]["rom_sha256"] = rom_sha256(args.cache, raw["key"]["rom_key"])
            with atomic_write(args.out, "w") as fh:
                json.dump(raw, fh, indent=1)
                fh.write("\n")
        old = load_reference(args.out, key)
        if raw["key"].get("rom_fingerprint") is None:  # files written before the fingerprint
            raw["key"]["rom_fingerprint"] = key["rom_fingerprint"]
        key = raw["key"]
        for r in old["speeds"]:
            r.pop("coefficients")
            if r.get("load_changes"):
                unc = uncertainty(r["load_changes"])
                r["uncertainty"] = unc if np.isfinite(unc) else None
            r.pop("drift_bound", None)
        write_reference(args.out, key, old["speeds"], old["settings"])
        return old
    scene = study.load_scene(args.scene, START_SET)
    problem, _ = Pipeline(scene, args.cache.parent / "ti-reference", cache_dir=args.cache,
                          progress=False).problem()
    branch = SavedBranch.read(args.branch) if args.branch else None
    if branch is not None and branch.unknowns.shape[1] != problem.n_unknowns:
        raise ValueError(f"--branch: {branch.unknowns.shape[1]} unknowns, the start set has "
                         f"{problem.n_unknowns}")
    records: list[dict] = []
    if args.keep and args.out.exists():
        old = load_reference(args.out, key)
        records = [r for r in old["speeds"] if r["rpm"] not in args.rpm]
        for r in records:
            r.pop("coefficients")
    settings = {"start_set": START_SET, "rtol": 1e-10, "tol_periodic": 1e-9,
                "max_periods": args.max_periods, "max_seconds": args.max_seconds,
                "branch": args.branch.name if args.branch else None}
    t0 = time.perf_counter()
    for rpm in args.rpm:
        records.append(reference_speed(problem, branch, rpm, args.harmonics, args.max_periods,
                                       args.max_seconds))
        write_reference(args.out, key, records, settings)
        log.info("wrote %s (%d speeds, %.0f s so far)", args.out, len(records),
                 time.perf_counter() - t0)
    return {"key": key, "speeds": records}


if __name__ == "__main__":
    main()
