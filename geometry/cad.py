"""CAD parts (STEP, IGES, BREP) read into the current gmsh model through OpenCASCADE.

A part is one file of one material: its solids become one physical volume. The caller
states the length unit of the numbers in the file (:data:`LENGTH_UNITS`; CAD is usually
in mm); the solids are scaled to metres while they are read (gmsh's
``Geometry.OCCScaling``: a uniform ``gp_Trsf`` that keeps planes and cylinders analytic,
whereas ``occ.dilate`` turns every face into a B-spline and moved the pump housing's
volume by 0.15 %).

Units of STEP and IGES files. OpenCASCADE converts the lengths of a STEP or IGES file
from the unit the file declares to millimetres (gmsh 4.8 has no ``OCCTargetUnit``): a
STEP file that declares metres and holds 0.3 is read as 300. The declared unit is read
from the file here (:func:`declared_unit`), so that ``unit`` keeps one meaning, the unit
of the numbers written in the file; when the caller's unit and the declared one differ,
the caller wins and a warning names both (files written by tools that ignore units, such
as gmsh from a model in metres, declare mm and hold metres). A BREP file has no unit.

Only the highest-dimensional entities of a file are read (``importShapes(highestDimOnly=
True)``): construction curves or surfaces beside the solids are left out.

Checks before any meshing (each a :class:`core.errors.InputError` naming the field):
the file exists and is readable, OpenCASCADE reads solids from it, every solid is closed
(each boundary curve shared by exactly two face sides) with a positive volume, and its
bounding box is plausible for the unit (:data:`PLAUSIBLE_SIZE`, the box is printed).
Small defects are healed with gmsh's OpenCASCADE healing (``occ.healShapes``: degenerate
edges, small edges and faces, sewing, solids from closed shells) when the checks fail
(``HealOptions.mode = "auto"``), always, or never. Healing is not done on a valid solid
by default: it splits periodic faces (the pump housing's 8 cylinders became 12).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import re
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import gmsh
import numpy as np

from core.errors import InputError
from core.files import atomic_write

from .session import ensure_initialized

log = logging.getLogger(__name__)

#: Length units a file may be written in -> metres per unit.
LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254, "ft": 0.3048}
#: File suffixes read by OpenCASCADE -> format.
CAD_SUFFIXES = {".step": "step", ".stp": "step", ".iges": "iges", ".igs": "iges",
                ".brep": "brep", ".brp": "brep"}
#: Default plausible range of a part's bounding-box diagonal [m] (a gearbox housing or a
#: shaft: 1 cm to 10 m); outside, the unit is probably wrong.
PLAUSIBLE_SIZE = (0.01, 10.0)
#: Healing modes.
HEAL_MODES = ("auto", "always", "never")
# STEP SI prefixes and named units, in mm
_STEP_PREFIX = {"$": 1e3, ".MILLI.": 1.0, ".CENTI.": 10.0, ".DECI.": 100.0, ".KILO.": 1e6,
                ".MICRO.": 1e-3}
_NAMED_UNITS_MM = {"INCH": 25.4, "FOOT": 304.8, "MILLIMETRE": 1.0, "METRE": 1000.0}
# IGES global parameter 14 (units flag) -> mm
_IGES_UNITS_MM = {1: 25.4, 2: 1.0, 4: 304.8, 5: 1609344.0, 6: 1000.0, 7: 1e6, 8: 0.0254,
                  9: 1e-3, 10: 10.0, 11: 2.54e-5}


@dataclass(frozen=True)
class HealOptions:
    """OpenCASCADE shape healing of a part (gmsh ``occ.healShapes``).

    Attributes
    ----------
    mode : str
        ``"auto"`` heals only when a check fails (no solid, an open or inverted solid),
        ``"always"`` heals every part, ``"never"`` refuses a part that fails.
    tolerance : float
        Healing tolerance [m]: edges and faces smaller than this are removed, gaps below
        it sewn.
    fix_degenerated, fix_small_edges, fix_small_faces, sew_faces, make_solids : bool
        The healing steps (gmsh's ``Geometry.OCCFix*``, ``OCCSewFaces``,
        ``OCCMakeSolids``).
    """

    mode: str = "auto"
    tolerance: float = 1e-6
    fix_degenerated: bool = True
    fix_small_edges: bool = True
    fix_small_faces: bool = True
    sew_faces: bool = True
    make_solids: bool = True

    def validate(self, where: str) -> None:
        """Raise :class:`InputError` naming ``{where}.heal.<field>``."""
        if self.mode not in HEAL_MODES:
            raise InputError.of(f"{where}.heal.mode", self.mode,
                                f"must be one of {', '.join(map(repr, HEAL_MODES))}")
        if not (math.isfinite(self.tolerance) and self.tolerance > 0):
            raise InputError.of(f"{where}.heal.tolerance", self.tolerance, "must be > 0",
                                unit="m")


@dataclass(frozen=True)
class CadPart:
    """One CAD file read as one part (one material, one physical volume).

    Attributes
    ----------
    name : str
        Physical volume name (``"housing"``, ``"shaft_in"``); the material is chosen by it.
    path : str or Path
        STEP (``.step``, ``.stp``), IGES (``.iges``, ``.igs``) or BREP (``.brep``) file.
    unit : str
        Unit of the lengths written in the file, a key of :data:`LENGTH_UNITS`.
    size : float, optional
        Element size on this part [m]; default the mesh options' ``size``.
    heal : HealOptions
    plausible_size : (float, float)
        Allowed range of the bounding-box diagonal [m].
    """

    name: str
    path: str | os.PathLike[str]
    unit: str = "mm"
    size: float | None = None
    heal: HealOptions = field(default_factory=HealOptions)
    plausible_size: tuple[float, float] = PLAUSIBLE_SIZE

    def validate(self, where: str = "part") -> None:
        """Check the fields and the file before any gmsh work (:class:`InputError`)."""
        if not isinstance(self.name, str) or not re.fullmatch(r"[A-Za-z][\w-]*", self.name):
            raise InputError.of(f"{where}.name", self.name,
                                "must be a name of letters, digits, '_' or '-'")
        if self.unit not in LENGTH_UNITS:
            raise InputError.of(f"{where}.unit", self.unit,
                                f"must be one of {', '.join(map(repr, LENGTH_UNITS))}")
        if self.size is not None and not (math.isfinite(self.size) and self.size > 0):
            raise InputError.of(f"{where}.size", self.size, "must be > 0", unit="m")
        lo, hi = self.plausible_size
        if not (0 < lo < hi):
            raise InputError.of(f"{where}.plausible_size", self.plausible_size,
                                "must be (low, high) with 0 < low < high", unit="m")
        self.heal.validate(where)
        check_file(self.path, f"{where}.path", CAD_SUFFIXES)


@dataclass
class ImportedSolid:
    """What was read of one :class:`CadPart` (model in metres).

    Attributes
    ----------
    name : str
    volumes : list[int]
        gmsh volume tags of the part.
    bbox : numpy.ndarray, shape (2, 3)
        Bounding box [m] (min corner, max corner).
    volume, area : float
        Solid volume [m^3] and boundary area [m^2] (OpenCASCADE).
    declared_unit : str or None
        The unit the file declares (STEP, IGES), None if none or unknown.
    healed : bool
        Whether the healing ran.
    notes : list[str]
        What was done or noticed (unit disagreement, healing, fragmenting).
    """

    name: str
    volumes: list[int]
    bbox: np.ndarray
    volume: float
    area: float
    declared_unit: str | None = None
    healed: bool = False
    notes: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """One line for logs."""
        size = self.bbox[1] - self.bbox[0]
        return (f"part '{self.name}': {len(self.volumes)} solid(s), box "
                f"{size[0] * 1e3:.1f} x {size[1] * 1e3:.1f} x {size[2] * 1e3:.1f} mm, volume "
                f"{self.volume * 1e6:.4g} cm^3, area {self.area * 1e4:.4g} cm^2")


def check_file(path: str | os.PathLike[str], fld: str, suffixes: dict[str, str]) -> Path:
    """The path of an existing, readable file with a known suffix, else InputError."""
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise InputError.of(fld, str(p), "must end in one of "
                            f"{', '.join(sorted(suffixes))}")
    if not p.is_file():
        raise InputError.of(fld, str(p), "no such file" if not p.exists() else "not a file")
    if not os.access(p, os.R_OK):
        raise InputError.of(fld, str(p), "the file is not readable (permissions)")
    if p.stat().st_size == 0:
        raise InputError.of(fld, str(p), "the file is empty")
    return p


def declared_unit(path: str | os.PathLike[str]) -> tuple[str | None, float | None]:
    """The length unit a STEP or IGES file declares, and its size in mm.

    Returns
    -------
    (str, float) or (None, None)
        E.g. ``("mm", 1.0)``, ``("m", 1000.0)``, ``("in", 25.4)``; ``(None, None)`` for a
        BREP file, a file without a declaration, or one that declares several length
        units.
    """
    p = Path(path)
    kind = CAD_SUFFIXES.get(p.suffix.lower())
    if kind == "step":
        return _step_unit(p.read_text(errors="replace"))
    if kind == "iges":
        return _iges_unit(p.read_text(errors="replace"))
    return None, None


def _unit_name(mm: float) -> str | None:
    for name, metres in LENGTH_UNITS.items():
        if math.isclose(metres * 1e3, mm, rel_tol=1e-9):
            return name
    return None


def _step_unit(text: str) -> tuple[str | None, float | None]:
    """The LENGTH_UNIT entity of a STEP file's data section."""
    found: set[float] = set()
    for entity in re.findall(r"#\d+\s*=\s*\(([^;]*?LENGTH_UNIT\s*\(\s*\)[^;]*);", text,
                             flags=re.S):
        si = re.search(r"SI_UNIT\s*\(\s*(\$|\.\w+\.)\s*,\s*\.METRE\.\s*\)", entity)
        named = re.search(r"CONVERSION_BASED_UNIT\s*\(\s*'([^']*)'", entity)
        if si and si.group(1).upper() in _STEP_PREFIX:
            found.add(_STEP_PREFIX[si.group(1).upper()])
        elif named and named.group(1).upper() in _NAMED_UNITS_MM:
            found.add(_NAMED_UNITS_MM[named.group(1).upper()])
    if len(found) != 1:
        return None, None
    mm = found.pop()
    return _unit_name(mm) or f"{mm:g} mm", mm


