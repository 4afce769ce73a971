"""Hand-over geometry -> DOLFINx 0.5: gmshio.model_to_mesh on the coarse pump."""

from __future__ import annotations

import math

import numpy as np
import pytest

gmsh = pytest.importorskip("gmsh")
dolfinx = pytest.importorskip("dolfinx")

pytestmark = pytest.mark.fem


def test_model_to_mesh_keeps_parts_and_surfaces():
    import ufl
    from dolfinx.fem import assemble_scalar, form
    from dolfinx.io import gmshio
    from mpi4py import MPI

    from geometry import PumpParams, build_pump, gmsh_session, part_volumes, preset

    p = PumpParams()
    with gmsh_session():
        model = build_pump(p, preset("coarse"))
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0,
                                                           gdim=3)
    assert mesh.geometry.dim == 3
    assert mesh.geometry.x.shape[0] == model.quality.n_nodes
    assert mesh.geometry.cmap.degree == 2
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    one = dolfinx.fem.Constant(mesh, 1.0)
    analytic = part_volumes(p)
    for name in ("shaft_in", "shaft_out", "housing"):
        vol = assemble_scalar(form(one * dx(model.tag(name))))
        assert vol == pytest.approx(analytic[name], rel=5e-3), name
    # lateral area of a journal and of a bore: 2 pi r L (curved P2 facets)
    sp, h = p.shaft_in, p.housing
    area = assemble_scalar(form(one * ds(model.tag("in/bearing_a"))))
    assert area == pytest.approx(2 * math.pi * sp.journal_radius * sp.journal_length, rel=5e-3)
    area = assemble_scalar(form(one * ds(model.tag("housing/bore_out_b"))))
    assert area == pytest.approx(2 * math.pi * h.bore_radius * h.bore_length, rel=5e-3)
    assert set(np.unique(cell_tags.values)) == {1, 2, 3}


def test_msh_file_round_trip_through_dolfinx(tmp_path):
    """write_msh -> gmsh.merge -> model_to_mesh gives the same parts (the CLI path)."""
    import ufl
    from dolfinx.fem import assemble_scalar, form
    from dolfinx.io import gmshio
    from mpi4py import MPI

    from geometry import (
        ShaftParams,
        build_single_shaft,
        gmsh_session,
        preset,
        shaft_volume,
        write_msh,
    )

    sp = ShaftParams()
    with gmsh_session():
        model = build_single_shaft(sp, preset("coarse"), name="in")
        path = write_msh(tmp_path / "mesh.msh")
        gmsh.clear()
        gmsh.merge(str(path))
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0,
                                                           gdim=3)
    assert mesh.topology.index_map(3).size_global == model.quality.n_elements
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    one = dolfinx.fem.Constant(mesh, 1.0)
    assert assemble_scalar(form(one * dx(model.tag("shaft_in")))) == pytest.approx(
        shaft_volume(sp), rel=5e-3)
    hub = assemble_scalar(form(one * ds(model.tag("in/hub"))))
    assert hub == pytest.approx(2 * math.pi * sp.hub_radius * sp.hub_length, rel=5e-3)
    for k in range(1, 7):
        ring = assemble_scalar(form(one * ds(model.tag(f"in/station_{k}"))))
        assert ring == pytest.approx(2 * math.pi * sp.body_radius * sp.station_width, rel=5e-3)
