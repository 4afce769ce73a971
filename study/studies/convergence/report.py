"""Outputs of the convergence study: ``convergence.csv``, ``convergence.md`` (table and
recommendation) and ``pareto.png`` (max error against cost, one series per knob)."""
from __future__ import annotations

import csv
import io
import logging
from pathlib import Path

from core.files import atomic_write
from study.scene.data import Scene
from study.studies.convergence.knobs import fmt_value
from study.studies.convergence.measures import MIN_VALUES, ConvergenceResult, Row

logger = logging.getLogger(__name__)

__all__ = ["table_markdown", "recommendation_text", "write_outputs", "pareto_plot",
           "cost_text", "write_text"]

_COLUMNS = ["knob", "value", "reference", "status", "seconds", "seconds_run", "points",
            "stages", "rom_freq_err", "curve_err", "grazing_ref", "grazing_matched",
            "grazing_fig11", "grazing_missing", "grazing_extra", "grazing_max_abs_rpm",
            "grazing_rel_err", "housing_err", "housing_metric", "max_err", "within_tol",
            "recommended", "overrides"]


def cost_text(r: Row) -> str:
    """A row's cost as written in the table and the log."""
    return "unknown" if r.seconds is None else f"{r.seconds:.2f} s"


def _csv_row(r: Row, tol: float) -> dict:
    g = r.grazing

    def f(x):
        return "" if x is None else f"{x:.6g}"
    return {"knob": r.setting.knob, "value": fmt_value(r.setting.value),
            "reference": int(r.reference), "status": r.status, "seconds": f(r.seconds),
            "seconds_run": f"{r.seconds_run:.3f}", "points": r.points,
            "stages": " ".join(f"{k}:{v}" for k, v in r.stages.items() if v != "skipped"),
            "rom_freq_err": f(r.rom_freq_err), "curve_err": f(r.curve_err),
            "grazing_ref": "" if g is None else len(g.pairs) + len(g.missing),
            "grazing_matched": "" if g is None else len(g.pairs),
            "grazing_fig11": "" if g is None else g.fig11,
            "grazing_missing": "" if g is None else " ".join(f"{x:.1f}" for x in g.missing),
            "grazing_extra": "" if g is None else " ".join(f"{x:.1f}" for x in g.extra),
            "grazing_max_abs_rpm": "" if g is None else f"{g.max_abs_rpm:.4g}",
            "grazing_rel_err": "" if g is None else f"{g.max_rel:.6g}",
            "housing_err": f(r.housing_err), "housing_metric": r.housing_metric,
            "max_err": f(r.max_err), "within_tol": int(r.within(tol)),
            "recommended": int(r.recommended),
            "overrides": ";".join(f"{k}={fmt_value(v)}" for k, v in r.setting.overrides.items())}


def write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_write(path, "w") as f:
        f.write(text)


