"""A parallel-shaft gearbox as an FE machine (``scene.kind = "gearbox"``).

The train sections (``[[shafts]]``, ``[[gears]]``, ``[[meshes]]``, ``[drive]``,
``[[loads]]``) give the layout (:class:`machines.train.layout.TrainLayout`: shaft
centres, exact speed ratios and senses, eq. 11 per mesh in the global frame, static
loads from the torque path); ``[housing]``, ``[mesh]`` and ``[materials]`` the FE model
(:mod:`machines.gearbox.params`). The mesh is :func:`geometry.build_gearbox` (or, with
``housing.source = "cad"``, the housing of a CAD file with its bores found from the
shafts' axes and its feet by their plane, and the parametric shafts:
:class:`geometry.CadHousing`), the FE model
:func:`fem.build_gearbox_model`: one body per gear (6 DOF, global frame) on its seat,
bearing springs between journals and bores, the motor on the drive shaft's start, each
load's inertia on its coupling at its shaft's end; the housing radiates.
"""
from __future__ import annotations

import dataclasses
import hashlib
from fractions import Fraction
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import InputError
from machines.base import GearBody, GearMeshSpec, Part, Shaft
from machines.fe import FEMachine, load_mesh, write_mesh_info
from machines.gearbox.params import (
    GearboxFEParams,
    bearing_names,
    cad_housing,
    gearbox_geometry,
    gearbox_parameters,
    mesh_housing,
)
from machines.registry import register
from machines.rom import rom_stage_inputs
from machines.train.layout import TrainLayout

__all__ = ["Gearbox", "gear_node"]


def gear_node(shaft: str, gear: str) -> str:
    """The FE node of gear ``gear`` on ``shaft`` (``geometry.gear_node``'s name)."""
    return f"{shaft}/gear_{gear}"


