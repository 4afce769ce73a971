"""Small gmsh geometries and helpers for the fem tests (not collected by pytest)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np


@contextlib.contextmanager
def gmsh_session() -> Iterator[object]:
    """Initialise gmsh quietly, yield gmsh.model, finalise.

    Uses ``geometry.gmsh_session`` when the geometry package is there, so that its
    record of gmsh's state stays right.
    """
    import gmsh

    try:
        from geometry import gmsh_session as geometry_session
    except ImportError:  # pragma: no cover - geometry missing
        geometry_session = None
    if geometry_session is not None:
        with geometry_session():
            yield gmsh.model
        return
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        yield gmsh.model
    finally:
        gmsh.finalize()


def _mesh_tet10(model: object, h: float) -> None:
    import gmsh

    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * h)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)
    model.mesh.generate(3)
    model.mesh.setOrder(2)


def build_cylinder(length: float, radius: float, h: float, comm_rank: int = 0) -> dict:
    """A z-axis cylinder [0, length] meshed in tet10 on rank 0.

    Groups: volume ``shaft``; surfaces ``end_a`` (z = 0), ``end_b`` (z = length),
    ``side``. Returns the centres of the end faces.
    """
    import gmsh

    model = gmsh.model
    if comm_rank == 0:
        model.add("cylinder")
        vol = model.occ.addCylinder(0, 0, 0, 0, 0, length, radius)
        model.occ.synchronize()
        faces = {}
        for _, tag in model.getBoundary([(3, vol)], oriented=False):
            z = model.occ.getCenterOfMass(2, tag)[2]
            key = "end_a" if abs(z) < 1e-9 else ("end_b" if abs(z - length) < 1e-9 else "side")
            faces[key] = tag
        model.addPhysicalGroup(3, [vol], 1)
        model.setPhysicalName(3, 1, "shaft")
        for i, name in enumerate(("end_a", "end_b", "side")):
            model.addPhysicalGroup(2, [faces[name]], 10 + i)
            model.setPhysicalName(2, 10 + i, name)
        _mesh_tet10(model, h)
    return {"end_a": np.zeros(3), "end_b": np.array([0.0, 0.0, length])}


def build_box_bar(length: float, width: float, h: float, comm_rank: int = 0) -> dict:
    """A square z-axis bar [-w/2, w/2]^2 x [0, length] meshed in tet10 on rank 0.

    Flat faces only, so the P2 geometry is exact. Groups: volume ``shaft``; surfaces
    ``end_a`` (z = 0), ``end_b`` (z = length), ``side``. Returns the end-face centres.
    """
    import gmsh

    model = gmsh.model
    if comm_rank == 0:
        model.add("box_bar")
        vol = model.occ.addBox(-0.5 * width, -0.5 * width, 0, width, width, length)
        model.occ.synchronize()
        faces: dict[str, list[int]] = {"end_a": [], "end_b": [], "side": []}
        for _, tag in model.getBoundary([(3, vol)], oriented=False):
            z = model.occ.getCenterOfMass(2, tag)[2]
            key = "end_a" if abs(z) < 1e-9 else ("end_b" if abs(z - length) < 1e-9 else "side")
            faces[key].append(tag)
        model.addPhysicalGroup(3, [vol], 1)
        model.setPhysicalName(3, 1, "shaft")
        for i, name in enumerate(("end_a", "end_b", "side")):
            model.addPhysicalGroup(2, faces[name], 10 + i)
            model.setPhysicalName(2, 10 + i, name)
        _mesh_tet10(model, h)
    return {"end_a": np.zeros(3), "end_b": np.array([0.0, 0.0, length])}


def build_housing_block(size: tuple[float, float, float], bore_radius: float, h: float,
                        comm_rank: int = 0) -> dict:
    """A hollow box (housing-like): box with a z-through bore, feet = bottom face.

    Groups: volume ``housing``; surfaces ``housing/feet`` (y = 0) and ``bore``.
    """
    import gmsh

    lx, ly, lz = size
    model = gmsh.model
    if comm_rank == 0:
        model.add("housing")
        box = model.occ.addBox(0, 0, 0, lx, ly, lz)
        cyl = model.occ.addCylinder(0.5 * lx, 0.55 * ly, 0, 0, 0, lz, bore_radius)
        out, _ = model.occ.cut([(3, box)], [(3, cyl)])
        model.occ.synchronize()
        vol = out[0][1]
        feet, bore = [], []
        for _, tag in model.getBoundary([(3, vol)], oriented=False):
            c = model.occ.getCenterOfMass(2, tag)
            if abs(c[1]) < 1e-9:
                feet.append(tag)
            elif model.getType(2, tag) == "Cylinder":
                bore.append(tag)
        model.addPhysicalGroup(3, [vol], 1)
        model.setPhysicalName(3, 1, "housing")
        model.addPhysicalGroup(2, feet, 10)
        model.setPhysicalName(2, 10, "housing/feet")
        model.addPhysicalGroup(2, bore, 11)
        model.setPhysicalName(2, 11, "bore")
        _mesh_tet10(model, h)
    return {"bore": np.array([0.5 * lx, 0.55 * ly, 0.5 * lz])}


def timoshenko_frequencies(
    E: float, nu: float, rho: float, radius: float, length: float, bc: str, n: int,
    f_min: float = 1.0, f_max: float = 1e5, n_grid: int = 2000,
) -> np.ndarray:
    """First ``n`` bending frequencies (Hz) of a solid circular Timoshenko beam.

    Exact solution of the uniform-beam equations
    kGA (w'' - psi') + rho A w^2 w = 0,  EI psi'' + kGA (w' - psi) + rho I w^2 psi = 0,
    written as y' = A y, y = (w, w', psi, psi'), y(L) = expm(A L) y(0); the
    frequency equation is the 2x2 determinant of the end conditions.
    ``bc`` is ``"clamped-free"`` or ``"free-free"``; shear coefficient of Cowper
    k = 6 (1 + nu) / (7 + 6 nu).
    """
    from scipy.linalg import expm
    from scipy.optimize import brentq

    G = E / (2 * (1 + nu))
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    A = np.pi * radius**2
    I = np.pi * radius**4 / 4
    n_seg = max(1, int(np.ceil(length * np.sqrt(kappa * G * A / (E * I)) / 2.0)))

    def det(f: float) -> float:
        w2 = (2 * np.pi * f) ** 2
        Amat = np.array([
            [0, 1, 0, 0],
            [-rho * w2 / (kappa * G), 0, 0, 1],
            [0, 0, 0, 1],
            [0, -kappa * G * A / (E * I), kappa * G * A / (E * I) - rho * I * w2 / (E * I), 0],
        ])  # fmt: skip
        if bc == "clamped-free":
            Y = np.array([[0, 0], [1, 0], [0, 0], [0, 1.0]])
        elif bc == "free-free":
            Y = np.array([[1, 0], [0, 1], [0, 1], [0, 0.0]])
        else:
            raise ValueError(f"bc = {bc!r}")
        # march in short segments, re-orthonormalising the 2 solutions (the shear
        # boundary-layer solutions grow like exp(x sqrt(kGA/EI))); QR with a
        # positive-diagonal R keeps the sign of the final determinant.
        Phi = expm(Amat * (length / n_seg))
        for _ in range(n_seg):
            Q, Rr = np.linalg.qr(Phi @ Y)
            Y = Q * np.sign(np.diag(Rr))
        rows = np.vstack([Y[3], Y[1] - Y[2]])
        return float(np.linalg.det(rows))

    grid = np.geomspace(f_min, f_max, n_grid)
    vals = np.array([det(f) for f in grid])
    roots = []
    for i in np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:])):
        roots.append(brentq(det, grid[i], grid[i + 1], xtol=1e-12, rtol=1e-13))
        if len(roots) == n:
            break
    return np.array(roots)


def free_shaft_model(h: float = 0.01, length: float = 0.2, radius: float = 0.01,
                     alpha: float = 0.349, **build_kw: object) -> object:
    """Steel cylinder, end faces linked to nodes ``a`` (global frame) and ``b``
    (gear-pair frame of angle ``alpha``), a gear blank mass on ``b``; no clamp."""
    from mpi4py import MPI

    import fem
    from gears.pair import pair_frame

    with gmsh_session() as model:
        centres = build_cylinder(length, radius, h, MPI.COMM_WORLD.rank)
        fe_mesh = fem.load_gmsh_mesh(model, MPI.COMM_WORLD, centres=centres)
    spec = fem.ModelSpec()
    spec.add_node("a", fe_mesh.centres["end_a"])
    spec.add_node("b", fe_mesh.centres["end_b"], frame=pair_frame(alpha))
    spec.add_link("end_a", "a")
    spec.add_link("end_b", "b")
    spec.add_mass("b", fem.disk_mass(0.05, 0.016, 0.02, 7850.0))
    return fem.build_model(fe_mesh, {"shaft": STEEL_TEST}, spec, **build_kw)


def _steel() -> object:
    import fem

    return fem.Material(E=210e9, nu=0.3, rho=7800.0)


STEEL_TEST = _steel()


def keep_only_housing(meshed: object) -> None:
    """Delete the shafts (entities, mesh and groups) from the live pump gmsh model,
    leaving the housing alone for a clamped-housing comparison."""
    import gmsh

    shafts = [k for k in meshed.groups if k.startswith("shaft_")]
    ents = [(3, int(e)) for k in shafts
            for e in gmsh.model.getEntitiesForPhysicalGroup(*meshed.groups[k])]  # fmt: skip
    drop = [k for k in meshed.groups if k.startswith(("shaft_", "in/", "out/"))]
    gmsh.model.removePhysicalGroups([meshed.groups[k] for k in drop])
    gmsh.model.removeEntities(ents, recursive=True)
    gmsh.model.mesh.renumberNodes()
    gmsh.model.mesh.renumberElements()
    for k in drop:
        meshed.groups.pop(k)


def rigid_motion_residuals(model: object, a: np.ndarray, th: np.ndarray,
                           o: np.ndarray) -> tuple[object, float, float]:
    """The reduced vector q of the rigid motion u = a + th x (x - o), ||K q|| relative to
    ||K||_F ||q|| (the scale of an arbitrary vector), and the largest error (m) of the
    field rebuilt by the prolongation at every P2 DOF against the exact one (all ranks)."""
    from mpi4py import MPI

    q = model.rigid_motion(a, th, o)
    r = model.K.createVecLeft()
    model.K.mult(q, r)
    strain = r.norm() / (model.K.norm() * q.norm())
    u = model.displacement(q)
    n = model.V.dofmap.index_map.size_local
    x = model.V.tabulate_dof_coordinates()[:n]
    err = np.abs(u.x.array[: 3 * n].reshape(-1, 3) - (a + np.cross(th, x - o))).max()
    return q, strain, model.comm.allreduce(err, op=MPI.MAX)
