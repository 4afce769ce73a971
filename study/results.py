"""``results.h5``: atomic writing, continuation checkpoints and resume.

Layout (documented in ``docs/results-format.md``): ``/scene`` (file text and
SI values), ``/versions``, ``/gear_mesh`` (stiffness and transmission error
coefficients, backlash, static load, teeth), ``/system`` (lumped M, C, K, G) or
``/rom`` (written by :func:`reduction.save_rom` into the same file),
``/excitation`` (orders/harmonics and forces), ``/continuation`` (every point),
``/grazing`` and ``/folds``.

Every write goes to a temporary file in the destination folder, then ``os.replace``
(:func:`core.files.atomic_write`) — a reader (or a killed run) never sees a
half-written file. During the continuation the whole file is rewritten every
``checkpoint_every`` points with ``continuation.attrs["status"] = "running"``;
``--resume`` rebuilds the :class:`hbm.Branch` from it and continues from the last saved point.
"""
from __future__ import annotations

import logging
import platform
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from core.files import atomic_write

logger = logging.getLogger(__name__)

__all__ = ["FORMAT_VERSION", "write_results", "read_branch", "stored_key", "Checkpointer",
           "versions"]

#: Version of the results.h5 layout (attribute ``/format_version``).
FORMAT_VERSION = 1

_BRANCH_ARRAYS = ("rpm", "omega", "coefficients", "unknowns", "residual", "newton_iterations",
                  "stable", "floquet_max_real", "mesh_load_std", "mesh_load_max", "contact",
                  "contact_loss_fraction", "impacts_per_mesh_period", "margin_active",
                  "margin_reverse", "ipp", "tangents")


def _branch_array_fields() -> tuple[str, ...]:
    """Per-point array fields of :class:`hbm.Branch` (all fields but the metadata)."""
    import dataclasses

    from hbm import Branch

    meta = {"harmonics", "condensation", "rpm_start", "rpm_end", "omega_scale", "grazing",
            "folds", "status", "message", "next_step"}
    return tuple(f.name for f in dataclasses.fields(Branch) if f.name not in meta)


def _branch_arrays(branch) -> tuple[str, ...]:
    names = _branch_array_fields()
    lost = set(_BRANCH_ARRAYS) - set(names)
    if lost:
        raise RuntimeError(f"hbm.Branch lost the documented datasets {sorted(lost)}")
    return names


