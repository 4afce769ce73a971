"""Mesh-energy spectrum (eq. 31) of pump structures: which stated structure gives the paper's?

Issue 14, item 1 and docs/theory.md §13.4: the shipped pump concentrates the mesh
energy in one mode (ρ = 0.87 at 4061 Hz with the calibrated k̄ = 185 N/µm); the paper's
mode with most mesh energy has ρ = 0.32 at 4 kHz, "several modes have a significant
mesh energy" and the highest-frequency one with mesh energy lies at 5 kHz (Sect. 4.1,
Fig. 8). This script reduces the coarse pump for a candidate structure (scene
overrides, one cached ``geardyn reduce`` each) and prints, for several mean mesh
stiffnesses k̄ (the Craig–Bampton ROM does not depend on k̄: the modes of eq. 17 are
recomputed from one ROM), every coupled mode below ``--fmax`` with ρ above 3 %.

Eq. (31) splits the mesh energy over modes, which a near coincidence with a housing or
shaft mode does easily; what sets how much a resonance softens when the teeth separate
is how much of the stiffness *seen at the mesh* the mesh supplies. The script therefore
also measures the peak of the linear dynamic factor (T.32 of docs/theory.md §13.4)

    D(f) = |k̄ Gᵀ (K_r + k̄ G Gᵀ − ω² M_r + iω C_r)⁻¹ G − 1|,   ω = 2πf,

the dynamic mesh force per unit TE excitation ``k̄ e`` (C_r: 5 % modal damping, eq. 18–19),
at k̄ and at k̄/2: a single mode with mesh energy ρ has ``f½/f = √(1 − ρ/2)``, so
``ρ_½ = 2 (1 − (f½/f)²)`` is the effective mesh-energy share of the resonance the TE
excites (0.32 → f½/f = 0.92; 0.87 → 0.75).

Every candidate (name, the assumption it states, overrides, modes per k̄) is kept in
``benchmarks/results/pump_structure.json``; ``show`` prints the table.

Run (one heavy run at a time; ~15 s per reduce)::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice .venv/bin/python -m benchmarks.pump_structure \\
        measure NAME --note "assumption" --set geometry.shaft_in.body_radius_mm=30 ...
    ... show

Not a timing benchmark (not picked up by ``run_all``).
"""
from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

import numpy as np

from benchmarks.common import scene_overrides, write_json

log = logging.getLogger("pump_structure")
ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "pump.toml"
RESULTS = ROOT / "benchmarks" / "results" / "pump_structure.json"

#: Mean mesh stiffnesses [N/µm]: the shipped calibrated value, ISO 6336-1 method B at
#: 70 N (docs/theory.md §13.1), LTCA class 6 profile only and perfect teeth at 3.29 N·m
#: (§13.3).
KM_DEFAULT = (185.0, 235.3, 249.3, 413.8)
#: Eq. (31) threshold of Fig. 8 ("only modes with a mesh energy greater than 3 %").
RHO_MIN = 0.03


def spectrum(M: np.ndarray, K: np.ndarray, G: np.ndarray, km: float,
             fmax: float) -> list[tuple[float, float]]:
    """Coupled modes (eq. 17) below ``fmax`` [Hz] with ρ (eq. 31) > :data:`RHO_MIN`,
    as ``(frequency [Hz], ρ)``."""
    from reduction import coupled_modes, mesh_energy

    f = coupled_modes(M, K, G, km).frequencies_hz
    rho = mesh_energy(M, K, G, km)
    keep = (f < fmax) & (rho > RHO_MIN)
    return [(float(a), float(b)) for a, b in zip(f[keep], rho[keep], strict=True)]


def dynamic_factor_peak(M: np.ndarray, K: np.ndarray, G: np.ndarray, km: float,
                        f_hz: np.ndarray, xi: float = 0.05) -> tuple[float, float]:
    """Frequency [Hz] and height of the peak of the dynamic factor D(f) (T.32,
    :func:`reduction.dynamic_factor`) on the grid ``f_hz``."""
    from reduction import dynamic_factor

    d = dynamic_factor(M, K, G, km, f_hz, xi)
    j = int(np.argmax(d))
    return float(f_hz[j]), float(d[j])


#: Frequency grid of the dynamic-factor peak search [Hz].
F_GRID = np.arange(1000.0, 7000.0, 10.0)


def summary(modes: list[tuple[float, float]]) -> dict:
    """Mode with most mesh energy, count above 3 %, highest such frequency, ρ sum."""
    if not modes:
        return {"top_hz": None, "top_rho": None, "n": 0, "highest_hz": None, "sum_rho": 0.0}
    top = max(modes, key=lambda m: m[1])
    return {"top_hz": top[0], "top_rho": top[1], "n": len(modes),
            "highest_hz": max(m[0] for m in modes), "sum_rho": sum(m[1] for m in modes)}


