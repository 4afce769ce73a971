"""Meshing time and size of the pump for the ``coarse`` and ``fine`` presets.

Run: ``.venv/bin/python -m benchmarks.bench_geometry [--repeats N]``
Writes ``benchmarks/results/geometry.json`` (atomically).
"""

from __future__ import annotations

import argparse
import logging

from benchmarks.common import median_time, peak_rss_mb, records_table, write_json
from geometry import PumpParams, build_pump, gmsh_session, preset

LOG = logging.getLogger(__name__)


def bench(name: str, repeats: int) -> dict:
    """Median wall time [s] of ``build_pump`` (CAD + mesh + quality) and mesh size."""
    opts = preset(name)
    with gmsh_session():
        seconds, model = median_time(lambda: build_pump(PumpParams(), opts),
                                     repeats=repeats, warmup=0)
    q = model.quality
    return {
        "preset": name,
        "size_m": opts.size,
        "shaft_size_m": opts.shaft_size,
        "median_s": seconds,
        "repeats": repeats,
        "n_elements": q.n_elements,
        "n_nodes": q.n_nodes,
        "n_dofs_p2_vector": q.n_dofs,
        "min_sicn": q.min_sicn,
        "n_poor": q.n_poor,
        "poor_threshold": q.poor_threshold,
        "n_straightened": q.n_straightened,
        "per_part_nodes": {k: int(v["n_nodes"]) for k, v in q.per_part.items()},
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    rows = [bench(name, args.repeats) for name in ("coarse", "fine")]
    columns = ["preset", "size_m", "n_elements", "n_nodes", "n_dofs_p2_vector", "min_sicn",
               "n_poor", "median_s"]
    path = write_json("geometry", {
        "command": ".venv/bin/python -m benchmarks.bench_geometry",
        "summary": "Pump mesh (2 shafts + housing, 10-node tets): build+mesh wall time "
                   "(median) and size per preset.",
        "results": rows,
        "peak_rss_mb": peak_rss_mb(),
        "tables": [records_table("geometry: pump meshing", columns, rows)],
    })
    for r in rows:
        LOG.info("%s: %d nodes, %d P2 DOF, min SICN %.3f, %.2f s", r["preset"], r["n_nodes"],
                 r["n_dofs_p2_vector"], r["min_sicn"], r["median_s"])
    LOG.info("wrote %s", path)


if __name__ == "__main__":
    main()
