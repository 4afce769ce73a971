"""The mesh excitation behind a run's k_m and TE when they come from the loaded tooth
contact analysis or a table (``source = "ltca" | "table"``, issue 38): its arrays
(:class:`MeshExcitation`), built from :mod:`gears` (:func:`from_source`), kept by the
ltca stage's cache (:meth:`MeshExcitation.save` / :meth:`MeshExcitation.load`, one
``.npz``) and written to results.h5 ``/mesh_excitation`` (:func:`write_group`; a train's meshes in
``/elements/<i>/mesh_excitation``, :func:`write_element_groups`; docs/results-format.md)
and summarised in report.md (:func:`source_lines`). SI units.
"""
from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.files import atomic_write
from gears.ltca import LtcaCase, contact_pattern, harris_map
from study.scene.data import MeshSource
from study.scene.excitation import solve_cached

logger = logging.getLogger(__name__)

__all__ = ["MeshExcitation", "from_source", "write_group", "write_element_groups",
           "source_lines", "PROFILE_BINS"]

#: Profile bins of the contact pattern.
PROFILE_BINS = 40

#: Arrays of the LTCA part: name -> (unit, meaning) (docs/results-format.md).
LTCA_ARRAYS = {
    "t": ("mesh periods", "time of each roll position, [0, periods)"),
    "ste": ("m", "loaded static transmission error q_s"),
    "stiffness": ("N/m", "tangent mesh stiffness k_m"),
    "no_load_te": ("m", "kinematic (unloaded) transmission error"),
    "pair_load": ("N", "load of each tooth-pair slot (positions, slots): the load sharing"),
    "slots": ("", "index j of each tooth-pair slot"),
    "teeth": ("", "tooth of gear 1 and gear 2 in each slot (positions, slots, 2)"),
    "pattern_diameter": ("m", "profile bin centres of gear 1's and gear 2's flank (2, bins)"),
    "pattern_z": ("m", "axial position of the slices, mid-face 0"),
    "pattern_line_load": ("N/m", "largest load per face width met on each flank "
                          "(2, bins, slices): the contact pattern"),
    "harris_torque": ("N m", "torques of the Harris map"),
    "harris_ste_peak_to_peak": ("m", "peak-to-peak q_s at each torque (mesh-periodic "
                                "part: pitch deviations left out)"),
    "harris_ste_mean": ("m", "mean q_s at each torque"),
    "harris_stiffness_mean": ("N/m", "mean k_m at each torque"),
    "harris_stiffness_peak_to_peak": ("N/m", "peak-to-peak k_m at each torque"),
}
#: Arrays of a table source: name -> (unit, meaning).
TABLE_ARRAYS = {
    "table_te_position": ("mesh periods", "positions of the TE table's samples"),
    "table_te": ("m", "TE samples"),
    "table_stiffness_position": ("mesh periods", "positions of the stiffness table's samples"),
    "table_stiffness": ("N/m", "stiffness samples"),
}


@dataclass
class MeshExcitation:
    """What a run shows of its ``ltca``/``table`` mesh excitation (SI).

    Attributes
    ----------
    stiffness_source, te_source : str
        ``fourier``, ``ltca`` or ``table``.
    harmonics : int
        Mesh harmonics kept for the dynamics.
    torque : float
        Torque of the LTCA (N·m); NaN without one.
    periods, n_positions, n_slices : int
        Mesh periods solved (1, or the hunting period with pitch deviations), positions
        per period and slices of the LTCA (0 without one).
    arrays : dict of str to ndarray
        The arrays of :data:`LTCA_ARRAYS` and :data:`TABLE_ARRAYS` that apply.
    """

    stiffness_source: str
    te_source: str
    harmonics: int
    torque: float = float("nan")
    periods: int = 0
    n_positions: int = 0
    n_slices: int = 0
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def has_ltca(self) -> bool:
        return "ste" in self.arrays

    def mesh_cycle(self, name: str) -> np.ndarray:
        """Synchronous average of an LTCA array over the mesh period (n_positions,)."""
        v = self.arrays[name]
        return v.reshape(self.periods, self.n_positions, *v.shape[1:]).mean(axis=0)

    def save(self, path: Path) -> None:
        """One ``.npz`` (atomic): the scalars and the arrays."""
        meta = {k: getattr(self, k) for k in ("stiffness_source", "te_source", "harmonics",
                                               "torque", "periods", "n_positions", "n_slices")}
        with atomic_write(Path(path)) as tmp, open(tmp, "wb") as f:
            np.savez(f, **{f"meta_{k}": np.asarray(v) for k, v in meta.items()},
                     **self.arrays)

    @classmethod
    def load(cls, path: Path) -> MeshExcitation:
        with np.load(Path(path), allow_pickle=False) as z:
            meta = {k[5:]: z[k].item() for k in z.files if k.startswith("meta_")}
            arrays = {k: z[k] for k in z.files if not k.startswith("meta_")}
        return cls(**{k: meta[k] for k in ("stiffness_source", "te_source", "harmonics",
                                           "torque", "periods", "n_positions", "n_slices")},
                   arrays=arrays)