def iges_global_parameters(text: str) -> list[str]:
    """The parameters of an IGES file's Global section (Hollerith strings unpacked).

    The section is the concatenation of columns 1-72 of the lines marked ``G`` in column
    73; parameters 1 and 2 set the parameter and record delimiters (default ``,`` ``;``).
    """
    chars = "".join(line[:72] for line in text.splitlines()
                    if len(line) >= 73 and line[72] == "G")
    params: list[str] = []
    delim, end = ",", ";"
    i, cur = 0, ""
    while i < len(chars):
        m = re.match(r"\s*(\d+)H", chars[i:])
        if m and not cur.strip():
            n = int(m.group(1))
            start = i + m.end()
            cur = chars[start:start + n]
            i = start + n
            continue
        c = chars[i]
        if c in (delim, end):
            params.append(cur.strip())
            cur = ""
            if len(params) == 1 and params[0]:
                delim = params[0]
            elif len(params) == 2 and params[1]:
                end = params[1]
            if c == end and len(params) > 2:
                break
        else:
            cur += c
        i += 1
    return params


def _iges_unit(text: str) -> tuple[str | None, float | None]:
    params = iges_global_parameters(text)
    try:
        flag = int(float(params[13]))
    except (IndexError, ValueError):
        return None, None
    if flag == 3 and len(params) > 14:  # unit named in parameter 15
        mm = _NAMED_UNITS_MM.get(params[14].upper().strip("'"))
        return (None, None) if mm is None else (_unit_name(mm), mm)
    mm = _IGES_UNITS_MM.get(flag)
    return (None, None) if mm is None else (_unit_name(mm) or f"{mm:g} mm", mm)


