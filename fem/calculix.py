"""Independent check with CalculiX: write the gmsh tet10 mesh as C3D10, read eigenvalues.

Used by the tests to compare DOLFINx frequencies with an independent FE code on the
very same mesh. Gmsh's 10-node tetrahedron orders its mid-edge nodes
(01, 12, 20, 03, 23, 13) while Abaqus/CalculiX C3D10 expects (01, 12, 20, 03, 13, 23):
the last two are swapped.

Surfaces coupled to a reference node (:class:`Coupling`) are written as CalculiX writes
RBE2 and RBE3: ``*RIGID BODY`` (every node of the surface follows the reference node; its
rotations are the translations of an extra rotation node) and ``*DISTRIBUTING COUPLING``
(a ``DCOUP3D`` element: the reference node's translation is the weighted mean of the
surface nodes' translations, one MPC per direction). A point mass (``*MASS``) and, on a
rigid coupling, springs to ground (``SPRING1``) sit on the reference node. Numbers are
written with 14 significant digits: CalculiX reads at most 20 characters per field.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from core.files import atomic_write

from .materials import Material

log = logging.getLogger(__name__)

GMSH_TET10 = 11
TET10_TO_C3D10 = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])


@dataclass(frozen=True)
class Coupling:
    """A surface group coupled to a reference node, for :func:`write_inp`.

    Attributes
    ----------
    surface : str
        Surface physical group.
    centre : tuple of 3 floats
        Reference node [m].
    kind : str
        ``"rigid"`` (``*RIGID BODY``) or ``"distributing"`` (``*DISTRIBUTING COUPLING``).
    weights : mapping int -> float, optional
        Distributing only: gmsh node tag -> weight (e.g. ``fem.housing.surface_weights``,
        tags = input node index + 1); nodes of zero weight are left out.
    mass : float
        Point mass on the reference node [kg] (translations only).
    stiffness : tuple of 6 floats, optional
        Rigid only: springs from the reference node to ground, ``(k_x, k_y, k_z)`` [N/m]
        and ``(k_rx, k_ry, k_rz)`` [N m/rad] (on the rotation node), global frame.
    """

    surface: str
    centre: tuple[float, float, float]
    kind: str = "rigid"
    weights: Mapping[int, float] | None = None
    mass: float = 0.0
    stiffness: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if self.kind not in ("rigid", "distributing"):
            raise ValueError(f"coupling {self.surface!r}: kind = {self.kind!r}; allowed "
                             "'rigid', 'distributing'")
        if self.kind == "distributing" and not self.weights:
            raise ValueError(f"coupling {self.surface!r}: a distributing coupling needs "
                             "weights")
        if self.kind == "distributing" and self.stiffness is not None:
            raise ValueError(f"coupling {self.surface!r}: CalculiX allows no element on a "
                             "distributing coupling's reference node but its mass")


def _lines(values: np.ndarray, per_line: int = 16) -> str:
    out = []
    for i in range(0, len(values), per_line):
        out.append(", ".join(str(int(v)) for v in values[i:i + per_line]))
    return "\n".join(out)


def write_inp(
    path: Path,
    model: Any,
    materials: dict[str, Material],
    groups: dict[str, tuple[int, int]],
    clamps: list[str],
    n_modes: int,
    couplings: Sequence[Coupling] = (),
) -> None:
    """Write a CalculiX *FREQUENCY deck of the live gmsh model's tet10 mesh.

    Parameters
    ----------
    path : Path
        Output ``.inp`` file (written atomically).
    model : gmsh.model
    materials : dict[str, Material]
        Volume group name -> material (SI units, so the deck is in m, kg, s).
    groups : dict[str, tuple[int, int]]
        Physical-group name -> (dim, tag).
    clamps : list[str]
        Surface groups whose nodes are fixed in x, y, z.
    n_modes : int
        Number of eigenmodes requested.
    couplings : sequence of Coupling
        Surfaces coupled to reference nodes. As in :mod:`fem.prolongation`, a clamp wins
        over a rigid coupling and a node on two rigid couplings stays with the first.
    """
    tags, xyz, _ = model.mesh.getNodes()
    xyz = xyz.reshape(-1, 3)
    elements = []
    for name in materials:
        dim, ptag = groups[name]
        blocks = []
        for ent in model.getEntitiesForPhysicalGroup(dim, ptag):
            etypes, _, enodes = model.mesh.getElements(dim, ent)
            for et, en in zip(etypes, enodes, strict=True):
                if et != GMSH_TET10:
                    raise ValueError(f"volume {name!r}: element type {et}, need tet10 (11)")
                blocks.append(np.asarray(en, dtype=np.int64).reshape(-1, 10)[:, TET10_TO_C3D10])
        elements.append(np.concatenate(blocks))
    used = np.unique(np.concatenate([e.reshape(-1) for e in elements]))
    keep = np.isin(tags, used)
    parts = ["*HEADING\ngeardyn fem check", "*NODE"]
    for t, (x, y, z) in zip(tags[keep], xyz[keep], strict=True):
        parts.append(f"{int(t)}, {x:.13e}, {y:.13e}, {z:.13e}")
    eid = 1
    for i, (conn, mat) in enumerate(zip(elements, materials.values(), strict=True)):
        parts.append(f"*ELEMENT, TYPE=C3D10, ELSET=E{i}")
        for c in conn:
            parts.append(f"{eid}, " + ", ".join(str(int(v)) for v in c))
            eid += 1
        parts += [f"*MATERIAL, NAME=M{i}", "*ELASTIC", f"{mat.E:.13e}, {mat.nu:.13e}",
                  "*DENSITY", f"{mat.rho:.13e}", f"*SOLID SECTION, ELSET=E{i}, MATERIAL=M{i}"]
    fixed: set[int] = set()
    for j, name in enumerate(clamps):
        nodes = _group_nodes(model, groups, name) & set(int(v) for v in used)
        fixed |= nodes
        parts += [f"*NSET, NSET=FIX{j}", _lines(np.array(sorted(nodes)))]
    parts += _coupling_cards(model, groups, couplings, fixed, int(tags.max()) + 1, eid)
    parts += ["*STEP", "*FREQUENCY", f"{int(n_modes)}"]
    if clamps:
        parts.append("*BOUNDARY")
        parts += [f"FIX{j}, 1, 3" for j in range(len(clamps))]
    parts += ["*END STEP", ""]
    with atomic_write(path, "w") as f:
        f.write("\n".join(parts))


def _group_nodes(model: Any, groups: dict[str, tuple[int, int]], name: str) -> set[int]:
    dim, ptag = groups[name]
    nodes: set[int] = set()
    for ent in model.getEntitiesForPhysicalGroup(dim, ptag):
        for en in model.mesh.getElements(dim, ent)[2]:
            nodes.update(int(v) for v in en)
    return nodes


def _coupling_cards(model: Any, groups: dict[str, tuple[int, int]],
                    couplings: Sequence[Coupling], fixed: set[int], node0: int,
                    eid: int) -> list[str]:
    """Reference nodes, node sets, coupling, mass and spring cards (model definition)."""
    if not couplings:
        return []
    out = ["*NODE"]
    for i, c in enumerate(couplings):
        x, y, z = (float(v) for v in c.centre)
        out.append(f"{node0 + 2 * i}, {x:.13e}, {y:.13e}, {z:.13e}")
        if c.kind == "rigid":
            out.append(f"{node0 + 2 * i + 1}, {x:.13e}, {y:.13e}, {z:.13e}")
    taken = set(fixed)
    for i, c in enumerate(couplings):
        ref = node0 + 2 * i
        if c.kind == "rigid":
            nodes = _group_nodes(model, groups, c.surface) - taken
            taken |= nodes
            out += [f"*NSET, NSET=RB{i}", _lines(np.array(sorted(nodes))),
                    f"*RIGID BODY, NSET=RB{i}, REF NODE={ref}, ROT NODE={ref + 1}"]
            for d, k in enumerate(c.stiffness or ()):
                if k > 0:
                    node, dof = (ref, d + 1) if d < 3 else (ref + 1, d - 2)
                    out += [f"*ELEMENT, TYPE=SPRING1, ELSET=SP{i}_{d}", f"{eid}, {node}",
                            f"*SPRING, ELSET=SP{i}_{d}", f"{dof}", f"{float(k):.13e}"]
                    eid += 1
        else:
            w = sorted(((float(v), int(n)) for n, v in c.weights.items() if v != 0.0),
                       key=lambda t: (-abs(t[0]), t[1]))  # dependent node: largest weight
            out += [f"*ELEMENT, TYPE=DCOUP3D, ELSET=DC{i}", f"{eid}, {ref}",
                    f"*DISTRIBUTING COUPLING, ELSET=DC{i}"]
            out += [f"{n}, {v:.13e}" for v, n in w]
            eid += 1
        if c.mass > 0:
            out += [f"*ELEMENT, TYPE=MASS, ELSET=PM{i}", f"{eid}, {ref}",
                    f"*MASS, ELSET=PM{i}", f"{float(c.mass):.13e}"]
            eid += 1
    return out


def read_dat_frequencies(path: Path) -> np.ndarray:
    """Frequencies (Hz, 'CYCLES/TIME' column) of the EIGENVALUE OUTPUT of a .dat file."""
    text = Path(path).read_text()
    block = text.split("E I G E N V A L U E   O U T P U T")
    if len(block) < 2:
        raise ValueError(f"{path}: no eigenvalue output")
    freqs = []
    number = r"[-+]?\d*\.?\d+(?:[EeDd][-+]?\d+)?"
    for line in block[1].splitlines():
        m = re.match(rf"^\s*(\d+)\s+({number})\s+({number})\s+({number})\s+({number})\s*$", line)
        if m:
            freqs.append(float(m.group(4)))
        elif freqs and line.strip() and not line.strip()[0].isdigit():
            break
    return np.array(freqs)


def run_frequency(
    model: Any,
    materials: dict[str, Material],
    groups: dict[str, tuple[int, int]],
    clamps: list[str],
    n_modes: int,
    workdir: Path | None = None,
    timeout: float = 600.0,
    couplings: Sequence[Coupling] = (),
) -> np.ndarray:
    """Run ``ccx`` on the gmsh mesh and return the first ``n_modes`` frequencies (Hz).

    ``couplings`` as in :func:`write_inp`.

    Raises
    ------
    FileNotFoundError
        If ``ccx`` is not on PATH.
    RuntimeError
        If CalculiX fails.
    """
    exe = shutil.which("ccx")
    if exe is None:
        raise FileNotFoundError("ccx (Debian package calculix-ccx) not found on PATH")
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        job = Path(tmp) / "job"
        write_inp(job.with_suffix(".inp"), model, materials, groups, clamps, n_modes,
                  couplings)
        env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1")
        res = subprocess.run([exe, "-i", "job"], cwd=tmp, env=env, capture_output=True,
                             text=True, timeout=timeout)  # fmt: skip
        if res.returncode != 0 or not job.with_suffix(".dat").exists():
            raise RuntimeError(f"ccx failed ({res.returncode}): {res.stdout[-2000:]}")
        f = read_dat_frequencies(job.with_suffix(".dat"))
    if f.size < n_modes:
        raise RuntimeError(f"ccx returned {f.size} of {n_modes} frequencies")
    return f[:n_modes]
