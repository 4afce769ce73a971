"""Parameter studies (``--set key=v1,v2``): overlay plot and table of the variants."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from core.files import atomic_write
from study.outputs.curves import contact_intervals
from study.plots.speed import forced_response_overlay

logger = logging.getLogger(__name__)

__all__ = ["write_variants", "variants_table"]


def _label(ov: dict) -> str:
    return ", ".join(f"{k.split('.')[-1]}={v}" for k, v in ov.items())


def variants_table(results: list) -> str:
    """Markdown table: one row per variant with its key numbers and grazing speeds."""
    rows = ["| variant | points | max std (N) | at rpm | grazing (rpm) | impacts (rpm) | stages |",
            "|---|---:|---:|---:|---|---|---|"]
    for ov, r in results:
        br = r.branch
        i = int(np.argmax(br.element(0).mesh_load_std))
        gz = ", ".join(f"{g.rpm:.1f}" for g in sorted(br.grazing, key=lambda g: g.rpm)) or "–"
        iv = contact_intervals(br)
        imp = "; ".join(f"{'SS' if c == 1 else 'DS'} {a:.0f}–{b:.0f}"
                        for c, ivs in iv.items() for a, b in ivs) or "none"
        st = ", ".join(f"{k}:{v.split(' ')[0]}" for k, v in r.stages.items()
                       if not v.startswith("skipped"))
        if br.status != "completed":
            st = f"stopped at {br.rpm[-1]:.0f} rpm ({br.status})"
        rows.append(f"| {_label(ov)} | {len(br)} | {br.element(0).mesh_load_std[i]:.4g} | "
                    f"{br.rpm[i]:.1f} | {gz} | {imp} | {st} |")
    return "\n".join(rows)


def write_variants(out: Path, results: list) -> tuple[Path, Path]:
    """``OUT/variants_forced_response.png`` and ``OUT/variants.md``."""
    out = Path(out)
    png = forced_response_overlay([r.branch for _, r in results],
                                  [_label(ov) for ov, _ in results],
                                  out / "variants_forced_response.png")
    text = "# Parameter study\n\n" + variants_table(results) + \
        "\n\nSS: single-sided impacts, DS: double-sided impacts.\n\n" \
        "![variants](variants_forced_response.png)\n"
    md = out / "variants.md"
    with atomic_write(md, "w") as f:
        f.write(text)
    logger.info("wrote %s and %s", png, md)
    return png, md