@contextlib.contextmanager
def _occ_scaling(factor: float) -> Iterator[None]:
    """gmsh's ``Geometry.OCCScaling`` (applied while shapes are imported), restored."""
    old = gmsh.option.getNumber("Geometry.OCCScaling")
    gmsh.option.setNumber("Geometry.OCCScaling", factor)
    try:
        yield
    finally:
        gmsh.option.setNumber("Geometry.OCCScaling", old)


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence OpenCASCADE's STEP/IGES transfer statistics, printed on file descriptor 1
    whatever gmsh's ``General.Terminal`` says."""
    try:
        fd = os.dup(1)
    except OSError:  # no stdout to silence
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            try:
                yield
            finally:
                os.dup2(fd, 1)
    finally:
        os.close(fd)


def open_edges(volume: int) -> tuple[int, int]:
    """Boundary curves of a volume used by one face side only, and by more than two.

    A closed (watertight, manifold) solid uses each curve of its boundary exactly twice:
    once by each of the two faces it separates, or twice by one periodic face (a seam).

    Returns
    -------
    (int, int)
        Numbers of curves used once (open) and more than twice (non-manifold).
    """
    uses: Counter[int] = Counter()
    for _, face in gmsh.model.getBoundary([(3, volume)], combined=False, oriented=False):
        for d, c in gmsh.model.getBoundary([(2, abs(face))], combined=False, oriented=True):
            if d == 1:
                uses[abs(c)] += 1
    return (sum(1 for n in uses.values() if n == 1), sum(1 for n in uses.values() if n > 2))


