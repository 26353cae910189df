"""Near misses: a non-foot part of the robot within 2 cm of the terrain, not touching it (NearMissMonitor)."""

from __future__ import annotations

import pytest

from planning.robot import load_robot
from planning.sim.world import RobotState, World
from planning.terrain.crossing import NEAR_MISS_EVERY, NEAR_MISS_M, NearMissMonitor
from planning.terrain.scenes import build_terrain


def _at(world: World, monitor: NearMissMonitor, gap_m: float, box_x: float) -> None:
    """Places the robot so that its trunk's front face is gap_m from the box's near face, and lets the monitor
    measure once."""
    world.reset()
    half = float(world.model.geom_size[world.model.geom("trunk_geom").id][0])
    world.place(box_x - half - gap_m, 0.0, 0.0)
    for _ in range(NEAR_MISS_EVERY):
        monitor(world.read_state(RobotState()))


def test_an_approach_is_counted_once_and_a_touch_is_no_near_miss() -> None:
    scene = build_terrain("clutter", n_low=0, platform=False)  # a tall box across the straight line
    box_x = scene.obstacle_boxes[0][0]
    world = World(load_robot("spot"), scene)
    nm = NearMissMonitor(world)
    _at(world, nm, 0.10, box_x)
    assert nm.near_misses == 0 and nm.least_m == float("inf")  # 10 cm away: not watched
    _at(world, nm, 0.012, box_x)
    assert nm.near_misses == 1
    assert nm.least_m == pytest.approx(0.012, abs=2e-3)  # MuJoCo's own distance, box to box
    _at(world, nm, 0.008, box_x)
    assert nm.near_misses == 1  # the same approach, closer
    assert nm.least_m == pytest.approx(0.008, abs=2e-3)
    _at(world, nm, 0.05, box_x)  # away beyond the clearing distance ...
    _at(world, nm, 0.015, box_x)  # ... and back: a second near miss
    assert nm.near_misses == 2
    _at(world, nm, 0.05, box_x)  # away: the second approach was a near miss too
    nm.finish(fell=False)
    assert nm.near_misses == 2 and len(nm.events) == 2
    _at(world, nm, 0.015, box_x)  # a third approach ...
    _at(world, nm, -0.01, box_x)  # ... ends touching: a fall, which ends the run
    assert nm.least_m == pytest.approx(0.008, abs=2e-3)  # (a touch is no clearance)
    nm.finish(fell=True)
    assert nm.near_misses == 2 and len(nm.events) == 2  # the approach that touched is no near miss
    assert all(name == "trunk_geom" and d < NEAR_MISS_M for _, name, d in nm.events)


def test_an_approach_open_when_a_walk_falls_elsewhere_is_dropped_with_the_fall() -> None:
    scene = build_terrain("clutter", n_low=0, platform=False)
    world = World(load_robot("spot"), scene)
    nm = NearMissMonitor(world)
    _at(world, nm, 0.01, scene.obstacle_boxes[0][0])
    assert nm.near_misses == 1
    nm.finish(fell=True)
    assert nm.near_misses == 0 and nm.events == []
