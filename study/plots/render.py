"""Off-screen pyvista rendering of the housing's vibration from the XDMF field.

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

__all__ = ["HousingRender", "render_housing", "render_housing_isolated"]


class HousingRender:
    """:func:`render_housing` of one XDMF file in a child process
    (``python -m study.plots.render XDMF PNG``), started at once and collected by
    :meth:`wait`: the parent draws its other plots meanwhile (the child's ~3 s of VTK
    import and rendering overlap them on a second core)."""

    def __init__(self, xdmf: Path, png: Path, timeout: float = 300.0) -> None:
        import subprocess
        import sys

        self.png, self.timeout = Path(png), timeout
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "study.plots.render", str(xdmf), str(png)],
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            self._error = ""
        except OSError as exc:
            self._proc, self._error = None, str(exc)

    def wait(self) -> Path | None:
        """The PNG once the child has written it; None (and a warning) if it failed."""
        import subprocess

        if self._proc is None:
            logger.warning("housing rendering failed: %s", self._error)
            return None
        try:
            _, err = self._proc.communicate(timeout=self.timeout)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.communicate()
            logger.warning("housing rendering failed: timed out after %g s", self.timeout)
            return None
        if self._proc.returncode != 0 or not self.png.exists():
            tail = (err or "").strip().splitlines()[-1:] or [""]
            logger.warning("housing rendering failed (exit %s): %s", self._proc.returncode,
                           tail[0][:200])
            return None
        logger.info("wrote %s", self.png)
        return self.png


def render_housing_isolated(xdmf: Path, png: Path, timeout: float = 300.0) -> Path | None:
    """:func:`render_housing` in a child process, waited for (:class:`HousingRender`)."""
    return HousingRender(xdmf, png, timeout).wait()


def _dynamic_frames(xdmf: Path) -> tuple[np.ndarray, dict, np.ndarray]:
    """Points, cells and the displacement frames of ``xdmf`` minus their mean over the period."""
    import meshio

    with meshio.xdmf.TimeSeriesReader(str(xdmf)) as rd:
        points, cells = rd.read_points_cells()
        frames = np.array([next(iter(rd.read_data(k)[1].values())) for k in range(rd.num_steps)])
    return points, cells, frames - frames.mean(axis=0)


def render_housing(xdmf: Path, png: Path, amplification: float = 0.05) -> Path | None:
    """Render the housing's vibration from ``xdmf`` to ``png``.

    Only the housing is drawn: the parts are meshed non-conformally, so the
    housing is the largest connected region of the mesh. The static (mean)
    deflection is removed; the housing is warped by the frame of largest dynamic
    displacement, scaled so that its maximum is ``amplification`` times the
    housing's bounding-box diagonal, and coloured by the dynamic amplitude
    max_t |u(t) - u_mean| in µm (true scale).
    """
    try:
        import meshio
        import pyvista as pv
    except ImportError as exc:
        logger.warning("housing rendering skipped: %s (install the 'viz' extra)", exc)
        return None
    try:
        points, cells, dyn = _dynamic_frames(xdmf)
        norms = np.linalg.norm(dyn, axis=2)                    # (frames, nodes)
        grid = pv.from_meshio(meshio.Mesh(points, cells))
        grid.point_data["amplitude (um)"] = norms.max(axis=0) * 1e6
        grid.point_data["u"] = dyn[int(np.argmax(norms.max(axis=1)))]
        housing = grid.connectivity("largest")
        best = float(np.max(housing.point_data["amplitude (um)"])) * 1e-6
        diag = float(np.linalg.norm(np.ptp(housing.points, axis=0)))
        scale = amplification * diag / max(best, 1e-300)
        warped = housing.warp_by_vector("u", factor=scale)
        pv.OFF_SCREEN = True
        p = pv.Plotter(off_screen=True, window_size=(1200, 800))
        surface = warped.extract_surface(algorithm="dataset_surface")
        p.add_mesh(surface, scalars="amplitude (um)", cmap="viridis", show_edges=False)
        p.add_text(f"{Path(xdmf).stem}: housing, dynamic displacement x{scale:.3g}",
                   font_size=10)
        p.view_isometric()
        png = Path(png)
        p.screenshot(str(png))
        p.close()
        logger.info("wrote %s", png)
        return png
    except Exception as exc:  # noqa: BLE001 - rendering is optional
        logger.warning("housing rendering failed: %s", exc)
        return None


if __name__ == "__main__":  # python -m study.plots.render XDMF PNG
    import sys

    logging.basicConfig(level=logging.WARNING)
    sys.exit(0 if render_housing(Path(sys.argv[1]), Path(sys.argv[2])) else 1)
