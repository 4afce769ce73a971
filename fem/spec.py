"""Plain description of what is added to the FE mesh: nodes, links, clamps, lumped parts."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Node:
    """An extra 6-DOF node (3 translations then 3 rotations).

    Attributes
    ----------
    name : str
    centre : numpy.ndarray, shape (3,)
        Position (m), global frame.
    frame : numpy.ndarray, shape (3, 3)
        Columns = local axes in global components; the node's DOF (translations and
        rotations) are expressed in this frame: u_global = frame @ u_local.
    fixed : numpy.ndarray of bool, shape (6,)
        Local DOF held at zero (eliminated).
    """

    name: str
    centre: np.ndarray
    frame: np.ndarray
    fixed: np.ndarray


#: Allowed values of :attr:`Link.kind`.
LINK_KINDS = ("rigid", "distributing")


def check_link_kind(field: str, value: str) -> None:
    """Refuse a link kind not in :data:`LINK_KINDS`, naming ``field``."""
    if value not in LINK_KINDS:
        raise ValueError(f"{field} = {value!r}: allowed {', '.join(map(repr, LINK_KINDS))}")


@dataclass
class Link:
    """A link of surface group ``surface`` to ``node``.

    ``kind = "rigid"`` (RBE2): every FE DOF of the surface follows the node.
    ``kind = "distributing"`` (RBE3-type): the node follows the mass-weighted rigid fit
    of the surface's displacement, which adds no stiffness (see :mod:`fem.distributing`).
    """

    surface: str
    node: str
    kind: str = "rigid"

    def __post_init__(self) -> None:
        if self.kind not in LINK_KINDS:
            raise ValueError(f"link {self.surface!r} -> {self.node!r}: kind = {self.kind!r}; "
                             f"allowed: {', '.join(repr(k) for k in LINK_KINDS)}")


@dataclass
class Lumped:
    """A lumped matrix on one or two nodes, global frame, DOF order (u, theta) per node.

    ``kind`` is ``"K"`` (stiffness, N/m, N m/rad) or ``"M"`` (mass, kg, kg m^2).
    """

    kind: str
    nodes: tuple[str, ...]
    matrix: np.ndarray


@dataclass
class ModelSpec:
    """Everything added to the elastic mesh, in the order given.

    Attributes
    ----------
    nodes, links, clamps, lumped : lists
        See :class:`Node`, :class:`Link`, :class:`Lumped`; clamps are surface names
        whose FE DOF are all held at zero.
    shared : str
        What to do with an FE DOF that lies on two surfaces linked to different nodes:
        ``"first"`` keeps the link added first (logged), ``"error"`` raises ValueError.
        A clamp always wins over a link.
    """

    nodes: list[Node] = field(default_factory=list)
    links: list[Link] = field(default_factory=list)
    clamps: list[str] = field(default_factory=list)
    lumped: list[Lumped] = field(default_factory=list)
    shared: str = "first"

    def node_index(self, name: str) -> int:
        """Position of node ``name`` in ``nodes``; ValueError if absent."""
        for i, n in enumerate(self.nodes):
            if n.name == name:
                return i
        raise ValueError(f"node = {name!r}: no such node (known: {[n.name for n in self.nodes]})")

    def add_node(
        self,
        name: str,
        centre: np.ndarray,
        frame: np.ndarray | None = None,
        fixed: np.ndarray | None = None,
    ) -> Node:
        """Add a 6-DOF node at ``centre`` (m), DOF expressed in ``frame`` (rotation)."""
        if any(n.name == name for n in self.nodes):
            raise ValueError(f"node name = {name!r}: already defined")
        c = np.asarray(centre, dtype=float).reshape(-1)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ValueError(f"node {name!r} centre = {centre!r}: must be 3 finite floats (m)")
        R = np.eye(3) if frame is None else np.asarray(frame, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-12):
            raise ValueError(f"node {name!r} frame: must be an orthonormal 3x3 matrix")
        fx = np.zeros(6, bool) if fixed is None else np.asarray(fixed, dtype=bool).reshape(-1)
        if fx.shape != (6,):
            raise ValueError(f"node {name!r} fixed = {fixed!r}: must be 6 booleans")
        node = Node(name, c, R, fx)
        self.nodes.append(node)
        return node

    def add_link(self, surface: str, node: str, kind: str = "rigid") -> None:
        """Link surface group ``surface`` to ``node``.

        ``kind`` is ``"rigid"`` (RBE2: every FE DOF of the surface follows the node) or
        ``"distributing"`` (RBE3-type: the node follows the surface's mass-weighted rigid
        fit); ValueError otherwise.
        """
        self.node_index(node)
        self.links.append(Link(surface, node, kind))

    def add_clamp(self, surface: str) -> None:
        """Hold every FE DOF of surface group ``surface`` at zero."""
        self.clamps.append(surface)

    def _add_lumped(self, kind: str, nodes: tuple[str, ...], matrix: np.ndarray) -> None:
        for n in nodes:
            self.node_index(n)
        A = np.asarray(matrix, dtype=float)
        size = 6 * len(nodes)
        if A.shape != (size, size) or not np.all(np.isfinite(A)):
            raise ValueError(
                f"{kind} matrix on {nodes}: shape {A.shape}, must be finite {size}x{size}"
            )
        if not np.allclose(A, A.T, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(A).max())):
            raise ValueError(f"{kind} matrix on {nodes}: must be symmetric")
        if np.linalg.eigvalsh(A).min() < -1e-9 * max(1.0, np.abs(A).max()):
            raise ValueError(f"{kind} matrix on {nodes}: must be positive semi-definite")
        self.lumped.append(Lumped(kind, tuple(nodes), A))

    def add_mass(self, node: str, matrix: np.ndarray) -> None:
        """Add a 6x6 mass matrix (kg, kg m^2; global frame) at ``node``."""
        self._add_lumped("M", (node,), matrix)

    def add_spring(self, node: str, matrix: np.ndarray, other: str | None = None) -> None:
        """Add a 6x6 stiffness (global frame) from ``node`` to ground or to ``other``.

        For two nodes the 6x6 ``matrix`` k acts on the relative motion:
        the element matrix is [[k, -k], [-k, k]].
        """
        k = np.asarray(matrix, dtype=float)
        if other is None:
            self._add_lumped("K", (node,), k)
        else:
            if k.shape != (6, 6):
                raise ValueError(f"spring {node}-{other}: matrix shape {k.shape}, must be (6, 6)")
            self._add_lumped("K", (node, other), np.block([[k, -k], [-k, k]]))

    def add_torsion_to_ground(self, node: str, stiffness: float, axis: np.ndarray) -> None:
        """Torsional spring (N m/rad) about unit ``axis`` between ``node`` and ground."""
        if not (math.isfinite(stiffness) and stiffness >= 0):
            raise ValueError(f"torsional stiffness = {stiffness}: must be >= 0 (N m/rad)")
        a = np.asarray(axis, dtype=float)
        a = a / np.linalg.norm(a)
        k = np.zeros((6, 6))
        k[3:, 3:] = stiffness * np.outer(a, a)
        self._add_lumped("K", (node,), k)
