"""Shared pieces of the CAD-import tests: the gearbox script, the pump housing as STEP,
the seats and feet a scene would state for both."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "gearbox_housing_step.py"


def gearbox_script() -> ModuleType:
    """scripts/gearbox_housing_step.py as a module."""
    name = "gearbox_housing_step"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    sys.modules[name] = mod  # dataclasses look their module up while the class is made
    spec.loader.exec_module(mod)
    return mod


def write_pump_housing_step(path: Path) -> Path:
    """The parametric pump housing (default parameters) as a STEP file in mm."""
    from geometry import HousingParams, build_housing, gmsh_session, write_step
    from geometry.params import DEFAULT_CENTRE_DISTANCE

    with gmsh_session():
        return write_step(path, lambda: build_housing(HousingParams(),
                                                      DEFAULT_CENTRE_DISTANCE))


def pump_seats(width: float = 0.015) -> list:
    """The pump housing's four bores as seats ``in_a`` ... ``out_b`` (the pump's group
    names ``housing/bore_{s}_{a|b}``), at the bore mid-planes."""
    from geometry import BearingSeat, HousingParams
    from geometry.params import DEFAULT_CENTRE_DISTANCE

    h = HousingParams()
    out = []
    for s, x in (("in", 0.0), ("out", DEFAULT_CENTRE_DISTANCE)):
        for end, (za, zb) in (("a", h.bore_a_z), ("b", h.bore_b_z)):
            out.append(BearingSeat(f"{s}_{end}", point=(x, 0.0, 0.5 * (za + zb)),
                                   direction=(0.0, 0.0, 1.0), radius=h.bore_radius,
                                   width=width))
    return out


def pump_feet(per_patch: bool = False) -> object:
    """The pump housing's feet: the plane under them, normal -y (group housing/feet)."""
    from geometry import HousingParams, Mount

    h = HousingParams()
    y = -0.5 * h.height_y - h.foot_height
    return Mount("feet", plane=((0.0, y, 0.0), (0.0, -1.0, 0.0)), per_patch=per_patch)