def table_markdown(result: ConvergenceResult) -> str:
    """The Markdown table of all rows (one per setting)."""
    fe = any(r.rom_freq_err is not None for r in result.rows)
    house = any(r.housing_err is not None for r in result.rows)
    head = ["knob", "value", "cost (s)", "points"]
    head += ["ROM freq. err"] if fe else []
    head += ["curve err", "grazing: matched (±1 %) / ref", "grazing err (rpm, rel.)",
             "missing / extra"]
    head += ["housing err"] if house else []
    head += ["max err", ""]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def e(x):
        return "–" if x is None else f"{x:.2e}"
    for r in result.rows:
        g = r.grazing
        cells = [r.setting.knob, fmt_value(r.setting.value) + (" (ref)" if r.reference else ""),
                 "n/a" if r.seconds is None else f"{r.seconds:.2f}", str(r.points)]
        cells += [e(r.rom_freq_err)] if fe else []
        if g is None:
            cells += [e(r.curve_err), "–", "–", "–"]
        else:
            n_ref = len(g.pairs) + len(g.missing)
            cells += [e(r.curve_err), f"{len(g.pairs)} ({g.fig11}) / {n_ref}",
                      f"{g.max_abs_rpm:.3g}, {g.max_rel:.2e}",
                      (", ".join(f"{x:.0f}" for x in g.missing) or "–") + " / " +
                      (", ".join(f"{x:.0f}" for x in g.extra) or "–")]
        cells += [e(r.housing_err) + (f" ({r.housing_metric})" if r.housing_metric else "")] \
            if house else []
        mark = "**recommended**" if r.recommended else ("" if r.status == "ok" else r.status)
        cells += [e(r.max_err), mark]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def recommendation_text(result: ConvergenceResult) -> str:
    """The recommended value of each knob, and the same as scene overrides."""
    lines = [f"Recommendation (tolerance {result.tol:g}: cheapest value of each knob, other "
             f"than its reference, whose errors are all within it; at least {MIN_VALUES} "
             "values per knob):", ""]
    for knob in dict.fromkeys(r.setting.knob for r in result.rows):
        r = result.recommendation.get(knob)
        if r is None:
            why = result.verdicts.get(knob, "its reference setting failed, so no errors "
                                             "were computed")
            lines.append(f"- {knob}: **no recommendation** — {why}")
            continue
        lines.append(f"- {knob} = {fmt_value(r.setting.value)} (cost {cost_text(r)}, max error "
                     f"{(r.max_err or 0.0):.2e} against the reference)")
    failed = [r for r in result.rows if r.status != "ok"]
    if failed:
        lines += ["", "Failed settings (their points are in `runs/<setting>/results.h5`):", ""]
        lines += [f"- {r.setting.label}: {r.status}, {r.points} points: {r.note}"
                  for r in failed]
    ov = result.overrides()
    if ov:
        lines += ["", "As scene overrides: " + " ".join(
            f"`--set {k}={fmt_value(v)}`" for k, v in ov.items())]
    return "\n".join(lines)


def write_outputs(result: ConvergenceResult, out: Path, scene: Scene) -> list[Path]:
    """``convergence.csv``, ``convergence.md`` and ``pareto.png`` in ``out``."""
    out = Path(out)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in result.rows:
        w.writerow(_csv_row(r, result.tol))
    write_text(out / "convergence.csv", buf.getvalue())
    png = pareto_plot(result, out / "pareto.png")
    md = [f"# Convergence study: {scene.name}", "",
          "One knob varied at a time around the scene's settings; errors are relative, "
          "against the knob's most converged value (ref). Cost: wall time of the stages "
          "the knob changes. See docs/convergence.md for the definitions.", "",
          table_markdown(result), "", recommendation_text(result), "",
          "![error against cost](pareto.png)", ""]
    write_text(out / "convergence.md", "\n".join(md))
    text = recommendation_text(result)
    logger.info("%s", text)
    return [out / "convergence.csv", out / "convergence.md", png]


def pareto_plot(result: ConvergenceResult, path: Path) -> Path:
    """Max error against cost, log-log, one series per knob, recommended points starred."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in result.rows if r.max_err is not None and r.seconds is not None]
    pos = [r.max_err for r in rows if r.max_err > 0]
    floor = min(pos + [result.tol]) / 10          # where the references (error 0) are drawn
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for i, knob in enumerate(dict.fromkeys(r.setting.knob for r in rows)):
        kr = sorted((r for r in rows if r.setting.knob == knob), key=lambda r: r.seconds)
        x = [max(r.seconds, 1e-3) for r in kr]
        y = [max(r.max_err, floor) for r in kr]
        line, = ax.plot(x, y, "o-", color=f"C{i}", label=knob)
        for r, xi, yi in zip(kr, x, y, strict=True):
            ax.annotate(fmt_value(r.setting.value) + (" (ref)" if r.reference else ""), (xi, yi),
                        textcoords="offset points", xytext=(4, 4), fontsize=7)
            if r.reference:
                ax.plot([xi], [yi], "o", ms=10, mfc="none", mec=f"C{i}")
            if r.recommended:
                ax.plot([xi], [yi], "*", ms=16, mfc="none", mec="k", mew=1.5)
    ax.axhline(result.tol, color="0.5", ls="--", lw=1, label=f"tol {result.tol:g}")
    ax.plot([], [], "*", ms=12, mfc="none", mec="k", label="recommended")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall time of the knob's stages (s)")
    ax.set_ylabel(f"max relative error (ref: 0, drawn at {floor:.1e})")
    ax.set_title("Error against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        with atomic_write(path) as tmp:
            fig.savefig(tmp, dpi=120)
    finally:
        plt.close(fig)
    return path