@register
class Gearbox(FEMachine):
    """The FE gearbox (see the module docstring)."""

    kind = "gearbox"
    summary = "FE gearbox: N parallel shafts in a housing → FE → ROM"
    mesh_file = "gearbox.msh"

    # ------------------------------------------------------------------ what it is
    @cached_property
    def layout(self) -> TrainLayout:
        """The train's layout (checks the train sections)."""
        return TrainLayout.from_scene(self.scene)

    @cached_property
    def shafts(self) -> tuple[Shaft, ...]:
        return tuple(Shaft(s.name, s.speed_ratio) for s in self.layout.shafts)

    @cached_property
    def gear_bodies(self) -> tuple[GearBody, ...]:
        """One body per gear, in the order of ``[[gears]]``, 6 DOF in the global frame."""
        return tuple(GearBody(g.name, g.shaft, gear_node(g.shaft, g.name), g.teeth,
                              g.base_radius, np.asarray(g.frame, dtype=float))
                     for g in self.layout.gears)

    @cached_property
    def gear_meshes(self) -> tuple[GearMeshSpec, ...]:
        """One per ``[[meshes]]``: eq. (11) in the global frame (the layout's vector)."""
        return tuple(GearMeshSpec(m.name, m.gears, np.asarray(m.vector, dtype=float),
                                  m.teeth[0], m.speed_ratio) for m in self.layout.meshes)

    @property
    def load_nodes(self) -> tuple[str, ...]:
        gears = tuple(b.node for b in self.gear_bodies)
        ends = (f"{self.scene.drive.shaft}/start",)
        loads = tuple(n for ld in self.scene.loads for n in (f"{ld.shaft}/end",
                                                              f"{ld.shaft}/load"))
        return gears + ends + loads

    @property
    def parts(self) -> tuple[Part, ...]:
        return tuple(Part(f"shaft_{s.name}") for s in self.scene.shafts) \
            + (Part("housing", radiates=True),)

    def static_mesh_loads(self) -> tuple[float, ...]:
        """F_s per mesh from the torque path (:class:`TrainLayout`)."""
        return tuple(float(m.static_load) for m in self.layout.meshes)

    def mean_mesh_stiffness(self) -> tuple[float, ...]:
        """k̄ per mesh: ``[meshes.mesh_stiffness]`` (or its ISO 6336 estimate)."""
        out = []
        for i, m in enumerate(self.scene.meshes):
            if m.mesh_stiffness is None:
                raise InputError.of(f"meshes[{i}].mesh_stiffness", None, "missing (the scene "
                                    "loader fills in the ISO 6336 estimate)")
            out.append(float(m.mesh_stiffness.mean))
        return tuple(out)

    # ------------------------------------------------------------------ parameters
    @cached_property
    def params(self) -> GearboxFEParams:
        """``[housing]``, ``[mesh]``, ``[materials]`` (imports geometry and fem)."""
        return gearbox_parameters(self.scene.fe)

    @cached_property
    def geometry(self) -> Any:
        """The shafts in their housing (:class:`geometry.GearboxParams`)."""
        return gearbox_geometry(self.scene, self.layout, self.params)

    def check(self) -> None:
        """The layout, a periodic basis (``hbm.basis = "periodic"``) within
        ``hbm.max_aft_samples``, the FE sections and the geometry, before any meshing."""
        _ = self.layout
        h = getattr(self.scene, "hbm", None)     # machine tests build scenes without it
        if h is not None and h.basis == "periodic":
            self.layout.check_periodic(h.mesh_harmonics, h.max_aft_samples,
                                       h.sideband_order)
        p = self.params
        for i, s in enumerate(self.scene.shafts):
            if len(s.bearings) != 2:
                raise InputError.of(f"shafts[{i}].bearings", len(s.bearings), "a gearbox "
                                    "shaft has two bearings, one in each end wall")
        g = self.geometry
        if p.options.source == "parametric":
            g.validate()
        else:
            for i, s in enumerate(g.shafts):
                s.validate(f"shafts[{i}]")

    @property
    def mesh_size(self) -> float:
        return float(self.params.mesh.size)

    # ------------------------------------------------------------------ cache keys
    def stage_inputs(self, stage: str) -> dict[str, Any]:
        """mesh: the geometry (shafts placed, gears, housing), the housing options and
        ``[mesh]``; fe: materials, bearings, gear bodies, drive, loads, the meshes'
        vectors and the links; rom: ``[rom]``."""
        s = self.scene
        if stage == "mesh":
            out = {"geometry": dataclasses.asdict(self.geometry),
                   "housing": dataclasses.asdict(self.params.options),
                   "mesh": dataclasses.asdict(self.params.mesh)}
            if self.params.options.source in ("cad", "mesh"):  # the file's content
                f = Path(self.params.options.file)
                out["cad_sha256"] = (hashlib.sha256(f.read_bytes()).hexdigest()
                                     if f.is_file() else None)
            return out
        if stage == "fe":
            return {"materials": dataclasses.asdict(self.params.materials),
                    "bearings": [[dataclasses.asdict(b) for b in sh.bearings]
                                 for sh in s.shafts],
                    "gears": [[g.name, g.mass, g.inertia, g.face_width]
                              for g in self.layout.gears],
                    "drive": dataclasses.asdict(s.drive),
                    "loads": [dataclasses.asdict(ld) for ld in s.loads],
                    "vectors": [m.vector.tolist() for m in self.gear_meshes],
                    "links": [self.params.options.bore_link, self.params.options.journal_link,
                              self.params.options.hub_link]}
        if stage == "rom":
            return {"rom": rom_stage_inputs(s.rom)}
        raise ValueError(f"stage = {stage!r}: the gearbox's stages are {self.stages}")

    def stage_code(self, stage: str) -> tuple[str, ...]:
        own = ("machines.fe", "machines.sections", "machines.gearbox", "machines.train")
        code = {"mesh": ("geometry", *own), "fe": ("fem", *own),
                "rom": ("reduction", "fem.post", "machines.rom", *own)}
        if stage not in code:
            raise ValueError(f"stage = {stage!r}: the gearbox's stages are {self.stages}")
        return code[stage]

    # ------------------------------------------------------------------ builders
    def build_mesh(self, folder: Path) -> None:
        """Mesh the gearbox (gmsh, rank 0): ``gearbox.msh`` and ``mesh.json``."""
        from geometry import build_gearbox, gmsh_session, write_msh

        p = self.params
        with gmsh_session():
            try:
                src = p.options.source
                meshed = build_gearbox(
                    self.geometry, p.mesh, cad=cad_housing(p.options) if src == "cad" else None,
                    mesh_housing=mesh_housing(p.options) if src == "mesh" else None)
            except InputError:
                raise
            except (ValueError, RuntimeError) as exc:
                raise InputError(f"meshing: {exc}") from exc
            write_msh(Path(folder) / self.mesh_file)
            write_mesh_info(meshed, folder)

    def fe_parts(self) -> tuple[list, list, Any, list]:
        """The gears, bearings, drive and loads of :func:`fem.build_gearbox_model`."""
        from fem import GearboxBearing, GearboxDrive, GearboxGear, GearboxLoad
        from fem.gearbox import gear_body_mass

        o = self.params.options
        gears = []
        for g in self.layout.gears:
            diametral = 0.5 * g.inertia + g.mass * g.face_width ** 2 / 12.0
            gears.append(GearboxGear(gear_node(g.shaft, g.name), f"{g.shaft}/seat_{g.name}",
                                     gear_body_mass(g.mass, g.inertia, diametral),
                                     link=o.hub_link))
        bearings = []
        for s in self.scene.shafts:
            for name, b in zip(bearing_names(s), s.bearings, strict=True):
                bearings.append(GearboxBearing(
                    s.name, name, b.radial, b.axial,
                    journal_link=o.journal_link if b.journal_link == "housing" else
                    b.journal_link,
                    bore_link=o.bore_link if b.bore_link == "housing" else b.bore_link))
        d = self.scene.drive
        drive = GearboxDrive(d.shaft, d.motor_inertia, d.motor_torsional_stiffness)
        loads = [GearboxLoad(ld.shaft, ld.inertia, ld.torsional_stiffness)
                 for ld in self.scene.loads]
        return gears, bearings, drive, loads

    def build_fe_model(self, mesh_dir: Path, comm: Any = None) -> Any:
        """The gearbox's FE model from the cached mesh (:func:`fem.build_gearbox_model`;
        gear nodes in the order of :attr:`gear_bodies`, G = :meth:`directions`)."""
        from fem import build_gearbox_model, gearbox_materials

        fe_mesh = load_mesh(mesh_dir, self.mesh_file, comm)
        m = self.params.materials.by_volume()
        mats = gearbox_materials(fe_mesh.groups, m["shaft_in"], m["housing"])
        gears, bearings, drive, loads = self.fe_parts()
        return build_gearbox_model(fe_mesh, mats, gears, bearings, drive, loads,
                                   G=self.directions())

    def load_torques(self) -> dict[str, np.ndarray]:
        """The static load torque on each load node (6,), global frame: ``share T_d / ρ``
        against the shaft's sense of rotation."""
        out = {}
        for ld in self.scene.loads:
            t = np.zeros(6)
            t[5] = -self.layout.shaft(ld.shaft).sense * self.layout.load_torques[ld.shaft]
            out[f"{ld.shaft}/load"] = t
        return out

    def shaft_order_loads(self) -> tuple[dict[Fraction, dict[str, np.ndarray]],
                                         dict[Fraction, dict[str, np.ndarray]]]:
        """The ``[external]`` loads as node loads (6,) complex, global frame, per frequency
        ratio ``k ρ_s`` of the drive speed: (constant, Ω²-proportional) ``{p: {node:
        load}}``, each spread evenly on the gear nodes of its shaft (as the pump spreads
        its unbalance on its stations).

        ``[[external.aero]]``: ``[F, M] e^{iφ}`` at ``k ρ_s``. ``[[external.unbalance]]``:
        the force ``m e (ρ_s Ω)² (cos ψ, sin ψ, 0)``, ``ψ = σ ρ_s Ω t + φ`` (σ the shaft's
        sense: it turns with the shaft, at the angle φ from the global x axis at t = 0),
        i.e. the Ω²-coefficients ``m e ρ_s² e^{iσφ} (1, −iσ, 0)`` at ``ρ_s``."""
        lay = self.layout
        const: dict[Fraction, dict[str, np.ndarray]] = {}
        om2: dict[Fraction, dict[str, np.ndarray]] = {}

        def spread(out, p, shaft, load):
            gears = lay.gears_on(shaft)
            at = out.setdefault(p, {})
            for g in gears:
                node = gear_node(shaft, g.name)
                at[node] = at.get(node, np.zeros(6, complex)) + load / len(gears)

        ext = getattr(self.scene, "external", None)
        for a in getattr(ext, "aero", ()):
            f = np.concatenate([a.force, a.torque]) * np.exp(1j * a.phase)
            spread(const, int(a.order) * lay.shaft(a.shaft).speed_ratio, a.shaft, f)
        for u in getattr(ext, "unbalance", ()):
            s = lay.shaft(u.shaft)
            c = u.m_unb * float(s.speed_ratio) ** 2 * np.exp(1j * s.sense * u.phase)
            spread(om2, s.speed_ratio, u.shaft,
                   np.array([c, -1j * s.sense * c, 0, 0, 0, 0]))
        return const, om2

    def rom_forcing(self, rows: dict[str, np.ndarray], n_r: int
                    ) -> tuple[dict, dict]:
        """Order 0: the load torques on the load nodes (balanced by the motor spring on
        the drive shaft; the meshes carry the layout's F_s). The ``[external]`` loads at
        their frequency ratios ``k ρ_s`` (:meth:`shaft_order_loads`) projected with the
        basis rows, ``f_r = T_nodeᵀ f``."""
        const: dict = {0: np.zeros(n_r, complex)}
        for node, t in self.load_torques().items():
            const[0] += rows[node].T @ t
        const[0] = const[0].real.astype(complex)
        om2: dict = {}
        for source, target in zip(self.shaft_order_loads(), (const, om2), strict=True):
            for p, loads in source.items():
                target[p] = sum(rows[node].T @ f for node, f in loads.items())
        return const, om2
