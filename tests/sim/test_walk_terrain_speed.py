"""Speed on terrain: a terrain walk's speed limit (WalkCommand.terrain_speed_mps, `footfall walk --speed`, REST
walk `terrain_speed`) raised to the terrain's measured limit, walked closed loop in MuJoCo with the depth sensor."""

from __future__ import annotations

import pytest

from planning.sim.run import (
    TERRAIN_SPEED_DEFAULT_MPS,
    RunOptions,
    WalkCommand,
    check_terrain_speed,
    run_walk,
    terrain_speed_limit,
)


def test_terrain_speed_limits_are_named_per_terrain() -> None:
    """Slope and rough allow 1.0 m/s (measured held); every other terrain, and a user's, keeps the default."""
    assert terrain_speed_limit("slope") == terrain_speed_limit("rough") == 1.0
    assert terrain_speed_limit("stairs") == terrain_speed_limit("my-room") == TERRAIN_SPEED_DEFAULT_MPS
    assert check_terrain_speed(1.0, "slope") is None
    why = check_terrain_speed(1.0, "stairs")
    assert why is not None and "stairs" in why and "0.5" in why
    assert check_terrain_speed(0.1, "slope") is not None


def test_a_walk_asking_beyond_its_terrains_limit_is_refused() -> None:
    with pytest.raises(ValueError, match="terrain_speed_mps: 0.8 m/s is outside"):
        run_walk(WalkCommand(vx=0.8, terrain_speed_mps=0.8), RunOptions(terrain="stones", duration_s=0.1))


def test_slope_steered_at_1_mps_with_the_sensor() -> None:
    """Steered at 1.0 m/s up the slope with the depth sensor and the terrain speed at its 1.0 m/s limit: the mean
    speed (after the 1.5 s settling) within 10 % of the command, no fall, across the slope (measured with the terrain
    pipeline: 0.99 m/s on the trot, crossed at 5.94 s, 2026-11-27; before its free_rise_m and fast stride, 0.50 m/s on
    `climb`)."""
    r = run_walk(
        WalkCommand(vx=1.0, terrain_speed_mps=1.0, terrain_sensor=True),
        RunOptions(terrain="slope", duration_s=6.2),
    )
    assert not r["fell"], r["failure_reason"]
    assert r["command"]["terrain_speed_mps"] == 1.0
    assert r["mean_velocity"]["vx"] == pytest.approx(1.0, rel=0.10)
    assert r["crossed"], r["time_to_cross_s"]


def test_a_live_studio_walk_takes_the_terrain_speed_limit() -> None:
    """A live session (the studio's, REST's /sessions) walks a terrain at up to its TERRAIN_SPEED_LIMITS_MPS, like
    the CLI's --speed: on the slope the pipeline's cap is 1.0 m/s; on the stairs it stays at the default. What the
    slope walk reaches under that cap is the test above."""
    from server.engine import LiveSim, walk_command

    stairs = LiveSim(walk_command(vx=1.0), "stairs")
    assert stairs.session.pipeline.params.decision.max_speed_mps == TERRAIN_SPEED_DEFAULT_MPS
    sim = LiveSim(walk_command(vx=1.0), "slope")
    assert sim.session.pipeline.params.decision.max_speed_mps == terrain_speed_limit("slope") == 1.0
    for _ in range(int(1.0 / sim.dt)):
        sim.step()
    assert not sim.fell, sim.failure_reason
