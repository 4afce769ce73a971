"""core.errors: the message of a refused input names the field, its value, unit and range."""
from __future__ import annotations

import pickle

import pytest

from core.errors import InputError, check_range, range_text, show, suggest
from study.scene.errors import SceneError


def test_message_names_field_value_unit_and_range() -> None:
    err = InputError.of("gear.backlash_um", -3, "must be > 0")
    assert str(err) == "gear.backlash_um = -3: must be > 0"
    assert (err.field, err.value, err.unit, err.allowed) == ("gear.backlash_um", -3, "",
                                                             "must be > 0")
    assert str(InputError.of("module", -1e-3, "must be > 0", unit="m")) == \
        "module = -0.001 m: must be > 0"
    assert str(InputError.of("hand", "left", "must be 1 or -1")) == \
        "hand = 'left': must be 1 or -1"
    assert isinstance(err, ValueError)


def test_range_text_and_show() -> None:
    assert range_text(0, None, lo_open=True) == "> 0"
    assert range_text(5, 45) == ">= 5 and <= 45"
    assert range_text(0, 1, hi_open=True) == ">= 0 and < 1"
    assert range_text() == "any"
    assert show("abc") == "'abc'" and show(2.5) == "2.5"


def test_check_range_refuses_out_of_range_and_non_finite() -> None:
    assert check_range("b", 0.02, lo=0, lo_open=True, unit="m") == 0.02
    with pytest.raises(InputError, match=r"^b = 0 m: must be finite and > 0$"):
        check_range("b", 0, lo=0, lo_open=True, unit="m")
    with pytest.raises(InputError, match=r"^x = nan: must be finite and >= -1 and <= 1$"):
        check_range("x", float("nan"), lo=-1, hi=1)
    with pytest.raises(InputError, match=r"^z = True: must be a finite number$"):
        check_range("z", True)
    with pytest.raises(SceneError, match="gear.teeth = 3"):
        check_range("gear.teeth", 3, lo=5, error=SceneError)


def test_errors_pickle_with_their_parts() -> None:
    """A parallel run sends the error of a worker back to the parent process."""
    for err in (InputError.of("a", 1, "must be > 2", unit="m"), SceneError("free text")):
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is type(err) and str(back) == str(err)
        assert (back.field, back.value, back.unit) == (err.field, err.value, err.unit)


def test_suggest_names_the_closest_allowed_name() -> None:
    assert suggest("backlsh", ["backlash", "teeth"]) == " (did you mean 'backlash'?)"
    assert suggest("zzz", ["backlash", "teeth"]) == ""