def measure(name: str, note: str, overrides: dict, kms: tuple[float, ...], fmax: float,
            work: Path, cache: Path, reuse: bool = False) -> dict:
    """Reduce the pump with ``overrides`` and its mesh-energy spectrum at every k̄
    (``reuse``: take the ROM already published in ``work/name/rom.h5``, if any)."""
    import study
    from reduction import load_rom

    t0 = time.perf_counter()
    path = work / name / "rom.h5"
    if not (reuse and path.exists()):
        res = study.run(SCENE, work / name, overrides=overrides, cache_dir=cache, until="rom")
        path = Path(res.out) / "rom.h5"
    rom = load_rom(path)
    per_km = {}
    for km in kms:
        modes = spectrum(rom.M, rom.K, rom.G, km * 1e6, fmax)
        fp, dp = dynamic_factor_peak(rom.M, rom.K, rom.G, km * 1e6, F_GRID)
        fh, _ = dynamic_factor_peak(rom.M, rom.K, rom.G, 0.5 * km * 1e6, F_GRID)
        per_km[f"{km:g}"] = {"modes": [[round(a, 1), round(b, 4)] for a, b in modes],
                             **summary(modes), "peak_hz": fp, "peak_factor": round(dp, 2),
                             "half_ratio": round(fh / fp, 3),
                             "rho_half": round(2.0 * (1.0 - (fh / fp) ** 2), 2)}
    return {"name": name, "note": note, "overrides": overrides, "fmax_hz": fmax,
            "seconds": round(time.perf_counter() - t0, 1), "km": per_km}


def _load(path: Path) -> dict:
    return json.loads(path.read_text()) if path.exists() else {"candidates": {}}


COLUMNS = ["candidate", "k̄ (N/µm)", "most mesh energy (Hz, ρ)", "modes ρ > 3 %",
           "highest (Hz)", "D peak (Hz, height)", "f½/f (ρ_½)", "modes (Hz: ρ)"]


def table_rows(data: dict, kms: tuple[str, ...] | None = None) -> list[list[str]]:
    """One row per candidate and k̄."""
    rows = []
    for c in data["candidates"].values():
        for km, s in c["km"].items():
            if kms and km not in kms:
                continue
            top = "–" if s["top_hz"] is None else f"{s['top_hz']:.0f}, {s['top_rho']:.2f}"
            rows.append([c["name"], km, top, str(s["n"]),
                         "–" if s["highest_hz"] is None else f"{s['highest_hz']:.0f}",
                         f"{s['peak_hz']:.0f}, {s['peak_factor']:.1f}",
                         f"{s['half_ratio']:.2f} ({s['rho_half']:.2f})",
                         ", ".join(f"{f:.0f}: {r:.2f}" for f, r in s["modes"])])
    return rows


def _save(path: Path, data: dict) -> None:
    write_json("pump_structure", {
        **data, "command": ".venv/bin/python -m benchmarks.pump_structure measure NAME ...",
        "summary": "Mesh-energy spectrum (eq. 31, modes with ρ > 3 %) of candidate pump "
                   "structures at several k̄ (docs/theory.md §13.4).",
        "tables": [{"title": "candidates", "columns": COLUMNS, "rows": table_rows(data)}]},
        path)


def show(data: dict, kms: tuple[str, ...] | None = None) -> str:
    """Markdown table of every candidate (optionally only the k̄ listed)."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(r) + " |" for r in table_rows(data, kms)]
    notes = [f"- **{c['name']}**: {c['note']} (`" +
             " ".join(f"--set {k}={json.dumps(v)}" for k, v in c["overrides"].items()) + "`)"
             for c in data["candidates"].values()]
    return "\n".join(lines + [""] + notes)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("command", choices=["measure", "show"])
    p.add_argument("name", nargs="?", default="")
    p.add_argument("--note", default="", help="the assumption the candidate states")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    p.add_argument("--km", default=",".join(f"{k:g}" for k in KM_DEFAULT),
                   help="mean mesh stiffnesses [N/µm]")
    p.add_argument("--fmax", type=float, default=6500.0, help="highest frequency [Hz]")
    p.add_argument("--reuse", action="store_true",
                   help="measure the ROM already in WORK/NAME/rom.h5 (no reduce)")
    p.add_argument("--json", type=Path, default=RESULTS)
    p.add_argument("--work", type=Path, default=ROOT / "out" / "structure")
    p.add_argument("--cache", type=Path, default=ROOT / "out" / "cache")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)-7s "
                        "%(name)s: %(message)s", datefmt="%H:%M:%S")
    log.setLevel(logging.INFO)
    data = _load(a.json)
    kms = tuple(float(v) for v in a.km.split(","))
    if a.command == "show":
        print(show(data, tuple(f"{k:g}" for k in kms) if a.km else None))
        return 0
    if not a.name:
        p.error("measure needs a candidate NAME")
    ov = scene_overrides(a.set)
    c = measure(a.name, a.note, ov, kms, a.fmax, a.work, a.cache, a.reuse)
    data["candidates"][a.name] = c
    _save(a.json, data)
    for km, s in c["km"].items():
        log.info("%s k̄ %s: top %s, n %d, D peak %.0f Hz, f½/f %.2f | %s", a.name, km,
                 "–" if s["top_hz"] is None else f"{s['top_hz']:.0f} Hz ρ {s['top_rho']:.2f}",
                 s["n"], s["peak_hz"], s["half_ratio"],
                 ", ".join(f"{f:.0f}:{r:.2f}" for f, r in s["modes"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