def versions() -> dict[str, str]:
    """Versions of the code and libraries that produced a file."""
    import scipy

    from study import __version__

    return {"geardyn": __version__, "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "h5py": h5py.__version__}


def _complex_pairs(d: dict[int, complex]) -> tuple[np.ndarray, np.ndarray]:
    keys = sorted(d)
    return np.array(keys, dtype=np.int64), np.array([complex(d[k]) for k in keys])


def write_static(f: h5py.File, scene, problem, extra: Callable[[h5py.File], None] | None = None,
                 stage_keys: dict[str, str] | None = None) -> None:
    """Write everything but the continuation: scene, versions, gear mesh, system, excitation."""
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["producer"] = "geardyn"
    g = f.create_group("scene")
    g.attrs["name"] = scene.name
    g.attrs["kind"] = scene.scene.kind
    g.create_dataset("text", data=scene.text)
    for k, v in (stage_keys or {}).items():
        g.attrs[f"stage_key_{k}"] = v
    v = f.create_group("versions")
    for k, s in versions().items():
        v.attrs[k] = s

    gm = f.create_group("gear_mesh")
    mesh = problem.mesh
    gm.attrs["te_kind"] = mesh.te_kind
    gm["n_teeth"] = mesh.n_teeth
    gm["backlash"] = mesh.backlash
    gm["static_load"] = mesh.static_load
    gm["torque"] = scene.load.torque
    gm["base_radius"] = scene.gear.base_radius
    gm["pressure_angle"] = scene.gear.pressure_angle
    gm["helix_angle"] = scene.gear.helix_angle
    k_idx, k_c = _complex_pairs(mesh.stiffness)
    gm["stiffness_harmonics"] = k_idx
    gm["stiffness"] = k_c
    t_idx, t_c = _complex_pairs(mesh.te)
    gm["te_harmonics"] = t_idx
    gm["te"] = t_c
    for name in ("stiffness", "te", "backlash", "static_load"):
        gm[name].attrs["unit"] = {"stiffness": "N/m"}.get(name, "N" if name == "static_load"
                                                          else "m")

    sysg = f.create_group("system")
    s = problem.system
    sysg.attrs["n_dof"] = s.n_dof
    sysg.attrs["source"] = "lumped" if scene.scene.kind == "lumped" else "rom"
    if s.n_dof <= 4096:
        for name in ("M", "C", "K", "G"):
            sysg[name] = getattr(s, name)

    ex = f.create_group("excitation")
    hs = problem.harmonics
    ex["harmonics"] = np.asarray(hs.indices, dtype=np.int64)
    ex["harmonics"].attrs["fundamental"] = hs.fundamental
    ex["harmonics"].attrs["divisor"] = hs.divisor
    ex["harmonics"].attrs["n_time"] = hs.n_time
    ex["harmonics"].attrs["aft"] = problem.aft
    ex["forces"] = problem.Fc
    ex["forces"].attrs["unit"] = "N"
    ex["forces"].attrs["meaning"] = "constant forcing per harmonic index (rows) and DOF"
    ex["forces_omega2"] = problem.Fu
    ex["forces_omega2"].attrs["unit"] = "N s^2"
    if extra is not None:
        extra(f)


def write_branch(f: h5py.File, branch, settings: dict | None = None) -> None:
    """Write ``/continuation``, ``/grazing`` and ``/folds`` of a (partial) branch."""
    c = f.create_group("continuation")
    for k in _branch_arrays(branch):
        v = np.asarray(getattr(branch, k))
        c.create_dataset(k, data=v.astype(np.int64).reshape(-1, 4) if k == "loops" else v)
    c["harmonics"] = np.asarray(branch.harmonics, dtype=np.int64)
    c.attrs["status"] = branch.status
    c.attrs["message"] = branch.message
    c.attrs["next_step"] = branch.next_step
    c.attrs["omega_scale"] = branch.omega_scale
    c.attrs["rpm_start"] = branch.rpm_start
    c.attrs["rpm_end"] = branch.rpm_end
    c.attrs["condensation"] = branch.condensation
    c.attrs["n_points"] = len(branch)
    for k, v in (settings or {}).items():
        c.attrs[k] = v
    units = {"rpm": "rpm", "omega": "rad/s", "coefficients": "m", "mesh_load_std": "N",
             "mesh_load_max": "N", "margin_active": "m", "margin_reverse": "m",
             "floquet_max_real": "1/s"}
    for k, u in units.items():
        c[k].attrs["unit"] = u
    g = f.create_group("grazing")
    g["rpm"] = np.array([p.rpm for p in branch.grazing], dtype=float)
    g["kind"] = np.array([p.kind for p in branch.grazing], dtype=h5py.string_dtype())
    g["side"] = np.array([p.side for p in branch.grazing], dtype=h5py.string_dtype())
    fo = f.create_group("folds")
    fo["rpm"] = np.array(branch.folds, dtype=float)


def write_results(path: str | Path, scene, problem, branch, *, settings: dict | None = None,
                  extra: Callable[[h5py.File], None] | None = None,
                  stage_keys: dict[str, str] | None = None) -> None:
    """Write a complete ``results.h5`` atomically."""
    with atomic_write(path) as tmp, h5py.File(tmp, "w") as f:
        write_static(f, scene, problem, extra, stage_keys)
        write_branch(f, branch, settings)


def stored_key(path: str | Path, name: str = "stage_key_hbm") -> str:
    """The stage key ``name`` recorded in the ``/scene`` attributes of ``path`` ("" when
    the file or the attribute is missing)."""
    try:
        with h5py.File(path, "r") as f:
            return str(f["scene"].attrs.get(name, ""))
    except (OSError, KeyError):
        return ""


def read_branch(path: str | Path, problem=None, expected_key: str | None = None,
                key_name: str = "stage_key_hbm"):
    """Rebuild the :class:`hbm.Branch` stored in ``results.h5`` (for ``--resume``).

    Returns ``None`` when the file has no continuation, was written by another
    scene/problem (``expected_key`` differs from the stored ``/scene`` attribute
    ``key_name``, by default the hbm stage key), or
    cannot be read; the reason is logged.
    """
    from hbm import Branch, GrazingPoint

    p = Path(path)
    if not p.exists():
        return None
    try:
        with h5py.File(p, "r") as f:
            if "continuation" not in f:
                return None
            if expected_key is not None and \
                    f["scene"].attrs.get(key_name, "") != expected_key:
                logger.debug("%s: %s differs; not read", p, key_name)   # the caller says why
                return None
            c = f["continuation"]
            arrays = {k: c[k][()] for k in _branch_array_fields() if k in c}
            missing = set(_branch_array_fields()) - set(arrays) - {"reversals", "leaps", "loop",
                                                                 "loops"}
            if missing:
                raise KeyError(f"continuation datasets missing: {sorted(missing)}")
            grazing = [GrazingPoint(float(r), k.decode() if isinstance(k, bytes) else str(k),
                                    s.decode() if isinstance(s, bytes) else str(s))
                       for r, k, s in zip(f["grazing/rpm"][()], f["grazing/kind"][()],
                                          f["grazing/side"][()], strict=True)]
            br = Branch(harmonics=tuple(int(i) for i in c["harmonics"][()]),
                        condensation=str(c.attrs["condensation"]),
                        rpm_start=float(c.attrs["rpm_start"]), rpm_end=float(c.attrs["rpm_end"]),
                        omega_scale=float(c.attrs["omega_scale"]), **arrays, grazing=grazing,
                        folds=[float(x) for x in f["folds/rpm"][()]],
                        status=str(c.attrs["status"]), message=str(c.attrs["message"]),
                        next_step=float(c.attrs["next_step"]))
    except (OSError, KeyError, ValueError, TypeError) as exc:
        logger.warning("cannot resume from %s (%s); starting over", p, exc)
        return None
    if problem is not None and (len(br) == 0 or br.unknowns.shape[1] != problem.n_unknowns):
        logger.warning("%s does not match this problem; starting over", p)
        return None
    return br


class Checkpointer:
    """``on_point`` callback of :func:`hbm.trace`: rewrites results.h5 every n points.

    Parameters
    ----------
    path
        results.h5 path.
    every
        Points between checkpoints (the final branch is always written by the caller).
    write
        ``write(branch)`` writing the full file atomically.
    progress
        Optional callable(branch) for progress reporting.
    """

    def __init__(self, path: str | Path, every: int, write: Callable, progress=None) -> None:
        self.path = Path(path)
        self.every = int(every)
        self.write = write
        self.progress = progress
        self.last_saved = -1
        self.n_written = 0

    def __call__(self, branch) -> None:
        n = len(branch)
        if self.progress is not None:
            self.progress(branch)
        if branch.status == "running" and n > 0 and n % self.every == 0 and n != self.last_saved:
            self.write(branch)
            self.last_saved = n
            self.n_written += 1
            logger.debug("checkpoint: %d points saved to %s", n, self.path)
