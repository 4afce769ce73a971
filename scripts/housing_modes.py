"""The housing-mode tables of docs/cad-import.md: RBE2 against RBE3 seats, mesh
convergence, and the STEP round trip of the pump housing.

Reads the gearbox housing written by scripts/gearbox_housing_step.py (written here to a
temporary folder when no file is given), finds its six seats and its feet, and prints
Markdown tables of the first modes with the feet clamped:

* seat links: no seat, each seat linked rigidly (RBE2) or distributing (RBE3) to a free
  node, and to a node carrying a point mass;
* convergence: the housing alone at several element sizes (DOF, time, frequencies);
* ``--pump``: the parametric pump housing against the same housing written as STEP and
  read back, at the coarse and fine presets, and the seat table of the pump housing.

Usage (serial; about 6 min and 5 GB at the default sizes)::

    python scripts/housing_modes.py [gearbox.step] [--size 0.012] [--sizes 0.03 0.02 ...]
        [--mass 2.0] [--modes 6] [--pump]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _gearbox_module():
    name = "gearbox_housing_step"
    spec = importlib.util.spec_from_file_location(name, HERE / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def _modes(fe_mesh, seats: dict[str, str], mass: float, n: int) -> np.ndarray:
    import fem

    spec = fem.housing_spec(fe_mesh, seats, {"housing/feet": fem.MountSupport()})
    for s in seats:
        if mass > 0:
            spec.add_mass(s, fem.rigid_body_mass(mass, [0.0, 0.0, 0.0]))
    model = fem.build_model(fe_mesh, {"housing": fem.CAST_IRON}, spec)
    return fem.eigenfrequencies(model.K, model.M, n)


def _load(step: Path, size: float, seats: list, feet) -> tuple:
    from mpi4py import MPI

    import fem
    from geometry import CadPart, gmsh_session, import_cad, preset

    t0 = time.perf_counter()
    with gmsh_session():
        model = import_cad([CadPart("housing", step, unit="mm")], seats, [feet],
                           preset("coarse", size=size, curvature_points=10))
        fe_mesh = fem.load_meshed_model(model, MPI.COMM_WORLD)
    return model, fe_mesh, time.perf_counter() - t0


def _row(label: str, f: np.ndarray, ref: np.ndarray | None = None) -> str:
    cells = [f"{x:.1f}" + ("" if ref is None else f" ({100 * (x / r - 1):+.1f} %)")
             for x, r in zip(f, ref if ref is not None else f, strict=True)]
    return f"| {label} | " + " | ".join(cells) + " |"


def seat_table(step: Path, seats: list, feet, size: float, mass: float, n: int,
               label: str = "gearbox housing") -> str:
    """First modes with no seat, RBE3 and RBE2 seats, free and with a mass."""
    model, fe_mesh, _ = _load(step, size, seats, feet)
    groups = list(model.seat_groups().values())
    bare = _modes(fe_mesh, {}, 0.0, n)
    head = ("| seats (feet clamped) | " + " | ".join(f"f{i + 1} [Hz]" for i in range(n))
            + " |\n|" + "---|" * (n + 1))
    rows = [_row("none (housing alone)", bare)]
    for m in (0.0, mass):
        for kind, rbe in (("distributing", "RBE3"), ("rigid", "RBE2")):
            f = _modes(fe_mesh, dict.fromkeys(groups, kind), m, n)
            rows.append(_row(f"{rbe}, " + (f"{m:g} kg on each node" if m else "free nodes"),
                             f, bare))
    return (f"{label}, size {size * 1e3:g} mm: {model.quality.summary()}\n\n"
            + head + "\n" + "\n".join(rows))


def convergence_table(step: Path, gb, sizes: list[float], n: int) -> str:
    """The housing alone (feet clamped) at several sizes (refined at its seats)."""
    p = gb.GearboxHousing()
    rows = []
    for size in sizes:
        model, fe_mesh, t_mesh = _load(step, size, gb.seats(p), gb.feet_mount(p))
        t0 = time.perf_counter()
        f = _modes(fe_mesh, {}, 0.0, n)
        rows.append((size, model.quality.n_elements, model.quality.n_dofs, t_mesh,
                     time.perf_counter() - t0, f))
    ref = rows[-1][-1]
    head = ("| size [mm] | tets | DOF | mesh [s] | solve [s] | "
            + " | ".join(f"f{i + 1} [Hz]" for i in range(n)) + " |\n|" + "---|" * (n + 5))
    lines = [f"| {s * 1e3:g} | {ne} | {nd} | {tm:.1f} | {ts:.1f} | "
             + " | ".join(f"{x:.1f} ({100 * (x / r - 1):+.2f} %)" for x, r in
                          zip(f, ref, strict=True)) + " |"
             for s, ne, nd, tm, ts, f in rows]
    return head + "\n" + "\n".join(lines)


def pump_tables(n: int, size: float, mass: float) -> str:
    """The parametric pump housing against its STEP round trip (coarse, fine), and its
    seat table at ``size``."""
    from mpi4py import MPI

    import fem
    from geometry import (
        BearingSeat,
        CadPart,
        HousingParams,
        Mount,
        PumpParams,
        build_housing,
        build_pump,
        gmsh_session,
        import_cad,
        preset,
        write_step,
    )
    from geometry.params import DEFAULT_CENTRE_DISTANCE as A

    h = HousingParams()
    seats = [BearingSeat(f"{s}_{e}", point=(x, 0.0, 0.5 * sum(z)), direction=(0, 0, 1),
                         radius=h.bore_radius, width=0.015)
             for s, x in (("in", 0.0), ("out", A)) for e, z in (("a", h.bore_a_z),
                                                                 ("b", h.bore_b_z))]
    feet = Mount("feet", plane=((0, -0.5 * h.height_y - h.foot_height, 0), (0, -1, 0)))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        step = Path(tmp) / "pump_housing.step"
        with gmsh_session():
            write_step(step, lambda: build_housing(h, A))
        for name in ("coarse", "fine"):
            with gmsh_session():
                meshed = build_pump(PumpParams(), preset(name))
                _drop_shafts(meshed)
                f_par = _modes(fem.load_meshed_model(meshed, MPI.COMM_WORLD), {}, 0.0, n)
            with gmsh_session():
                model = import_cad([CadPart("housing", step)], seats, [feet], preset(name))
                f_step = _modes(fem.load_meshed_model(model, MPI.COMM_WORLD), {}, 0.0, n)
            rows.append((name, f_par, f_step))
        seat_text = seat_table(step, seats, feet, size, mass, n, "pump housing")
    head = ("| preset | model | " + " | ".join(f"f{i + 1} [Hz]" for i in range(n))
            + " |\n|" + "---|" * (n + 2))
    lines = []
    for name, fp, fs in rows:
        lines.append(f"| {name} | parametric | " + " | ".join(f"{x:.2f}" for x in fp) + " |")
        lines.append(f"| {name} | STEP | " + " | ".join(
            f"{x:.2f} ({100 * (x / r - 1):+.3f} %)" for x, r in zip(fs, fp, strict=True))
            + " |")
    return head + "\n" + "\n".join(lines) + "\n\n" + seat_text


def _drop_shafts(meshed) -> None:
    """Remove the shafts from the live pump model, leaving the housing."""
    import gmsh

    shafts = [k for k in meshed.groups if k.startswith("shaft_")]
    ents = [(3, int(e)) for k in shafts
            for e in gmsh.model.getEntitiesForPhysicalGroup(*meshed.groups[k])]
    drop = [k for k in meshed.groups if k.startswith(("shaft_", "in/", "out/"))]
    gmsh.model.removePhysicalGroups([meshed.groups[k] for k in drop])
    gmsh.model.removeEntities(ents, recursive=True)
    gmsh.model.mesh.renumberNodes()
    gmsh.model.mesh.renumberElements()
    for k in drop:
        meshed.groups.pop(k)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("step", nargs="?", help="gearbox housing STEP (default: written here)")
    ap.add_argument("--size", type=float, default=0.012, help="size of the seat table [m]")
    ap.add_argument("--sizes", type=float, nargs="*", default=[0.03, 0.02, 0.012, 0.008],
                    help="sizes of the convergence table [m], finest last")
    ap.add_argument("--mass", type=float, default=2.0, help="mass on each seat node [kg]")
    ap.add_argument("--modes", type=int, default=6)
    ap.add_argument("--pump", action="store_true", help="also the pump round-trip table")
    args = ap.parse_args(argv)
    gb = _gearbox_module()
    with tempfile.TemporaryDirectory() as tmp:
        step = Path(args.step) if args.step else gb.write(Path(tmp) / "gearbox.step")
        p = gb.GearboxHousing()
        print(seat_table(step, gb.seats(p), gb.feet_mount(p), args.size, args.mass,
                         args.modes), "\n")
        if args.sizes:
            print(convergence_table(step, gb, args.sizes, args.modes), "\n")
    if args.pump:
        print(pump_tables(args.modes, args.size, args.mass))
    return 0


if __name__ == "__main__":
    sys.exit(main())