def _mesh_periodic(case: LtcaCase) -> LtcaCase:
    """``case`` without its pitch deviations: the mesh-periodic part, whose STE
    fluctuation a Harris map shows (with them it would be the pitch errors' at every
    torque, over the whole hunting period)."""
    if case.periods == 1:
        return case
    flanks = tuple(dataclasses.replace(f, pitch_deviations=()) for f in case.flanks)
    return dataclasses.replace(case, flanks=flanks)


def from_source(src: MeshSource) -> MeshExcitation:
    """The arrays of a mesh's :class:`~study.scene.data.MeshSource`: the LTCA (solved once
    per case and process, :func:`study.scene.excitation.solve_cached`) with its load
    sharing, both flanks' contact patterns and the Harris map over ``src.harris_torques``
    (of the mesh-periodic part: pitch deviations left out); the samples of its tables."""
    out = MeshExcitation(src.stiffness, src.te, src.harmonics)
    if src.case is not None:
        case = src.case
        res = solve_cached(case)
        patterns = [contact_pattern(res, gear, PROFILE_BINS) for gear in (1, 2)]
        harris = harris_map(_mesh_periodic(case), np.asarray(src.harris_torques))
        out = dataclasses.replace(out, torque=case.torque, periods=res.periods,
                                  n_positions=case.n_positions, n_slices=int(res.z.size))
        out.arrays.update(
            t=res.t, ste=res.ste, stiffness=res.stiffness, no_load_te=res.no_load_te,
            pair_load=res.pair_load, slots=res.slots, teeth=res.teeth,
            pattern_diameter=np.stack([p.diameter for p in patterns]),
            pattern_z=res.z, pattern_line_load=np.stack([p.line_load for p in patterns]),
            harris_torque=harris.torque, harris_ste_peak_to_peak=harris.ste_peak_to_peak,
            harris_ste_mean=harris.ste_mean, harris_stiffness_mean=harris.stiffness_mean,
            harris_stiffness_peak_to_peak=harris.stiffness_peak_to_peak)
    for quantity, table in src.tables.items():
        out.arrays[f"table_{quantity}_position"] = np.asarray(table.position)
        out.arrays[f"table_{quantity}"] = np.asarray(getattr(table, quantity))
    return out


def write_group(f, data: MeshExcitation) -> None:
    """``/mesh_excitation`` of results.h5 (docs/results-format.md): the sources and
    harmonics as attributes, every array with its unit and meaning."""
    g = f.create_group("mesh_excitation")
    g.attrs["stiffness_source"] = data.stiffness_source
    g.attrs["te_source"] = data.te_source
    g.attrs["harmonics"] = data.harmonics
    if data.has_ltca:
        g.attrs["torque"] = data.torque
        g.attrs["periods"] = data.periods
        g.attrs["n_positions"] = data.n_positions
        g.attrs["n_slices"] = data.n_slices
    for name, (unit, meaning) in {**LTCA_ARRAYS, **TABLE_ARRAYS}.items():
        if name in data.arrays:
            g[name] = data.arrays[name]
            g[name].attrs["unit"] = unit
            g[name].attrs["meaning"] = meaning


def write_element_groups(f, per_mesh: dict[str, MeshExcitation]) -> None:
    """``/elements/<i>/mesh_excitation`` of a train's results.h5 (:func:`write_group` in
    the group of the element named like the mesh) for each mesh of ``per_mesh``."""
    groups = {g.attrs["name"]: g for g in f["elements"].values()}
    for name, data in per_mesh.items():
        if name not in groups:
            raise KeyError(f"results.h5 /elements holds no element named {name!r} "
                           f"(it has {sorted(groups)})")
        write_group(groups[name], data)


def source_lines(src: MeshSource, data: MeshExcitation | None, where: str,
                 mesh: str = "") -> list[str]:
    """report.md lines of an ``ltca``/``table`` source: where k_m and the TE come from
    and the harmonics kept, with the LTCA's loaded STE, k_m range and the Harris map's
    smallest STE fluctuation; ``where`` names the results.h5 group of the arrays,
    ``mesh`` the train mesh (empty for a one-pair scene)."""
    of = f" of {mesh}" if mesh else ""
    out = [f"- mesh excitation{of}: k_m from `{src.stiffness}`, TE from `{src.te}` "
           f"({src.harmonics} mesh harmonics kept; arrays in results.h5 `{where}`)"]
    if data is not None and data.has_ltca:
        a = data.arrays
        i = int(np.argmin(a["harris_ste_peak_to_peak"]))
        out.append(f"- LTCA{of} at {data.torque:g} N·m ({data.periods} mesh period(s) × "
                   f"{data.n_positions} positions, {data.n_slices} slice(s)): loaded STE "
                   f"peak-to-peak {np.ptp(a['ste']) * 1e6:.3f} µm, k_m "
                   f"{a['stiffness'].min() * 1e-6:.1f}–{a['stiffness'].max() * 1e-6:.1f} N/µm; "
                   f"Harris map: smallest STE fluctuation "
                   f"{a['harris_ste_peak_to_peak'][i] * 1e6:.3f} µm at "
                   f"{a['harris_torque'][i]:.3g} N·m")
    return out
