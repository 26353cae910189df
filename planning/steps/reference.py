"""Reference step path: where and when each foot should land, from the command, the state and the robot.

Nominal foothold of a touchdown = the leg's neutral point (its nominal stance foot, body frame) at mid-stance on
the body motion the command predicts (which is the Raibert term v·T_stance/2 ahead of the touchdown-time neutral
point, and turns with the yaw rate), plus a capture-point feedback term k·(v - v_cmd)/ω that steps the foot after
a velocity error (k decays for each later touchdown of the same leg). The reference ignores the robot's limits;
the potential paths and their screening deal with those.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import numpy as np

from planning.steps.gait import Gait, GaitClock
from planning.steps.lip import state_omega
from planning.steps.state import F64, N_LEGS, BodyMotion, SteeringCommand, StepPath, StepRobot, WalkState

GroundHeight = Callable[[F64, F64], object]


@dataclass(frozen=True)
class ReferenceParams:
    """n_cycles: gait cycles planned ahead (touchdowns per leg). capture_gain: -, gain of the capture-point
    feedback term on a leg's first touchdown. capture_decay: -, factor on that gain per later touchdown.
    centripetal_gain: -, footholds outward of a turn by this times the centripetal acceleration / ω²."""

    n_cycles: int = 2
    capture_gain: float = 1.0
    capture_decay: float = 0.5
    # turning while moving: each foothold moves outward of the arc by this times a/ω² (a = yaw rate × speed, the
    # centripetal acceleration; ω² = g/h the pendulum's), so the body leans into the turn; without it a trot on a
    # 1 m radius at 1.5 m/s slid out of the circle and fell
    centripetal_gain: float = 1.0
    # the bound's footholds behind their neutral points by this times the commanded velocity (s): its pairs push
    # one at a time, so the pitch moment of the forward push (body height × force) has to be balanced by the
    # weight carried behind the center of mass; at the neutral points the balance QP held the pitch and gave up the
    # push, and the speed bench's bound stopped at 1.6 m/s (1.8 tracked 12 % slow); 0.08 s: 2.4 m/s (0.05: 2.2,
    # 0.11: 2.0). The gallop, whose three-foot phases balance the push, tracked no better with it (fell at 2.2 m/s
    # with 0.05 s).
    thrust_lead_s: tuple[tuple[str, float], ...] = (("bound", 0.08),)

    def __post_init__(self) -> None:
        if self.n_cycles < 1:
            raise ValueError(f"ReferenceParams.n_cycles: must be >= 1, got {self.n_cycles}")


def eval_map(fn: GroundHeight, x: F64, y: F64) -> F64:
    """Returns fn evaluated on arrays x, y (same shape): one vectorized call, else one call per point."""
    try:
        z = np.asarray(fn(x, y), dtype=np.float64)
        if z.shape == x.shape:
            return z
    except (TypeError, ValueError):
        pass
    one = cast(Callable[[float, float], float], fn)
    return np.array(
        [float(one(float(a), float(b))) for a, b in zip(x.ravel(), y.ravel(), strict=True)]
    ).reshape(x.shape)


def map_height(maps: object | None) -> GroundHeight | None:
    """Returns the height lookup of a maps object: its ``height_at`` (TerrainMaps), else a callable
    ``ground_height``, else None."""
    for name in ("height_at", "ground_height"):
        fn = getattr(maps, name, None)
        if callable(fn):
            return cast(GroundHeight, fn)
    return None


def body_motion(cmd: SteeringCommand, state: WalkState, t_now: float) -> BodyMotion:
    """Returns the body motion the command predicts from the state's CoM position and heading."""
    return BodyMotion(
        p0_world=state.p_world_com[:2].copy(),
        yaw0=state.yaw,
        v_heading=np.array([cmd.vx, cmd.vy]),
        yaw_rate=cmd.yaw_rate,
        t0=t_now,
    )


def touchdown_rank(leg: np.ndarray) -> np.ndarray:
    """Returns, per touchdown (K,), how many earlier touchdowns of the same leg the path has (0 = first)."""
    rank = np.zeros(leg.shape[0], dtype=np.int64)
    seen = np.zeros(N_LEGS, dtype=np.int64)
    for i, lg in enumerate(leg):
        rank[i] = seen[lg]
        seen[lg] += 1
    return rank


def reference_step_path(
    cmd: SteeringCommand,
    state: WalkState,
    robot: StepRobot,
    gait: Gait,
    clock: GaitClock,
    t_now: float,
    ground_height: GroundHeight | None = None,
    params: ReferenceParams | None = None,
) -> StepPath:
    """Returns the reference step path for the next ``params.n_cycles`` gait cycles (ignoring robot limits).

    Touchdown timing comes from the clock (which may be switching gaits); ``gait`` gives the stance time assumed
    for a liftoff beyond the planning window. Heights come from ground_height(x, y) (world m) when terrain is
    known, else from the stance feet.
    """
    p = params or ReferenceParams()
    sched = clock.schedule(t_now, p.n_cycles)
    body = body_motion(cmd, state, t_now)
    omega = state_omega(state, robot.standing_height_m)
    leg = sched.leg
    t_stance = np.where(np.isfinite(sched.t_liftoff), sched.t_liftoff - sched.t_touchdown, gait.stance_s)
    neutral = np.asarray(robot.nominal_foot_body, dtype=np.float64)[:, :2]
    xy = body.neutral_points(sched.t_touchdown + 0.5 * t_stance, neutral, leg)
    v_err = state.v_world_com[:2] - body.velocity_world(t_now)
    gain = p.capture_gain * p.capture_decay ** touchdown_rank(leg)
    xy = xy + gain[:, None] * (v_err / omega)[None, :]
    lead = dict(p.thrust_lead_s).get(clock.gait.name, 0.0)
    if lead != 0.0:
        xy = xy - lead * body.velocity_world(t_now)[None, :]
    if cmd.yaw_rate != 0.0 and p.centripetal_gain != 0.0 and leg.shape[0]:
        v_td = body.velocity_world(sched.t_touchdown + 0.5 * t_stance)  # (K, 2)
        a_in = cmd.yaw_rate * np.column_stack([-v_td[:, 1], v_td[:, 0]])  # ω × v, toward the turn's center
        xy = xy - p.centripetal_gain * a_in / (omega * omega)
    if ground_height is not None and leg.shape[0]:
        z = eval_map(ground_height, xy[:, 0], xy[:, 1])
    else:
        z = np.full(leg.shape[0], state.ground_z())
    # The measured contact wins over the plan: a foot still down that the plan has in the air lifts off now; a
    # foot in the air has no liftoff to come before its next touchdown.
    t_lo_now = np.where(
        state.contact, np.where(np.isnan(sched.t_liftoff_now), t_now, sched.t_liftoff_now), np.nan
    )
    return StepPath(
        leg=leg,
        t_touchdown=sched.t_touchdown,
        t_liftoff=sched.t_liftoff,
        p_world_touchdown=np.column_stack([xy, z]) if leg.shape[0] else np.zeros((0, 3)),
        t_liftoff_now=t_lo_now,
        body=body,
        kind="reference",
        gait=clock.gait.name,
    )