def _problems(dim_tags: list[tuple[int, int]]) -> list[str]:
    """What makes the imported entities not a set of closed solids (empty if they are)."""
    vols = [t for d, t in dim_tags if d == 3]
    if not vols:
        dims = Counter(d for d, _ in dim_tags)
        return [f"no solid in the file ({dims.get(2, 0)} free surfaces, {dims.get(1, 0)} "
                "free curves)"]
    out = []
    for v in vols:
        n_open, n_multi = open_edges(v)
        mass = gmsh.model.occ.getMass(3, v)
        if n_open or n_multi:
            out.append(f"solid {v} is not closed: {n_open} boundary curves bound one face "
                       f"only, {n_multi} more than two")
        if not mass > 0:
            out.append(f"solid {v} has volume {mass:.3g} m^3 (inverted or empty)")
    return out


def _heal(dim_tags: list[tuple[int, int]], opts: HealOptions) -> list[tuple[int, int]]:
    """Heal the entities and remove the originals (gmsh 4.8 keeps them beside the result)."""
    out = gmsh.model.occ.healShapes(dim_tags, opts.tolerance, opts.fix_degenerated,
                                    opts.fix_small_edges, opts.fix_small_faces,
                                    opts.sew_faces, opts.make_solids)
    gmsh.model.occ.synchronize()
    new = {(d, t) for d, t in out}
    stale = [(d, t) for d, t in dim_tags if (d, t) not in new]
    if stale:
        gmsh.model.occ.remove(stale, recursive=True)
        gmsh.model.occ.synchronize()
    return _top_level([(int(d), int(t)) for d, t in out])


def import_part(part: CadPart, where: str = "part") -> ImportedSolid:
    """Read one CAD part into the current gmsh model (metres), checked and healed.

    Parameters
    ----------
    part : CadPart
    where : str
        How error messages name the part's fields (``"parts[0]"``).

    Returns
    -------
    ImportedSolid
        The OCC model is synchronised; the part's solids are fragmented together when
        there are several (conformal interfaces, one mesh).

    Raises
    ------
    core.errors.InputError
        Naming the field: the file (missing, unreadable, no solid, open solid after
        healing), or the unit (implausible size; the bounding box is printed).
    """
    part.validate(where)
    ensure_initialized()
    path = Path(part.path)
    notes: list[str] = []
    name, mm = declared_unit(path)
    factor = LENGTH_UNITS[part.unit] / (mm if mm is not None else 1.0)
    if name is not None and name != part.unit:
        msg = (f"{path.name} declares its lengths in {name!r}, {where}.unit = {part.unit!r}"
               f" is used: the numbers in the file are taken as {part.unit}")
        log.warning("%s", msg)
        notes.append(msg)
    before = set(gmsh.model.getEntities())
    try:
        with _occ_scaling(factor), quiet_stdout():
            gmsh.model.occ.importShapes(str(path), highestDimOnly=True)
        gmsh.model.occ.synchronize()
    except Exception as exc:  # noqa: BLE001 - gmsh raises a bare Exception
        raise InputError.of(f"{where}.path", str(path),
                            f"OpenCASCADE cannot read it as {CAD_SUFFIXES[path.suffix.lower()]}"
                            f" ({exc})") from exc
    new = [dt for dt in gmsh.model.getEntities() if dt not in before]
    top = _top_level(new)
    if not top:
        raise InputError.of(f"{where}.path", str(path), "the file holds no shape")
    check_size(_bbox(top), part.unit, part.plausible_size, f"{where}.unit", path.name)
    problems = _problems(top)
    healed = False
    if part.heal.mode == "always" or (problems and part.heal.mode == "auto"):
        top = _heal(top, part.heal)
        healed = True
        remaining = _problems(top)
        notes.append(f"healed with tolerance {part.heal.tolerance:g} m ({len(new)} entities "
                     "read): " + ("; ".join(problems) if problems else "no defect found")
                     + ("" if not problems else
                        f"; still: {'; '.join(remaining)}" if remaining else "; fixed"))
        problems = remaining
    if problems:
        hint = (f"; {where}.heal.mode = 'never': healing might fix it"
                if part.heal.mode == "never" else
                f" (after healing with tolerance {part.heal.tolerance:g} m; a larger "
                f"{where}.heal.tolerance may close small gaps)")
        raise InputError.of(f"{where}.path", str(path),
                            "not a closed solid: " + "; ".join(problems) + hint)
    vols = [t for d, t in top if d == 3]
    if len(vols) > 1:
        out, _ = gmsh.model.occ.fragment([(3, vols[0])], [(3, v) for v in vols[1:]])
        gmsh.model.occ.synchronize()
        vols = sorted(t for d, t in out if d == 3)
        notes.append(f"{len(vols)} solids fragmented together (conformal interfaces)")
    bbox = _bbox([(3, v) for v in vols])
    faces = {abs(t) for _, t in gmsh.model.getBoundary([(3, v) for v in vols],
                                                       combined=False, oriented=False)}
    solid = ImportedSolid(
        name=part.name, volumes=vols, bbox=bbox,
        volume=float(sum(gmsh.model.occ.getMass(3, v) for v in vols)),
        area=float(sum(gmsh.model.occ.getMass(2, f) for f in faces)),
        declared_unit=name, healed=healed, notes=notes)
    log.info("%s (%s)", solid.summary(), path.name)
    return solid


