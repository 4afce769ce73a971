"""The table of docs/gears.md "Table 1's pair at class 6, beside the shipped scenes" is
what ``python -m benchmarks.ltca_pump --docs`` produces (issue 38 item 3's last point):
the LTCA of the paper's Table 1 pair at ISO 1328 class-6 deviations beside the pump
scenes' calibrated values, the last row through the scene loader (``source = "ltca"``)."""
from __future__ import annotations

import pytest

from benchmarks import ltca_pump


@pytest.fixture(scope="module")
def data():
    d = ltca_pump.measure((ltca_pump.DOCS_TORQUE,), 1440, 1280)
    d["scene_ltca"] = ltca_pump.scene_ltca(1440, 1280,
                                           ltca_pump.CASES["class 6, profile + helix (gear 1)"])
    return d


def test_the_docs_table_is_the_generated_one(data):
    assert ltca_pump.docs_table(data) in ltca_pump.DOCS.read_text()


def test_the_scene_loader_gives_the_ltca_of_the_same_case(data):
    direct = data["cases"][f"class 6, profile + helix (gear 1) @ {ltca_pump.DOCS_TORQUE} N·m"]
    wired = data["scene_ltca"]
    assert wired["torque_Nm"] == ltca_pump.DOCS_TORQUE
    for sec, key in (("mesh_stiffness", "amplitudes_N_per_um"),
                     ("transmission_error", "amplitudes_um")):
        # scene_coefficients rounds to 3-4 decimals; the scene keeps every digit
        assert wired[sec][key][:3] == pytest.approx(direct[sec][key], abs=6e-4)
    assert wired["mesh_stiffness"]["mean_N_per_um"] == pytest.approx(
        direct["mesh_stiffness"]["mean_N_per_um"], abs=6e-4)
