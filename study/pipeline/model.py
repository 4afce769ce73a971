"""Scene -> HBM inputs: gear meshes, harmonic set, excitation and the HBM problem.

The linear part (M, C, K), the directions of the gear meshes and the forcing come from
the scene's machine (:mod:`machines`: a lumped machine's linear system, or an FE
machine's ROM); this module adds what the scene says about each mesh and the excitation
(eq. 12–16) and builds the :class:`hbm.HBMProblem` with one gear-mesh element per mesh
of the machine.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from machines import FEMachine, LinearModel, Machine, machine_for
from study.scene.data import Scene

logger = logging.getLogger(__name__)

__all__ = ["gear_meshes", "harmonic_set", "build_problem", "scene_problem", "BasisChoice",
           "train_basis_choice", "torus_basis", "torus_resonance"]


def gear_meshes(scene: Scene, machine: Machine, G) -> list:
    """One :class:`hbm.GearMesh` per mesh of the machine, along its column of ``G``
    ``(n, E)`` (k_m and TE per mesh harmonic from the scene, static load from the
    machine's torque path, SI)."""
    from hbm import GearMesh

    G = np.asarray(G)
    specs = machine.gear_meshes
    if G.ndim != 2 or G.shape[1] != len(specs):
        raise ValueError(f"G.shape = {G.shape}: must be (n, {len(specs)}), one direction per "
                         "gear mesh of the machine")
    loads = machine.static_mesh_loads()
    if scene.is_train:
        layout = machine.layout
        return [GearMesh(direction=np.ascontiguousarray(G[:, e]), n_teeth=m.teeth,
                         stiffness=sm.mesh_stiffness.coefficients(),
                         te=sm.transmission_error.coefficients(), backlash=sm.backlash,
                         static_load=loads[e], te_kind=sm.transmission_error.kind,
                         speed_ratio=m.speed_ratio, name=m.name,
                         phase=layout.meshes[e].phase)
                for e, (m, sm) in enumerate(zip(specs, scene.meshes, strict=True))]
    te = scene.transmission_error
    cycles = mesh_cycles(scene)
    extra = {} if cycles == 1 else {"cycles": cycles}
    return [GearMesh(direction=np.ascontiguousarray(G[:, e]), n_teeth=m.teeth,
                     stiffness=series_coefficients(scene.mesh_stiffness, cycles),
                     te=series_coefficients(te, cycles), backlash=scene.gear.backlash,
                     static_load=loads[e], te_kind=te.kind, speed_ratio=m.speed_ratio,
                     name=m.name, **extra)
            for e, m in enumerate(specs)]


def mesh_cycles(scene: Scene) -> int:
    """Mesh periods over which a pair scene's k_m and TE repeat: 1, or the hunting period
    of an ``ltca`` source with pitch deviations (``[ltca] hunting``)."""
    c = (scene.mesh_stiffness.cycles, scene.transmission_error.cycles)
    return max(c)


def series_coefficients(series, cycles: int) -> dict[int, complex]:
    """The series' coefficients as harmonics of the mesh frequency / ``cycles``: a series
    over ``cycles`` mesh periods as it is, a mesh-period series (``series.cycles = 1``)
    with its harmonic m moved to ``m cycles``."""
    coef = series.coefficients()
    if series.cycles == cycles:
        return coef
    if series.cycles != 1:
        raise ValueError(f"series over {series.cycles} mesh periods beside one over {cycles}: "
                         "cannot combine")
    return {m * cycles: c for m, c in coef.items()}


@dataclass(frozen=True)
class BasisChoice:
    """The harmonic basis of a train and what the other one would have cost.

    Attributes
    ----------
    basis : hbm.HarmonicSet or hbm.TorusBasis
        The basis chosen.
    kind : str
        ``"periodic"`` (one fundamental: the hunting fundamental) or ``"torus"``.
    requested : str
        ``hbm.basis`` of the scene (``auto``, ``periodic``, ``torus``).
    fundamental : Fraction
        The hunting fundamental over the drive speed.
    periodic_harmonics, periodic_samples : int
        Harmonics and AFT samples per period of the periodic set.
    torus_harmonics, torus_samples : int
        Harmonic vectors and AFT samples (product of the grid) of the torus.
    """

    basis: Any
    kind: str
    requested: str
    fundamental: Fraction
    periodic_harmonics: int
    periodic_samples: int
    torus_harmonics: int
    torus_samples: int

    def attributes(self) -> dict[str, Any]:
        """The choice as results.h5 attributes (``/continuation``)."""
        return {"basis": self.kind, "basis_requested": self.requested,
                "hunting_fundamental": str(self.fundamental),
                "periodic_harmonics": self.periodic_harmonics,
                "periodic_aft_samples": self.periodic_samples,
                "torus_harmonics": self.torus_harmonics,
                "torus_aft_samples": self.torus_samples}


def train_basis_choice(scene: Scene, layout) -> BasisChoice:
    """The basis of a train scene (docs/hbm.md, "The basis of a train scene").

    Periodic: the one-dimensional set over the hunting fundamental of the meshes and the
    excited shaft orders (:meth:`TrainLayout.periodic_indices`: every combination of the
    meshes' harmonics up to ``hbm.mesh_harmonics``, each with the shaft orders' sidebands
    up to ``hbm.sideband_order``). Torus (:func:`torus_basis`): one base per distinct
    mesh frequency and one per distinct speed of an excited shaft. ``auto`` takes the
    periodic set when its AFT grid stays within ``hbm.max_aft_samples``; ``periodic``
    above it is refused (naming the field and the size it needs). The choice and both
    sizes are logged."""
    from hbm import HarmonicSet

    h = scene.hbm
    H, s = h.mesh_harmonics, h.sideband_order
    r = layout.hunting_fundamental()
    idx = layout.periodic_indices(H, s)
    n_periodic = h.aft_samples or layout.periodic_aft_samples(H, s)
    torus = torus_basis(layout, H, s)
    n_torus = int(np.prod(torus.n_time))
    if h.basis == "periodic":
        layout.check_periodic(H, h.max_aft_samples, s)
    kind = h.basis if h.basis != "auto" else (
        "periodic" if n_periodic <= h.max_aft_samples else "torus")
    n_mesh_bases = len({m.frequency_ratio for m in layout.meshes})
    if kind == "periodic":
        one = n_mesh_bases == 1 and not layout.shaft_orders
        basis = HarmonicSet(idx, ratio=r, fundamental="mesh" if one else "hunting",
                            n_time=n_periodic)
    else:
        basis = torus
    choice = BasisChoice(basis, kind, h.basis, r, len(idx), n_periodic,
                         len(torus.indices), n_torus)
    logger.info("harmonic basis: %s (hbm.basis = %r); periodic over the hunting fundamental "
                "%s Omega: %d harmonics, %d AFT samples; torus of %d bases (%s): %d "
                "harmonics, %d AFT samples", kind, h.basis, r, len(idx), n_periodic,
                torus.dimension, ", ".join(torus.names), len(torus.indices), n_torus)
    return choice


def torus_basis(layout, mesh_harmonics: int, sideband_order: int = 0):
    """The torus of a train (:func:`hbm.train_basis`): a carrier base per distinct mesh
    frequency with ``mesh_harmonics`` harmonics, and a sideband base per distinct speed
    ``ρ_s`` of an excited shaft with its orders, combined up to ``max(sideband_order, 1)``
    (the orders themselves and their sidebands around every mesh combination).

    Why mesh bases and not the shafts' speeds alone: a mesh's frequency is ``Z ρ`` of
    its gear's shaft, so on shaft bases its harmonic m would be the lattice vector
    ``m Z e_shaft`` and the grid along that shaft would need ``> 2 H Z`` samples (2048
    for Z = 23, H = 6, against 64 along a mesh base), and the two gears of a mesh give
    it two vectors (``Z_1 e_1``, ``Z_2 e_2``) of which the element may take only one.
    The mesh and shaft bases are commensurate (``Z_1 ρ_1 = Z_2 ρ_2``); the torus treats
    them as independent, which averages over their relative phases (docs/theory.md
    T.39-T.40: the relation enters only through combinations of high order, e.g. 68 for
    the second mesh of 19:67 against its output shaft).

    An excited order whose frequency equals a mesh frequency is that mesh's first
    harmonic (its base) and adds no sideband; every other order ``k`` of shaft ``s``
    is the lattice vector ``k e_s`` of the excitation key ``k ρ_s`` (``vectors``)."""
    from hbm import train_basis

    meshes: dict[str, Fraction] = {}
    for m in layout.meshes:
        if m.frequency_ratio not in meshes.values():
            meshes[m.name] = m.frequency_ratio
    shafts: dict[str, tuple[Fraction, list[int]]] = {}
    keys: dict[Fraction, tuple[str, int]] = {}
    for (name, k), p in layout.order_frequencies().items():
        if p in meshes.values() or p in keys:
            continue
        speed = layout.shaft(name).speed_ratio
        base = next((b for b, (v, _) in shafts.items() if v == speed), f"shaft {name}")
        if base in meshes:
            raise ValueError(f"torus: shaft base {base!r} has the name of a mesh")
        shafts.setdefault(base, (speed, []))[1].append(k)
        keys[p] = (base, k)
    names = list(meshes) + list(shafts)
    vectors = {}
    for p, (base, k) in keys.items():
        if k > 1:      # order 1 is the base itself
            v = [0] * len(names)
            v[names.index(base)] = k
            vectors[p] = tuple(v)
    torus = train_basis(meshes, mesh_harmonics,
                        {b: (v, tuple(sorted(o))) for b, (v, o) in shafts.items()},
                        sideband_order=max(int(sideband_order), 1), vectors=vectors)
    _warn_resonances(torus)
    return torus


def torus_resonance(torus) -> tuple[int, ...] | None:
    """The shortest (sum of |k_j|) non-zero integer vector ``k`` (canonical: first
    non-zero component > 0) with ``k . r = 0`` and
    ``|k_j| <= 3 max |k_j|`` of the set, or None.

    Such a ``k`` joins two different harmonics of the torus of one frequency within the
    reach of the harmonic balance (a product of two harmonics of the set reaches 2 max |k|
    and can land on the frequency of a third): the periodic set over the hunting period
    couples them, the torus — which averages over the relative phases of its bases —
    does not, so the two differ at the size of that coupling (docs/hbm.md)."""
    n = np.asarray(torus.multiples, dtype=np.int64)
    top = [3 * int(t) for t in torus.max_index]
    d = len(n)
    if d < 2:
        return None
    grids = np.meshgrid(*[np.arange(-t, t + 1) for t in top[:-1]], indexing="ij")
    head = np.stack([g.ravel() for g in grids], axis=-1)
    rest = head @ n[:-1]
    ok = (rest % n[-1] == 0)
    last = -rest // n[-1]
    ok &= np.abs(last) <= top[-1]
    k = np.concatenate([head, last[:, None]], axis=1)[ok]
    k = k[np.any(k != 0, axis=1)]
    if not len(k):
        return None
    from hbm.torus import canonical

    return canonical(k[np.argmin(np.abs(k).sum(axis=1))])


def _warn_resonances(torus) -> None:
    """Log a warning naming :func:`torus_resonance`'s vector when there is one."""
    k = torus_resonance(torus)
    if k is not None:
        terms = " ".join(f"{'+' if v > 0 else '-'} {abs(v)} {name!r}".replace(" 1 '", " '")
                         for v, name in zip(k, torus.names, strict=True) if v)
        logger.warning("torus: the bases are commensurate within the reach of the set "
                       "(%s = 0, order %d): the torus averages over their relative phase "
                       "and is not this train's response at that order; use hbm.basis = "
                       "'periodic'", terms.lstrip("+ "), sum(abs(v) for v in k))


def harmonic_set(scene: Scene, machine: Machine | None = None):
    """The :class:`hbm.HarmonicSet`: explicit list, or built from the excitation orders.

    Without external excitation the fundamental is the mesh frequency ZΩ and the
    indices are 0…n (``hbm.mesh_harmonics``); with it, the shaft frequency Ω with
    mesh harmonics kZ, the external orders and their sidebands. A train's basis is
    :func:`train_basis_choice`'s (periodic or torus).
    """
    from hbm import HarmonicSet

    if scene.is_train:
        if machine is None:
            machine = machine_for(scene)
        return train_basis_choice(scene, machine.layout).basis

    h = scene.hbm
    n_time = h.aft_samples or None
    ext = scene.external.orders
    cycles = mesh_cycles(scene)
    if cycles > 1 and h.harmonics is None:
        return hunting_set(scene, cycles, n_time)
    if h.harmonics is not None:
        if ext:
            return HarmonicSet(h.harmonics, ratio=1, fundamental="shaft", n_time=n_time)
        return HarmonicSet(h.harmonics, ratio=scene.gear.teeth, fundamental="mesh",
                           n_time=n_time)
    return HarmonicSet.build(scene.gear.teeth, h.mesh_harmonics, ext, h.sideband_order,
                             n_time=n_time, kind=h.harmonic_set)


def hunting_set(scene: Scene, cycles: int, n_time: int | None):
    """The set of a pair whose k_m and TE repeat every ``cycles`` mesh periods (pitch
    deviations): every harmonic of the hunting frequency ZΩ/cycles up to the top mesh
    harmonic ``hbm.mesh_harmonics`` (the sidebands of each mesh harmonic are dense), and
    the external orders with their sidebands as the contiguous set has them."""
    from hbm import HarmonicSet

    h, z = scene.hbm, scene.gear.teeth
    ext = scene.external.orders
    top = h.mesh_harmonics * z + (h.sideband_order * max(ext) if ext else 0)
    ratio = Fraction(z, cycles)
    per_order = 1 / ratio                            # harmonic indices per shaft order
    if per_order.denominator != 1:
        raise ValueError(f"hunting period of {cycles} mesh periods: its frequency Z/{cycles} "
                         f"= {ratio} shaft orders is not a submultiple of the shaft speed")
    idx = list(range(0, top * int(per_order) + 1))
    logger.info("harmonic set over the hunting period (%d mesh periods): %d harmonics of "
                "%s Omega", cycles, len(idx), ratio)
    return HarmonicSet(idx, ratio=ratio, fundamental="hunting", n_time=n_time)


def build_problem(scene: Scene, machine: Machine, linear: LinearModel):
    """Assemble :class:`hbm.HBMProblem` from the machine's linear model and forcing."""
    from hbm import Excitation, HBMProblem, LinearSystem

    system = LinearSystem(np.asarray(linear.M), np.asarray(linear.C), np.asarray(linear.K))
    exc = Excitation(system.n_dof, constant=linear.constant,
                     omega_squared=linear.omega_squared or {})
    return HBMProblem(system, gear_meshes(scene, machine, linear.G), exc,
                      harmonic_set(scene, machine),
                      condensation=scene.hbm.condensation,
                      linear_solver=scene.hbm.linear_solver)


def scene_problem(scene: Scene, rom_dir: str | Path | None = None):
    """(HBMProblem, RomData or None) of a scene: a lumped machine's own linear system, or
    an FE machine's ROM read from its cached rom folder ``rom_dir``."""
    machine = machine_for(scene)
    if isinstance(machine, FEMachine):
        if rom_dir is None:
            raise ValueError(f"scene.kind = {scene.scene.kind!r}: the problem is built on a "
                             "ROM; give its cached folder (rom_dir)")
        rom = machine.load_rom(Path(rom_dir))
        return build_problem(scene, machine, machine.linear_model(rom)), rom
    return build_problem(scene, machine, machine.linear_model()), None