def _bbox(dim_tags: list[tuple[int, int]]) -> np.ndarray:
    """Bounding box (2, 3) [m] of entities."""
    boxes = np.array([gmsh.model.getBoundingBox(d, t) for d, t in dim_tags]).reshape(-1, 6)
    return np.array([boxes[:, :3].min(axis=0), boxes[:, 3:].max(axis=0)])


def _top_level(dim_tags: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The entities of ``dim_tags`` not on the boundary of another one of them."""
    dim_tags = sorted(set(dim_tags))
    bnd: set[tuple[int, int]] = set()
    for d in (3, 2, 1):  # getBoundary(recursive=True) gives the points only
        ents = [(dd, t) for dd, t in dim_tags if dd == d] + [b for b in bnd if b[0] == d]
        if ents:
            bnd |= {(dd, abs(t)) for dd, t in gmsh.model.getBoundary(
                sorted(set(ents)), combined=False, oriented=False)}
    return [dt for dt in dim_tags if dt not in bnd]


def check_size(bbox: np.ndarray, unit: str, plausible: tuple[float, float], fld: str,
               label: str) -> None:
    """Refuse a bounding box whose diagonal lies outside ``plausible`` [m].

    The message prints the box and names the units that would make it plausible.
    """
    size = np.asarray(bbox[1]) - np.asarray(bbox[0])
    diag = float(np.linalg.norm(size))
    lo, hi = plausible
    if lo <= diag <= hi:
        return
    in_file = diag / LENGTH_UNITS[unit]
    fits = [u for u, s in LENGTH_UNITS.items() if lo <= in_file * s <= hi]
    box = " x ".join(f"{s:.4g}" for s in size)
    raise InputError.of(
        fld, unit,
        f"{label} measures {box} m (diagonal {diag:.4g} m; {in_file:.4g} {unit} in the "
        f"file's numbers), outside the plausible {lo:g}-{hi:g} m of a machine part"
        + (f"; the unit would fit as {' or '.join(map(repr, fits))}" if fits else ""))


def write_step(path: str | os.PathLike[str], build: Callable[[], object]) -> Path:
    """Write a solid built in metres as a STEP file in millimetres, atomically.

    ``build`` adds the solid(s) to a scratch gmsh model (OCC kernel, metres); they are
    written to a BREP file, read back scaled by 1000 (``Geometry.OCCScaling``, which keeps
    planes and cylinders analytic) and exported as STEP, declaring millimetres. The
    current model is restored.

    Parameters
    ----------
    path : str or PathLike
        Target ``.step`` / ``.stp`` file; its folder is created.
    build : callable
        Builds the geometry in the current (scratch) model; its return value is ignored.

    Returns
    -------
    Path
    """
    import tempfile

    target = Path(path)
    if target.suffix.lower() not in (".step", ".stp"):
        raise InputError.of("path", str(target), "must end in .step or .stp")
    ensure_initialized()
    current = gmsh.model.getCurrent() if gmsh.model.list() else None
    names = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            brep = Path(tmp) / "solid.brep"
            for n in ("_write_step_m", "_write_step_mm"):
                if n in gmsh.model.list():
                    gmsh.model.setCurrent(n)
                    gmsh.model.remove()
            gmsh.model.add("_write_step_m")
            names.append("_write_step_m")
            build()
            gmsh.model.occ.synchronize()
            gmsh.write(str(brep))
            gmsh.model.add("_write_step_mm")
            names.append("_write_step_mm")
            with _occ_scaling(1000.0):
                gmsh.model.occ.importShapes(str(brep))
            gmsh.model.occ.synchronize()
            with atomic_write(target) as out, quiet_stdout():
                gmsh.write(str(out))
    finally:
        for n in names:
            if n in gmsh.model.list():
                gmsh.model.setCurrent(n)
                gmsh.model.remove()
        if current is not None and current in gmsh.model.list():
            gmsh.model.setCurrent(current)
    log.info("wrote %s (mm)", target)
    return target
