"""StepPlanner: the one stateful object of step planning (steering filter, gait clock, weights), ticked ≥ 100 Hz."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planning.steps.gait import Gait, GaitClock, get_gait
from planning.steps.lip import capture_point, project_to_support, state_omega
from planning.steps.potential import PotentialParams, potential_step_paths
from planning.steps.reference import ReferenceParams, map_height, reference_step_path
from planning.steps.select import Selection, SelectionParams, WeightPresets, Weights, select_step_path
from planning.steps.state import SteeringCommand, StepMaps, StepRobot, WalkState
from planning.steps.steering import SteeringFilter, SteeringParams

_FAST_TROT = get_gait("trot_fast")


@dataclass(frozen=True)
class StepPlannerParams:
    """Composed stage parameters. n_candidates: potential paths per replan. walk_gait: gait used to start
    walking from a stand. start_speed_mps: command magnitude (m/s, rad/s) above which a stand starts walking.
    push_margin_m: a standing robot whose capture point leaves its support polygon by more than this (m) starts
    stepping. settle_speed_mps: a stopped robot stepping after a push stands again below this speed (m/s).
    fast_trot_above_mps / fast_trot_below_mps: a trot commanded faster forward than the first switches to
    trot_fast (a longer swing) and back below the second (m/s; the gap keeps it from switching to and fro).
    fast_trot_lateral_above_mps / fast_trot_lateral_below_mps: the same for the sideways speed (m/s, either side):
    trot_fast when either axis asks for it, the trot again once both are below their second thresholds.
    stop_stepping_below_mps: a stop asked faster than this decelerates stepping first (m/s)."""

    steering: SteeringParams = field(default_factory=SteeringParams)
    reference: ReferenceParams = field(default_factory=ReferenceParams)
    potential: PotentialParams = field(default_factory=PotentialParams)
    selection: SelectionParams = field(default_factory=SelectionParams)
    n_candidates: int = 25
    walk_gait: str = "trot"
    start_speed_mps: float = 0.05
    push_margin_m: float = 0.03
    settle_speed_mps: float = 0.1
    fast_trot_above_mps: float = 0.9
    fast_trot_below_mps: float = 0.7
    # sideways, trot_fast from lower speeds: from a stand the trot (0.5 s cycle, duty 0.6: 0.3 s stances that
    # sweep the trailing feet 0.3-0.4 m out past their hips) fell at 1.0 m/s sideways in 11 of 14 starts, at 0.9 in 3,
    # at 0.8 in 2, at 0.7 in 1 (the trailing foot scuffs the floor just after liftoff, the trip response stops it,
    # it lands late and the body rolls over the leading feet); trot_fast held 14 of 14 at 0.7, 0.9, 1.0, 1.1 and 1.2
    # (docs/agility-notes.md, session 11)
    fast_trot_lateral_above_mps: float = 0.6
    fast_trot_lateral_below_mps: float = 0.4
    # a stop asked while the filtered command is faster than this (m/s, forward and sideways) goes on stepping while
    # the steering filter ramps the command down at its deceleration limits, and stands once below it (measured:
    # at 2 m/s a stop that lifts no foot again fell within 0.7 s)
    stop_stepping_below_mps: float = 0.5


def wants_fast_trot(cmd: SteeringCommand, params: StepPlannerParams) -> bool:
    """Returns True when a (limited) command asks the trot for trot_fast: faster than fast_trot_above_mps forward
    or fast_trot_lateral_above_mps sideways (either side)."""
    return cmd.vx > params.fast_trot_above_mps or abs(cmd.vy) > params.fast_trot_lateral_above_mps


def slow_trot_allowed(cmd: SteeringCommand, filtered: SteeringCommand, params: StepPlannerParams) -> bool:
    """Returns True when trot_fast may go back to the trot: the command and the filtered command both below
    fast_trot_below_mps forward and fast_trot_lateral_below_mps sideways."""
    return (
        max(cmd.vx, filtered.vx) < params.fast_trot_below_mps
        and max(abs(cmd.vy), abs(filtered.vy)) < params.fast_trot_lateral_below_mps
    )


class StepPlanner:
    """Turns a steering command and the measured state into a selected step path, every tick.

    State it holds: the filtered command, the gait clock, the current weights, the last selection.
    """

    def __init__(
        self,
        robot: StepRobot,
        params: StepPlannerParams | None = None,
        t0: float = 0.0,
        gait: Gait | str = "stand",
        weights: Weights | str = "default",
    ) -> None:
        self.robot = robot
        self.params = params or StepPlannerParams()
        self.steering = SteeringFilter(self.params.steering)
        self.clock = GaitClock(gait, t0=t0)
        self.weights = weights if isinstance(weights, Weights) else WeightPresets.get(weights)
        self.walk_gait: Gait = get_gait(self.params.walk_gait)
        self.last: Selection | None = None
        self._t_last = t0
        self._stopped = False
        self._stand_when_slow = False  # a stop asked at speed: stand once the command has ramped down

    def set_gait(self, gait: Gait | str) -> None:
        """Switches gait (at the clock's next safe boundary); "stand" stops."""
        g = get_gait(gait)
        if g.is_stand:
            self.stop()
            return
        self.walk_gait = g
        self._stopped = self._stand_when_slow = False
        if g.name == "trot" and not self.clock.gait.is_stand:
            # a trot asked while walking at speed goes straight to trot_fast (through the trot, from a gallop at
            # 1.2 m/s, it fell: the trot's swing limits and cycle for one switch's time at a trot_fast speed)
            if wants_fast_trot(self.steering.command, self.params):
                g = _FAST_TROT
        self.clock.request(g)

    def stop(self) -> None:
        """Comes to a stable stand: feet in the air finish their swing, no new liftoffs; commands are ignored
        until set_gait is called (a push that moves the capture point out of the support still makes it step).
        Asked at speed (above stop_stepping_below_mps), it first steps on while the command ramps down."""
        self._stopped = True
        c = self.steering.command
        if self.clock.gait.is_stand or math.hypot(c.vx, c.vy) < self.params.stop_stepping_below_mps:
            self.clock.request("stand")
        else:  # at speed: the command ramps down while stepping on (tick), then the stand
            self._stand_when_slow = True

    def set_weights(self, weights: Weights | str) -> None:
        """Sets Qp, Qr (a Weights or a preset name); takes effect at the next tick."""
        self.weights = weights if isinstance(weights, Weights) else WeightPresets.get(weights)

    def pushed_out_of_support(self, state: WalkState) -> bool:
        """Returns True when the capture point lies outside the stance feet's support polygon by the margin."""
        if not state.contact.any():
            return False
        z = float(state.p_world_com[2]) - state.ground_z()
        xi = capture_point(
            state.p_world_com, state.v_world_com, z if z > 0.05 else self.robot.standing_height_m
        )
        q = project_to_support(xi[None], state.p_world_feet[None, :, :2], state.contact[None])[0]
        return bool(np.linalg.norm(xi - q) > self.params.push_margin_m)

    def _settled(self, state: WalkState) -> bool:
        """Returns True when the robot barely moves and its capture point is inside its support polygon."""
        slow = float(np.linalg.norm(state.v_world_com[:2])) < self.params.settle_speed_mps
        return slow and state.contact.sum() >= 3 and not self.pushed_out_of_support(state)

    def _trot_for_speed(self, cmd: SteeringCommand, filtered: SteeringCommand) -> None:
        """A trot asked to go faster than fast_trot_above_mps forward (or fast_trot_lateral_above_mps sideways)
        switches to trot_fast; back once below fast_trot_below_mps and fast_trot_lateral_below_mps."""
        p, clock = self.params, self.clock
        if self._stopped or clock.pending is not None or self.walk_gait.name != "trot":
            return
        if clock.gait.name == "trot" and wants_fast_trot(self.steering.limit(cmd, _FAST_TROT), p):
            clock.request(_FAST_TROT)
        elif clock.gait.name == _FAST_TROT.name and slow_trot_allowed(cmd, filtered, p):
            clock.request(self.walk_gait)

    def tick(self, cmd: SteeringCommand, state: WalkState, maps: StepMaps | None = None) -> Selection:
        """Returns the selected step path for this tick (its next touchdowns are the contact schedule)."""
        dt = max(state.t - self._t_last, 0.0)
        self._t_last = state.t
        if self.clock.pending is None:
            if self.clock.gait.is_stand:
                wants_walk = not self._stopped and max(abs(cmd.vx), abs(cmd.vy), abs(cmd.yaw_rate)) > (
                    self.params.start_speed_mps
                )
                if wants_walk or self.pushed_out_of_support(state):
                    self.clock.request(self.walk_gait)
            elif self._stopped and self._settled(state):
                self.clock.request("stand")  # stepping after a push while stopped: stand again once settled
        self.clock.advance(state.t)
        target_gait = self.clock.pending or self.clock.gait
        filtered = self.steering.update(cmd if not self._stopped else SteeringCommand(), dt, target_gait)
        self._trot_for_speed(cmd, filtered)
        if (
            self._stand_when_slow
            and math.hypot(filtered.vx, filtered.vy) < self.params.stop_stepping_below_mps
        ):
            self._stand_when_slow = False
            self.clock.request("stand")
        reference = reference_step_path(
            filtered,
            state,
            self.robot,
            self.clock.gait,
            self.clock,
            state.t,
            ground_height=map_height(maps),
            params=self.params.reference,
        )
        candidates = potential_step_paths(
            reference, state, self.robot, maps, self.params.n_candidates, self.params.potential
        )
        omega = state_omega(state, self.robot.standing_height_m)
        self.last = select_step_path(reference, candidates, state, self.weights, omega, self.params.selection)
        return self.last
