"""Every shipped maneuver loads, validates without failures, and keeps its feet down near the nominal pose."""

from __future__ import annotations

import numpy as np
import pytest

from planning.maneuver import (
    SHIPPED_LIBRARY,
    ManeuverError,
    find_maneuver,
    list_library,
    load_maneuver,
    validate_maneuver,
)

SHIPPED = sorted(SHIPPED_LIBRARY.glob("*.yaml"))


def test_the_four_basics_are_shipped() -> None:
    names = {p.stem for p in SHIPPED}
    assert {"stand", "bow", "look-around", "crouch"} <= names


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_maneuver_is_valid(path, robot) -> None:
    result = validate_maneuver(path, robot)
    assert result.failures == [], [p.located() for p in result.failures]
    assert result.ok
    m = result.maneuver
    assert m is not None and m.name == path.stem
    assert m.title


@pytest.mark.parametrize("name", ["stand", "bow", "look-around", "crouch"])
def test_basic_maneuver_keeps_feet_down_and_ends_at_nominal(name, robot) -> None:
    m = load_maneuver(find_maneuver(name))
    assert 4.0 <= m.duration <= 10.0
    assert not m.events and not m.gaits
    last = m.body[-1]
    assert last.t <= m.duration
    np.testing.assert_allclose(last.position, [0.0, 0.0, robot.standing_height_m], atol=1e-9)
    np.testing.assert_allclose(last.rpy, [0.0, 0.0, 0.0], atol=1e-9)


def test_basic_maneuvers_do_what_their_names_say() -> None:
    bow = load_maneuver(find_maneuver("bow"))
    assert max(k.rpy[1] for k in bow.body) >= 15.0  # nose down
    assert min(k.position[2] for k in bow.body) < 0.52 - 0.03  # and lower
    look = load_maneuver(find_maneuver("look-around"))
    yaws, rolls = [k.rpy[2] for k in look.body], [k.rpy[0] for k in look.body]
    assert max(yaws) >= 15 and min(yaws) <= -15 and max(rolls) >= 8 and min(rolls) <= -8
    crouch = load_maneuver(find_maneuver("crouch"))
    assert 0.52 - min(k.position[2] for k in crouch.body) == pytest.approx(0.12, abs=0.02)


def test_list_library_names_every_file() -> None:
    entries = list_library()
    assert [e.name for e in entries] == sorted(p.stem for p in SHIPPED)
    assert all(e.problems == () and e.duration_s is not None for e in entries)


def test_find_maneuver_refuses_paths_when_asked_and_suggests_names(tmp_path) -> None:
    with pytest.raises(ManeuverError, match="not a maneuver name"):
        find_maneuver("../etc/passwd", allow_paths=False)
    with pytest.raises(ManeuverError, match="did you mean crouch"):
        find_maneuver("crouhc")
    own = tmp_path / "crouch.yaml"
    own.write_text(SHIPPED_LIBRARY.joinpath("crouch.yaml").read_text())
    assert find_maneuver("crouch", [tmp_path, SHIPPED_LIBRARY]) == own  # the first directory wins
