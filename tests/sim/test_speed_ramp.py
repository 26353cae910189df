"""The speed bench's ramp: one run per gait and direction, the command raised in levels until a fall or more
than 10 % tracking error; and its table beside Spot's published figure."""

from __future__ import annotations

import pytest

from benchmarks.speed import DIRECTIONS, Direction, format_speed_table, ramp


def test_levels_cover_the_range_in_steps() -> None:
    assert Direction("x", 0, "m/s", 0.4, 0.2, 1.0).levels() == [0.4, 0.6, 0.8, 1.0]
    assert [d.name for d in DIRECTIONS] == ["forward", "sideways", "turning"]
    with pytest.raises(ValueError, match="measure_s"):
        ramp("trot", DIRECTIONS[0], hold_s=1.0, measure_s=2.0)


@pytest.mark.sim
def test_ramp_holds_a_trot_and_stops_where_it_cannot_follow() -> None:
    # 0.6 m/s is held; 3 m/s (beyond the steering limits, lifted for the bench) is not
    r = ramp("trot", DIRECTIONS[0], hold_s=2.0, measure_s=1.0, levels=[0.6, 3.0])
    assert r.top == 0.6
    assert r.stopped_by in ("fall", "tracking") and r.at == 3.0
    ((cmd, mean),) = r.levels
    assert abs(mean - cmd) <= 0.1 * cmd
    # a trot (duty 0.6 at 0.6 m/s) always has a foot down
    assert r.flight == [0.0] and r.as_dict()["flight_fraction"] == [0.0]


def test_table_puts_spot_beside_the_top_speeds() -> None:
    row = {"top": 1.2, "unit": "m/s", "stopped_by": "fall", "at": 1.4, "mean_at_stop": None, "levels": []}
    side = {**row, "top": 0.5, "stopped_by": "tracking", "at": 0.6, "mean_at_stop": 0.5}
    table = format_speed_table(
        {"by_gait": {"trot": {"forward": row, "sideways": side}}, "spot_published": {"forward": 1.6}}
    )
    assert "| trot | 1.2 (1.4 falls) | 0.5 (0.6 tracks > 10 % off) |" in table
    assert "| Spot (published) | 1.6 | – |" in table
    # the fraction of time in flight at each gait's top forward speed, when the ramp measured it
    table = format_speed_table(
        {
            "by_gait": {
                "bound": {"forward": {**row, "flight_fraction": [0.0, 0.031]}},
                "trot": {"forward": row},
            },
            "spot_published": {"forward": 1.6},
        }
    )
    assert "| gait | forward (m/s) | flight at top forward (% of time) |" in table
    assert "| bound | 1.2 (1.4 falls) | 3.1 |" in table and "| trot | 1.2 (1.4 falls) | – |" in table
