"""The pump of the paper as an FE machine (``scene.kind = "fe"``).

Two parallel shafts ``in`` (the motor's, the reference speed) and ``out`` (the
impeller's) in a cast housing, one 1:1 gear pair between the gear bodies ``in/gear``
and ``out/gear`` (nodes of the FE model, DOF in the gear-pair frame of Fig. 1), the
scene's loads at the shafts' stations, couplings and gears. The geometry is
:func:`geometry.build_pump`, the FE model :func:`fem.build_pump_model`; the scene's
free FE sections reach them through :func:`machines.pump.params.fe_parameters`.
"""
from __future__ import annotations

from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from core.errors import InputError
from machines.base import Part
from machines.fe import FEMachine, load_mesh, write_mesh_info
from machines.pair import SHAFTS, OnePair
from machines.pump.params import FEParams, fe_parameters
from machines.registry import register
from machines.rom import rom_stage_inputs

__all__ = ["Pump", "SHAFTS", "N_STATIONS", "LOAD_NODES", "PARTS"]

#: Stations per shaft where the aerodynamic loads act (eq. 1).
N_STATIONS = 6
#: Named FE nodes whose basis rows are kept with the ROM (loads act there).
LOAD_NODES = tuple(f"{s}/station_{k}" for s in SHAFTS for k in range(1, N_STATIONS + 1)) \
    + ("in/coupling", "out/coupling", "in/gear", "out/gear")
#: The volumes; the housing radiates.
PARTS = (Part("shaft_in"), Part("shaft_out"), Part("housing", radiates=True))


@register
class Pump(OnePair, FEMachine):
    """The pump (see the module docstring)."""

    kind = "fe"
    summary = "geometry → FE → ROM"
    mesh_file = "pump.msh"

    # ------------------------------------------------------------------ what it is
    def gear_node(self, shaft: str) -> str:
        """Each gear body is the FE node of the same name (``in/gear``, ``out/gear``)."""
        return f"{shaft}/gear"

    @property
    def load_nodes(self) -> tuple[str, ...]:
        return LOAD_NODES

    @property
    def parts(self) -> tuple[Part, ...]:
        return PARTS

    @cached_property
    def params(self) -> FEParams:
        """The FE packages' parameters of the scene (imports geometry and fem)."""
        return fe_parameters(self.scene.fe, self.scene.gear)

    def check(self) -> None:
        """The free FE sections (:func:`machines.pump.params.fe_parameters`)."""
        _ = self.params

    @property
    def mesh_size(self) -> float:
        return float(self.params.mesh.size)

    # ------------------------------------------------------------------ cache keys
    def stage_inputs(self, stage: str) -> dict[str, Any]:
        """mesh: ``[geometry]``, ``[mesh]``, gear face width, tip radius and centre
        distance; fe: ``[materials]``, ``[bearings]``, ``[drive]``, ``[rotors]`` and
        ``[links]`` (these two only when given, so that scenes without them keep their
        keys) and the gear data of G; rom: ``[rom]``."""
        s = self.scene
        fe = s.fe
        if stage == "mesh":
            return {"geometry": fe.get("geometry", {}), "mesh": fe.get("mesh", {}),
                    "gear": {"face_width": s.gear.face_width, "tip_radius": s.gear.tip_radius,
                             "centre_distance": s.gear.centre_distance}}
        if stage == "fe":
            return {**{k: fe.get(k, {}) for k in ("materials", "bearings", "drive")},
                    **({"rotors": fe["rotors"]} if fe.get("rotors") else {}),
                    **({"links": fe["links"]} if fe.get("links") else {}),
                    "gear": {"base_radius": s.gear.base_radius,
                             "pressure_angle": s.gear.pressure_angle,
                             "helix_angle": s.gear.helix_angle,
                             "face_width": s.gear.face_width}}
        if stage == "rom":
            return {"rom": rom_stage_inputs(s.rom)}
        raise ValueError(f"stage = {stage!r}: the pump's stages are {self.stages}")

    def stage_code(self, stage: str) -> tuple[str, ...]:
        """geometry (mesh), fem (fe), reduction and fem.post (rom), each with this
        machine and :mod:`machines.fe` (and :mod:`machines.rom` for rom)."""
        own = ("machines.fe", "machines.sections", "machines.pump")
        code = {"mesh": ("geometry", *own), "fe": ("fem", *own),
                "rom": ("reduction", "fem.post", "machines.rom", *own)}
        if stage not in code:
            raise ValueError(f"stage = {stage!r}: the pump's stages are {self.stages}")
        return code[stage]

    # ------------------------------------------------------------------ builders
    def build_mesh(self, folder: Path) -> None:
        """Build and mesh the pump (gmsh, rank 0): ``pump.msh`` and ``mesh.json``."""
        from geometry import build_pump, gmsh_session, write_msh

        p = self.params
        with gmsh_session():
            try:
                meshed = build_pump(p.pump, p.mesh)
            except (ValueError, RuntimeError) as exc:  # sizes refused, or quality too low
                raise InputError(f"meshing: {exc}") from exc
            write_msh(Path(folder) / self.mesh_file)
            write_mesh_info(meshed, folder)

    def build_fe_model(self, mesh_dir: Path, comm: Any = None) -> Any:
        """FE model of the pump from the cached mesh (``fem.build_pump_model``; its gear
        nodes ``in/gear``, ``out/gear`` and G of eq. 11 as the one column)."""
        from fem import build_pump_model

        p = self.params
        fe_mesh = load_mesh(mesh_dir, self.mesh_file, comm)
        return build_pump_model(None, p.materials, p.gears, p.bearings, p.drive,
                                fe_mesh=fe_mesh, rotors=p.rotors)

    def rom_forcing(self, rows: dict[str, np.ndarray], n_r: int
                    ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
        """External forcing on the ROM per shaft order: constant and Ω²-proportional parts.

        Order 0: the impeller load torque T about +z on ``out/coupling`` (balanced by the
        motor spring on the input: mesh load F_s = T/r_b). Aerodynamic loads (eq. 1):
        node load ``[F, M] e^{iφ}`` on ``{shaft}/station_k`` projected with the basis
        rows, ``f_r = T_nodeᵀ f``. Unbalance (eq. 2–3): ``f_x = −m Ω² sin(Ωt + φ)``,
        ``f_y = −m Ω² cos(Ωt + φ)`` spread evenly on the six stations of the shaft,
        i.e. Ω²-coefficients ``(i m e^{iφ}, −m e^{iφ})/6`` at order 1.
        """
        scene = self.scene
        const: dict[int, np.ndarray] = {0: np.zeros(n_r, complex)}
        om2: dict[int, np.ndarray] = {}
        const[0] += rows["out/coupling"].T @ np.array([0, 0, 0, 0, 0, scene.load.torque])
        for a in scene.external.aero:
            f = np.concatenate([a.force, a.torque]) * np.exp(1j * a.phase)
            v = rows[f"{a.shaft}/station_{a.station}"].T @ f
            const[a.order] = const.get(a.order, np.zeros(n_r, complex)) + v
        for u in scene.external.unbalance:
            c = u.m_unb * np.exp(1j * u.phase) / 6.0
            f = np.array([1j * c, -c, 0, 0, 0, 0])
            for k in range(1, N_STATIONS + 1):
                v = rows[f"{u.shaft}/station_{k}"].T @ f
                om2[1] = om2.get(1, np.zeros(n_r, complex)) + v
        const[0] = const[0].real.astype(complex)
        return const, om2
