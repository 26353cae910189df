"""Move parameters: what a move does, read off its file, and the move rescaled (server.studio.moves, pure)."""

from __future__ import annotations

from typing import Any

import pytest

from planning.maneuver import validate_maneuver
from planning.maneuver.load import read_yaml
from server.studio.editor import MOVES_DIR
from server.studio.moves import MAX_STEP_PER_CYCLE_M, MAX_TURN_PER_CYCLE_DEG, natural_params, scale_move

H = 0.52


def _move(name: str) -> dict[str, Any]:
    return dict(read_yaml((MOVES_DIR / f"{name}.yaml").read_text())[0])


def test_natural_parameters_are_read_off_what_the_move_does() -> None:
    assert natural_params(_move("turn-left-45")) == {"angle": 45.0}
    assert natural_params(_move("turn-right-45"))["angle"] == pytest.approx(-45.0)
    assert natural_params(_move("trot-forward")) == {"distance": pytest.approx(0.32)}
    assert natural_params(_move("bow")) == {"amount": 1.0}
    assert natural_params(_move("sway")) == {"amount": 1.0}
    assert "amount" in natural_params(_move("look-left")) and "angle" not in natural_params(
        _move("look-left")
    )


def test_an_angle_within_the_trots_reach_keeps_the_cycles() -> None:
    m = _move("turn-left-45")
    out = scale_move(m, standing_height_m=H, angle=30.0)
    g, g0 = out["gaits"][0], m["gaits"][0]
    assert (g["from"], g["to"], out["duration"]) == (g0["from"], g0["to"], m["duration"])
    assert natural_params(out)["angle"] == pytest.approx(30.0)
    assert m["gaits"][0]["step"][2] == 11.25  # the input is left alone


def test_a_larger_turn_takes_more_cycles_and_the_move_grows() -> None:
    m = _move("turn-left-45")
    out = scale_move(m, standing_height_m=H, angle=-180.0)
    g = out["gaits"][0]
    cycles = round((g["to"] - g["from"]) / g["cycle"])
    assert cycles == 8 and abs(g["step"][2]) <= MAX_TURN_PER_CYCLE_DEG
    assert natural_params(out)["angle"] == pytest.approx(-180.0)
    assert out["duration"] == pytest.approx(m["duration"] + 4 * g["cycle"])
    assert validate_maneuver(out).ok


def test_distance_scales_the_steps_and_stays_a_trot() -> None:
    m = _move("trot-forward")
    out = scale_move(m, standing_height_m=H, distance=1.0)
    g = out["gaits"][0]
    assert natural_params(out)["distance"] == pytest.approx(1.0, abs=1e-3)  # steps rounded to 0.1 mm
    assert g["step"][0] <= MAX_STEP_PER_CYCLE_M and g["step"][1] == 0
    out = scale_move(_move("side-step-left"), standing_height_m=H, distance=0.08)
    assert out["gaits"][0]["step"][1] == pytest.approx(0.02)


def test_amount_scales_the_lean_and_the_dip_about_the_standing_pose() -> None:
    out = scale_move(_move("bow"), standing_height_m=H, amount=1.5)
    first, last = out["body"][0], out["body"][-1]
    assert first["rpy"][1] == pytest.approx(27.0) and first["position"][2] == pytest.approx(H - 1.5 * 0.07)
    assert last["position"] == [0.0, 0.0, H] and last["rpy"] == [0.0, 0.0, 0.0]
    out = scale_move(_move("look-left"), standing_height_m=H, amount=0.5)
    assert max(abs(k["rpy"][2]) for k in out["body"]) == pytest.approx(
        0.5 * max(abs(k["rpy"][2]) for k in _move("look-left")["body"])
    )


@pytest.mark.parametrize(
    ("move", "kw", "text"),
    [
        ("bow", {"angle": 30.0}, "angle: the move 'bow' has no angle to set (it has: amount)"),
        ("turn-left-45", {"angle": 400.0}, "angle: must be between -360 and 360"),
        ("trot-forward", {"distance": -1.0}, "distance: must be between 0 and 3"),
        ("bow", {"amount": 5.0}, "amount: must be between 0 and 2"),
    ],
)
def test_bad_parameters_are_named(move: str, kw: dict[str, float], text: str) -> None:
    with pytest.raises(ValueError, match=text.replace("(", r"\(").replace(")", r"\)")):
        scale_move(_move(move), standing_height_m=H, **kw)
