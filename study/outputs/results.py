"""``results.h5``: atomic writing, continuation checkpoints and resume.

Layout (documented in ``docs/results-format.md``): ``/scene`` (file text and the
scene as run), ``/versions``, ``/provenance`` (version, git revision, stage times),
``/gear_mesh`` (stiffness and transmission error coefficients, backlash, static load,
teeth), ``/system`` (lumped M, C, K, G) or
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

import json
import logging
import platform
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from core.files import atomic_write

logger = logging.getLogger(__name__)

__all__ = ["FORMAT_VERSION", "write_results", "read_branch", "branch_from_group",
           "stored_key", "Checkpointer", "versions", "replace_group"]

@contextmanager
def replace_group(path: str | Path, name: str) -> Iterator[h5py.Group]:
    """Replace the group ``name`` of an existing ``results.h5`` by an empty one, given to
    the ``with`` block to fill. Atomic: a copy of the file is updated, then renamed over
    it, so everything else in it is kept as it was and a failure leaves the file whole."""
    path = Path(path)
    with atomic_write(path) as tmp:
        shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a") as f:
            if name in f:
                del f[name]
            yield f.create_group(name)


#: Version of the results.h5 layout (attribute ``/format_version``).
FORMAT_VERSION = 1

#: The documented per-point datasets of /continuation: the branch's own arrays and the
#: gear mesh's statistics (docs/results-format.md).
_BRANCH_ARRAYS = ("rpm", "omega", "coefficients", "unknowns", "residual", "newton_iterations",
                  "stable", "floquet_max_real", "mesh_load_std", "mesh_load_max", "contact",
                  "contact_loss_fraction", "impacts_per_mesh_period", "margin_active",
                  "margin_reverse", "ipp", "tangents")
# Branch fields that are not per-point datasets of /continuation
_META = {"harmonics", "condensation", "rpm_start", "rpm_end", "omega_scale", "grazing",
         "folds", "status", "message", "next_step", "stats", "element_names",
         "element_statistics"}


def _branch_array_fields() -> tuple[str, ...]:
    """Per-point array fields and counters of :class:`hbm.Branch` (all fields but the
    metadata and the per-element table)."""
    import dataclasses

    from hbm import Branch

    return tuple(f.name for f in dataclasses.fields(Branch) if f.name not in _META)


def _branch_datasets(branch) -> dict[str, np.ndarray]:
    """The /continuation datasets of a branch: its arrays and counters, and its
    per-element table, each statistic ``(n_points, ...)`` for one element (the element axis
    dropped) and ``(n_points, n_elements, ...)`` for several."""
    out = {k: np.asarray(getattr(branch, k)) for k in _branch_array_fields()}
    single = branch.n_elements <= 1
    for k, v in branch.stats.items():
        out[k] = v[:, 0] if single and v.ndim >= 2 else v
    lost = set(_BRANCH_ARRAYS) - set(out)
    if "mesh_load_std" not in branch.stats:     # no gear mesh: its statistics are not due
        lost -= {"mesh_load_std", "mesh_load_max", "contact", "contact_loss_fraction",
                 "impacts_per_mesh_period", "margin_active", "margin_reverse", "ipp"}
    if lost:
        raise RuntimeError(f"hbm.Branch lost the documented datasets {sorted(lost)}")
    return out


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
                 stage_keys: dict[str, str] | None = None, stages: dict | None = None) -> None:
    """Write everything but the continuation: scene (file text and the scene as run),
    versions, provenance (``stages``: stage -> how it was served, with its wall time),
    gear mesh, system, excitation."""
    from study.outputs.provenance import write_provenance, write_scene_as_run

    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["producer"] = "geardyn"
    g = f.create_group("scene")
    g.attrs["name"] = scene.name
    g.attrs["kind"] = scene.scene.kind
    g.create_dataset("text", data=scene.text)
    write_scene_as_run(g, scene)
    for k, v in (stage_keys or {}).items():
        g.attrs[f"stage_key_{k}"] = v
    v = f.create_group("versions")
    for k, s in versions().items():
        v.attrs[k] = s
    write_provenance(f, stages)

    _write_elements(f, scene, problem)

    sysg = f.create_group("system")
    s = problem.system
    sysg.attrs["n_dof"] = s.n_dof
    sysg.attrs["source"] = "lumped" if scene.scene.kind == "lumped" else "rom"
    if s.n_dof <= 4096:
        for name in ("M", "C", "K"):
            sysg[name] = getattr(s, name)
        sysg["G"] = problem.directions[0] if problem.n_elements == 1 else problem.G

    ex = f.create_group("excitation")
    hs = problem.harmonics
    ex["harmonics"] = np.asarray(hs.indices, dtype=np.int64)
    ex["harmonics"].attrs["fundamental"] = hs.fundamental
    if hs.ratio.denominator == 1:
        ex["harmonics"].attrs["divisor"] = hs.integer_ratio
    else:
        ex["harmonics"].attrs["ratio"] = str(hs.ratio)
    ex["harmonics"].attrs["n_time"] = hs.n_time
    ex["harmonics"].attrs["aft"] = problem.aft
    ex["forces"] = problem.Fc
    ex["forces"].attrs["unit"] = "N"
    ex["forces"].attrs["meaning"] = "constant forcing per harmonic index (rows) and DOF"
    ex["forces_omega2"] = problem.Fu
    ex["forces_omega2"].attrs["unit"] = "N s^2"
    if extra is not None:
        extra(f)


def _write_elements(f: h5py.File, scene, problem) -> None:
    """``/gear_mesh`` for a problem whose one element is a gear mesh; else one group
    ``/elements/<i>`` per element (its kind and name, and a gear mesh's data)."""
    from hbm import GearMesh

    els = problem.elements
    if len(els) == 1 and isinstance(els[0], GearMesh):
        _write_gear_mesh(f.create_group("gear_mesh"), scene, els[0])
        return
    grp = f.create_group("elements")
    for i, el in enumerate(els):
        g = grp.create_group(str(i))
        g.attrs["kind"] = el.kind
        g.attrs["name"] = el.name
        g["direction"] = el.direction
        if isinstance(el, GearMesh):
            _write_gear_mesh(g, scene, el)


def _write_gear_mesh(gm, scene, mesh) -> None:
    """A gear mesh's data (n_teeth, backlash, static load, stiffness and TE harmonics)."""
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


def write_branch(f: h5py.File, branch, settings: dict | None = None) -> None:
    """Write ``/continuation``, ``/grazing`` and ``/folds`` of a (partial) branch."""
    c = f.create_group("continuation")
    for k, v in _branch_datasets(branch).items():
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
    if branch.n_elements > 1:
        c.attrs["elements"] = list(branch.element_names)
        c.attrs["element_statistics"] = json.dumps([list(s) for s in
                                                    branch.element_statistics])
    for k, v in (settings or {}).items():
        c.attrs[k] = v
    units = {"rpm": "rpm", "omega": "rad/s", "coefficients": "m", "mesh_load_std": "N",
             "mesh_load_max": "N", "margin_active": "m", "margin_reverse": "m",
             "floquet_max_real": "1/s", "floquet_amplification": "1"}
    for k, u in units.items():
        if k in c:
            c[k].attrs["unit"] = u
    g = f.create_group("grazing")
    g["rpm"] = np.array([p.rpm for p in branch.grazing], dtype=float)
    g["kind"] = np.array([p.kind for p in branch.grazing], dtype=h5py.string_dtype())
    g["side"] = np.array([p.side for p in branch.grazing], dtype=h5py.string_dtype())
    if branch.n_elements > 1:
        g["element"] = np.array([p.element for p in branch.grazing], dtype=np.int64)
    fo = f.create_group("folds")
    fo["rpm"] = np.array(branch.folds, dtype=float)


def write_results(path: str | Path, scene, problem, branch, *, settings: dict | None = None,
                  extra: Callable[[h5py.File], None] | None = None,
                  stage_keys: dict[str, str] | None = None, stages: dict | None = None) -> None:
    """Write a complete ``results.h5`` atomically."""
    with atomic_write(path) as tmp, h5py.File(tmp, "w") as f:
        write_static(f, scene, problem, extra, stage_keys, stages)
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
            br = branch_from_group(f)
    except (OSError, KeyError, ValueError, TypeError) as exc:
        logger.warning("cannot resume from %s (%s); starting over", p, exc)
        return None
    if problem is not None and (len(br) == 0 or br.unknowns.shape[1] != problem.n_unknowns):
        logger.warning("%s does not match this problem; starting over", p)
        return None
    return br


def branch_from_group(g: h5py.Group, element_name: str | None = None):
    """The :class:`hbm.Branch` written by :func:`write_branch` into ``g`` (the file's root,
    or a ``/branches/<name>`` group): its ``continuation/``, ``grazing/`` and ``folds/``.
    ``element_name``: the one element's label (default: from the file, which does not
    store it for one element). Raises KeyError when a documented dataset is missing."""
    from hbm import Branch, GrazingPoint

    c = g["continuation"]
    fields = _branch_array_fields()
    arrays = {k: c[k][()] for k in fields if k in c}
    missing = set(fields) - set(arrays) - {"reversals", "leaps", "loop", "loops",
                                           "floquet_amplification", "stability_grazing"}
    missing |= {"rpm", "omega", "unknowns", "coefficients"} - set(c)
    if missing:
        raise KeyError(f"continuation datasets missing: {sorted(missing)}")
    names = [str(x.decode() if isinstance(x, bytes) else x)
             for x in c.attrs.get("elements", [])]
    single = len(names) <= 1
    # the per-element table: every other dataset, its element axis restored
    stats = {k: (c[k][()][:, None] if single and c[k].ndim >= 1 and len(c[k]) else
                 c[k][()]) for k in c if k not in fields and k != "harmonics"}
    elements = g["grazing/element"][()] if "grazing/element" in g else \
        [0] * len(g["grazing/rpm"])
    grazing = [GrazingPoint(float(r), k.decode() if isinstance(k, bytes) else str(k),
                            s.decode() if isinstance(s, bytes) else str(s), int(e))
               for r, k, s, e in zip(g["grazing/rpm"][()], g["grazing/kind"][()],
                                     g["grazing/side"][()], elements, strict=True)]
    return Branch(harmonics=tuple(int(i) for i in c["harmonics"][()]),
                  condensation=str(c.attrs["condensation"]),
                  rpm_start=float(c.attrs["rpm_start"]), rpm_end=float(c.attrs["rpm_end"]),
                  omega_scale=float(c.attrs["omega_scale"]), **arrays, stats=stats,
                  element_names=tuple(names) or (element_name or _element_name(g.file),),
                  element_statistics=tuple(tuple(x) for x in json.loads(
                      c.attrs.get("element_statistics", "[]"))), grazing=grazing,
                  folds=[float(x) for x in g["folds/rpm"][()]],
                  status=str(c.attrs["status"]), message=str(c.attrs["message"]),
                  next_step=float(c.attrs["next_step"]))


def _element_name(f: h5py.File) -> str:
    """The one element's label in a file without an ``elements`` attribute: a gear mesh's
    default name when ``/gear_mesh`` holds it."""
    return "gear mesh" if "gear_mesh" in f else "element 0"


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
