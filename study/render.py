"""Off-screen pyvista rendering of the deformed housing and shafts from the XDMF field.

Optional (``pyvista`` and ``meshio``, the ``viz`` extra); a missing package or a
failing renderer only logs a warning. :func:`render_housing_isolated` runs the
rendering in a separate Python process: VTK can abort natively when its libraries
share a process with DOLFINx/PETSc, and that must not take a finished run down.
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

__all__ = ["render_housing", "render_housing_isolated"]


def render_housing_isolated(xdmf: Path, png: Path, timeout: float = 300.0) -> Path | None:
    """:func:`render_housing` in a child process (``python -m study.render XDMF PNG``)."""
    import subprocess
    import sys

    try:
        p = subprocess.run([sys.executable, "-m", "study.render", str(xdmf), str(png)],
                           capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as exc:
        logger.warning("housing rendering failed: %s", exc)
        return None
    if p.returncode != 0 or not Path(png).exists():
        tail = (p.stderr or "").strip().splitlines()[-1:] or [""]
        logger.warning("housing rendering failed (exit %s): %s", p.returncode, tail[0][:200])
        return None
    logger.info("wrote %s", png)
    return Path(png)


def render_housing(xdmf: Path, png: Path, amplification: float = 0.05) -> Path | None:
    """Render the frame of largest displacement of ``xdmf`` to ``png``.

    The displacement is scaled so that its maximum is ``amplification`` times the
    model's bounding-box diagonal; colours show |u| in µm (true scale).
    """
    try:
        import meshio
        import pyvista as pv
    except ImportError as exc:
        logger.warning("housing rendering skipped: %s (install the 'viz' extra)", exc)
        return None
    try:
        with meshio.xdmf.TimeSeriesReader(str(xdmf)) as rd:
            points, cells = rd.read_points_cells()
            best, frame = -1.0, None
            for k in range(rd.num_steps):
                _, pdata, _ = rd.read_data(k)
                u = next(iter(pdata.values()))
                m = float(np.max(np.linalg.norm(u, axis=1)))
                if m > best:
                    best, frame = m, u
        grid = pv.from_meshio(meshio.Mesh(points, cells))
        mag = np.linalg.norm(frame, axis=1)
        diag = float(np.linalg.norm(np.ptp(points, axis=0)))
        scale = amplification * diag / max(best, 1e-300)
        grid.point_data["|u| (um)"] = mag * 1e6
        grid.point_data["u"] = frame
        warped = grid.warp_by_vector("u", factor=scale)
        pv.OFF_SCREEN = True
        p = pv.Plotter(off_screen=True, window_size=(1200, 800))
        p.add_mesh(warped.extract_surface(), scalars="|u| (um)", cmap="viridis",
                   show_edges=False)
        p.add_text(f"{Path(xdmf).stem}: displacement x{scale:.3g}", font_size=10)
        p.view_isometric()
        png = Path(png)
        p.screenshot(str(png))
        p.close()
        logger.info("wrote %s", png)
        return png
    except Exception as exc:  # noqa: BLE001 - rendering is optional
        logger.warning("housing rendering failed: %s", exc)
        return None


if __name__ == "__main__":  # python -m study.render XDMF PNG
    import sys

    logging.basicConfig(level=logging.WARNING)
    sys.exit(0 if render_housing(Path(sys.argv[1]), Path(sys.argv[2])) else 1)
