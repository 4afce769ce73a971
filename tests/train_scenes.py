"""The shipped two-stage train (scenes/two-stage-lumped.toml) with stage 2's mesh
excitation tables replaced: the scenes of the LTCA-per-mesh, tutorial (section 8) and
micro-geometry tests (not collected by pytest)."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Stage 2's tables in the shipped scene (the ISO 6336 estimates).
STAGE2_ESTIMATE = ('[meshes.mesh_stiffness]\nestimate = true\nn_harmonics = 5\n'
                   '[meshes.transmission_error]\nestimate = true\n')

#: Stage 2 from the LTCA with tip relief from 40 / 135 mm and crowning (docs/tutorial.md
#: section 8).
LTCA_RELIEVED = ('[meshes.mesh_stiffness]\nsource = "ltca"\n[meshes.transmission_error]\n'
                 'source = "ltca"\nkind = "loaded"\n[meshes.micro_geometry.both]\n'
                 'tip_relief_um = 20.0\ncrowning_um = 4.0\n[meshes.micro_geometry.gear1]\n'
                 'tip_relief_start_diameter_mm = 40.0\n[meshes.micro_geometry.gear2]\n'
                 'tip_relief_start_diameter_mm = 135.0\n')


def two_stage_parts() -> tuple[str, str]:
    """The shipped scene's text before and after stage 2's tables."""
    text = (ROOT / "scenes" / "two-stage-lumped.toml").read_text()
    assert text.count(STAGE2_ESTIMATE) == 2
    head, tail = text.rsplit(STAGE2_ESTIMATE, 1)
    return head, tail


def two_stage_with_stage2(tables: str) -> str:
    """The shipped scene's text with ``tables`` as stage 2's excitation tables."""
    head, tail = two_stage_parts()
    return head + tables + tail
