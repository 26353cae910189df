"""StepPlanner: the replanning loop on an idealized robot that follows its plan (no physics)."""

from __future__ import annotations

import numpy as np
from _steps_common import robot

from planning.steps import SteeringCommand, StepPlanner, WalkState, WeightPresets, standing_state
from planning.steps.planner import StepPlannerParams, slow_trot_allowed, wants_fast_trot

DT = 0.01  # s, 100 Hz replanning


class _Kinematic:
    """A robot whose body moves at the filtered command and whose feet land where the planner says."""

    def __init__(self) -> None:
        self.state = standing_state(robot())
        self.feet = self.state.p_world_feet.copy()
        self.targets = self.feet.copy()

    def step(self, planner: StepPlanner, v_extra=(0.0, 0.0)) -> WalkState:
        s = self.state
        t = s.t + DT
        contact = planner.clock.contact(t)
        landed = contact & ~s.contact
        self.feet[landed] = self.targets[landed]
        cmd = planner.steering.command
        yaw = s.yaw + cmd.yaw_rate * DT
        c, sn = np.cos(yaw), np.sin(yaw)
        v = np.array([c * cmd.vx - sn * cmd.vy + v_extra[0], sn * cmd.vx + c * cmd.vy + v_extra[1], 0.0])
        self.state = WalkState(s.p_world_com + v * DT, v, yaw, cmd.yaw_rate, self.feet, contact, t)
        return self.state

    def tick(self, planner: StepPlanner, cmd: SteeringCommand, **kw) -> None:
        state = self.step(planner, **kw)
        sel = planner.tick(cmd, state)
        _, p = sel.path.next_touchdowns()
        ok = np.isfinite(p[:, 0]) & ~state.contact
        self.targets[ok] = p[ok]


def test_walks_forward_following_the_command_and_switches_gait() -> None:
    planner = StepPlanner(robot(), gait="stand")
    sim = _Kinematic()
    for _ in range(200):
        sim.tick(planner, SteeringCommand(0.5, 0.0, 0.0))
    assert planner.clock.gait.name == "trot"  # a command starts the walking gait
    sel = planner.last
    assert sel is not None and sel.path.n_touchdowns == 8
    t_next, _ = sel.path.next_touchdowns()
    assert np.all(t_next > sim.state.t)
    x = sim.state.p_world_com[0]
    assert 0.5 < x < 1.0  # accelerating to 0.5 m/s over 2 s
    # Feet kept up with the body: each within its reach of the nominal stance around the body.
    rel = sim.feet[:, :2] - sim.state.p_world_com[:2] - robot().nominal_foot_body[:, :2]
    assert np.all(np.abs(rel[:, 0]) < 0.35) and np.all(np.abs(rel[:, 1]) < 0.1)
    planner.set_gait("walk")
    for _ in range(150):
        sim.tick(planner, SteeringCommand(0.3, 0.0, 0.0))
    assert planner.clock.gait.name == "walk" and planner.last is not None
    planner.set_weights("stable_body")
    sim.tick(planner, SteeringCommand(0.3, 0.0, 0.0))
    assert planner.weights == WeightPresets.STABLE_BODY


def test_stop_comes_to_a_stand_and_a_push_makes_it_step() -> None:
    planner = StepPlanner(robot(), gait="trot")
    sim = _Kinematic()
    for _ in range(100):
        sim.tick(planner, SteeringCommand(0.4, 0.0, 0.0))
    planner.stop()
    for _ in range(150):
        sim.tick(planner, SteeringCommand(0.4, 0.0, 0.0))  # ignored after stop
    assert planner.clock.gait.is_stand and sim.state.contact.all()
    assert planner.last is not None and planner.last.path.n_touchdowns == 0
    assert planner.steering.command.is_zero
    # A shove sideways while standing: the capture point leaves the support polygon, so it steps.
    sim.tick(planner, SteeringCommand(), v_extra=(0.0, 1.2))
    assert planner.clock.gait.name == "trot" and planner.last.path.n_touchdowns > 0
    for _ in range(100):  # the shove is over: once settled, it stands again
        sim.tick(planner, SteeringCommand())
    assert planner.clock.gait.is_stand


def test_stop_at_speed_steps_on_while_the_command_ramps_down() -> None:
    planner = StepPlanner(robot(), gait="trot")
    sim = _Kinematic()
    for _ in range(200):
        sim.tick(planner, SteeringCommand(1.5, 0.0, 0.0))
    assert planner.steering.command.vx > planner.params.stop_stepping_below_mps
    planner.stop()
    sim.tick(planner, SteeringCommand(1.5, 0.0, 0.0))  # ignored after stop
    assert not planner.clock.gait.is_stand and planner.clock.pending is None  # still stepping
    assert planner.steering.command.vx < 1.5
    for _ in range(150):
        sim.tick(planner, SteeringCommand(1.5, 0.0, 0.0))
    assert planner.clock.gait.is_stand and abs(planner.steering.command.vx) < 0.05


def test_fast_trot_thresholds_forward_and_sideways() -> None:
    p = StepPlannerParams()
    assert p.fast_trot_lateral_below_mps < p.fast_trot_lateral_above_mps
    lat = p.fast_trot_lateral_above_mps
    assert not wants_fast_trot(SteeringCommand(0.5 * p.fast_trot_above_mps, 0.9 * lat, 0.0), p)
    assert wants_fast_trot(SteeringCommand(p.fast_trot_above_mps + 0.1, 0.0, 0.0), p)
    for side in (1.0, -1.0):  # sideways, either side, with or without a little forward speed
        assert wants_fast_trot(SteeringCommand(0.0, side * (lat + 0.05), 0.0), p)
        assert wants_fast_trot(SteeringCommand(0.2, side * (lat + 0.05), 0.2), p)
    slow = SteeringCommand(0.0, 0.5 * p.fast_trot_lateral_below_mps, 0.0)
    assert slow_trot_allowed(slow, slow, p)
    # back to the trot only once both axes, commanded and filtered, are below their lower thresholds
    between = SteeringCommand(0.0, 0.5 * (p.fast_trot_lateral_below_mps + lat), 0.0)
    assert not slow_trot_allowed(slow, between, p) and not slow_trot_allowed(between, slow, p)
    fwd = SteeringCommand(p.fast_trot_below_mps + 0.05, 0.0, 0.0)
    assert not slow_trot_allowed(fwd, slow, p)


def test_a_trot_asked_fast_sideways_walks_trot_fast_and_back() -> None:
    planner = StepPlanner(robot(), gait="stand")
    sim = _Kinematic()
    for _ in range(150):
        sim.tick(planner, SteeringCommand(0.0, -1.0, 0.0))
    assert planner.clock.gait.name == "trot_fast"
    assert abs(planner.steering.command.vy + 1.0) < 0.05  # the trots' own sideways limit is 1.0 m/s
    for _ in range(200):
        sim.tick(planner, SteeringCommand(0.0, 0.2, 0.0))
    assert planner.clock.gait.name == "trot"
