"""Gait cadence: overlay candidate cadences on the body path and the step-obstacle map, score them, pick one.

A cadence is a touchdown order (groups of legs that touch down together), a step period (time between successive
groups), a swing duration and a body speed. Overlaid on the body path, it gives nominal footholds: each foot lands
under its hip at the middle of its coming stance (the body pose then, plus the nominal foot offset). Each nominal
foothold on a no-step cell is a collision whose severity is how far the foot must move to leave it (the step SDF's
depth plus the margin). Score (lower is better):

    w_count · collisions + w_severity · Σ severity² + w_speed · (1 - speed / fastest speed)

so slight collisions with several obstacles may beat a deep one, and, all else equal, faster cadences win.

The gait table (legs FL, FR, RL, RR = 0..3):

    name     order                      step period s   swing s   speed m/s
    slow     RL · FL · RR · FR (walk)   0.30            0.25      0.30
    medium   FL+RR · FR+RL (trot)       0.32            0.30      0.55
    fast     FL+RR · FR+RL (trot)       0.25            0.23      0.85
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from planning.terrain.bodypath import BodyPath
from planning.terrain.maps import TerrainMaps
from planning.terrain.stepqp import StepRequest

FL, FR, RL, RR = 0, 1, 2, 3


@dataclass(frozen=True)
class Cadence:
    """One cadence. groups: touchdown order, legs landing together; step_period_s: time between groups (s);
    swing_s: swing duration (s); speed_mps: body speed along the path (m/s)."""

    name: str
    groups: tuple[tuple[int, ...], ...]
    step_period_s: float
    swing_s: float
    speed_mps: float

    @property
    def cycle_s(self) -> float:
        return self.step_period_s * len(self.groups)

    @property
    def stance_s(self) -> float:
        return self.cycle_s - self.swing_s

    def slots(self, n: int, first_group: int = 0) -> list[tuple[int, int]]:
        """Gives n (group index, leg) touchdown slots from `first_group`, in touchdown order."""
        out: list[tuple[int, int]] = []
        g = 0
        while len(out) < n:
            group = self.groups[(first_group + g) % len(self.groups)]
            for leg in group:
                out.append((g, leg))
            g += 1
        return out[:n]


CADENCES: tuple[Cadence, ...] = (
    Cadence("slow", ((RL,), (FL,), (RR,), (FR,)), 0.30, 0.25, 0.30),
    Cadence("medium", ((FL, RR), (FR, RL)), 0.32, 0.30, 0.55),
    Cadence("fast", ((FL, RR), (FR, RL)), 0.25, 0.23, 0.85),
)


def _default_feet() -> tuple[tuple[float, float], ...]:
    return ((0.30, 0.165), (0.30, -0.165), (-0.30, 0.165), (-0.30, -0.165))


def _default_hips() -> tuple[tuple[float, float], ...]:
    return ((0.30, 0.055), (0.30, -0.055), (-0.30, 0.055), (-0.30, -0.055))


@dataclass(frozen=True)
class CadenceParams:
    """Cadence choice. cadences: candidates; w_count, w_severity (1/m²), w_speed: score weights; margin_m: keep-out
    margin counted in the severity (m); horizon_m: how much of the path is overlaid (m); feet_body_xy: nominal
    foot xy in the body frame per leg (m); hips_body_xy: hip xy in the body frame per leg (m); hip_height_m: hip
    above the ground (m)."""

    cadences: tuple[Cadence, ...] = CADENCES
    w_count: float = 1.0
    w_severity: float = 200.0
    w_speed: float = 1.0
    margin_m: float = 0.03
    horizon_m: float = 3.0
    feet_body_xy: tuple[tuple[float, float], ...] = field(default_factory=_default_feet)
    hips_body_xy: tuple[tuple[float, float], ...] = field(default_factory=_default_hips)
    hip_height_m: float = 0.52

    @staticmethod
    def from_robot(robot: object, **overrides: object) -> CadenceParams:
        """Gives params with the robot's nominal feet, hips and standing height (a planning.robot RobotModel)."""
        feet = np.asarray(robot.nominal_foot_body)[:, :2]  # type: ignore[attr-defined]
        hips = np.asarray(robot.p_body_hip)[:, :2]  # type: ignore[attr-defined]
        kw: dict[str, object] = {
            "feet_body_xy": tuple(map(tuple, feet.tolist())),
            "hips_body_xy": tuple(map(tuple, hips.tolist())),
            "hip_height_m": float(robot.standing_height_m),  # type: ignore[attr-defined]
        }
        kw.update(overrides)
        return CadenceParams(**kw)  # type: ignore[arg-type]


@dataclass(frozen=True, eq=False)
class CadenceScore:
    """One cadence overlaid. footholds: (N, 2) nominal footholds (m); legs: (N,); severity: (N,) how far each must
    move (m, 0 when clear); collisions: count; score: lower is better."""

    cadence: Cadence
    footholds: NDArray[np.float64]
    legs: NDArray[np.intp]
    severity: NDArray[np.float64]
    collisions: int
    score: float


def overlay(
    cadence: Cadence, path: BodyPath, params: CadenceParams, s0_m: float = 0.0
) -> tuple[NDArray, NDArray]:
    """Gives the nominal footholds (N, 2) and legs (N,) of a cadence walked along the path from arc length s0_m."""
    length = min(path.length_m - s0_m, params.horizon_m)
    duration = max(length, 0.0) / cadence.speed_mps
    n_groups = int(np.ceil(duration / cadence.step_period_s)) + len(cadence.groups)
    feet = np.asarray(params.feet_body_xy)
    out_p: list[NDArray[np.float64]] = []
    out_l: list[int] = []
    for g in range(n_groups):
        t_td = (g + 1) * cadence.step_period_s
        t_mid = t_td + 0.5 * cadence.stance_s
        s = s0_m + min(cadence.speed_mps * t_mid, max(length, 0.0))
        xy, yaw = path.pose_at(s)
        c, sn = np.cos(yaw), np.sin(yaw)
        for leg in cadence.groups[g % len(cadence.groups)]:
            fx, fy = feet[leg]
            out_p.append(np.array([xy[0] + c * fx - sn * fy, xy[1] + sn * fx + c * fy]))
            out_l.append(leg)
    return np.array(out_p).reshape(-1, 2), np.array(out_l, dtype=np.intp)


def score_cadence(cadence: Cadence, path: BodyPath, maps: TerrainMaps | None, params: CadenceParams,
                  s0_m: float = 0.0) -> CadenceScore:  # fmt: skip
    """Gives the overlay of one cadence with its collisions and score."""
    p_nom, legs = overlay(cadence, path, params, s0_m)
    if maps is None or p_nom.shape[0] == 0:
        sev = np.zeros(p_nom.shape[0])
    else:
        sd = np.asarray(maps.sdf_step(p_nom[:, 0], p_nom[:, 1]), dtype=np.float64).reshape(-1)
        inside = np.asarray(maps.in_map(p_nom[:, 0], p_nom[:, 1]), dtype=bool).reshape(-1)
        sev = np.where(inside & np.isfinite(sd), np.maximum(params.margin_m - sd, 0.0), 0.0)
    fastest = max(c.speed_mps for c in params.cadences)
    hits = sev > params.margin_m  # inside a no-step cell (the margin alone is not a collision)
    score = (
        params.w_count * float(hits.sum())
        + params.w_severity * float(np.sum(sev**2))
        + params.w_speed * (1.0 - cadence.speed_mps / fastest)
    )
    return CadenceScore(cadence, p_nom, legs, sev, int(hits.sum()), score)


def choose_cadence(path: BodyPath, maps: TerrainMaps | None, params: CadenceParams | None = None,
                   s0_m: float = 0.0) -> tuple[CadenceScore, list[CadenceScore]]:  # fmt: skip
    """Gives the best-scoring cadence and all the scores, in params.cadences order."""
    p = params or CadenceParams()
    if not p.cadences:
        raise ValueError("CadenceParams.cadences: at least one cadence is needed")
    scores = [score_cadence(c, path, maps, p, s0_m) for c in p.cadences]
    best = min(scores, key=lambda sc: sc.score)
    return best, scores


def make_request(
    cadence: Cadence,
    path: BodyPath,
    params: CadenceParams,
    n_slots: int,
    p_feet: NDArray[np.float64],
    v_feet: NDArray[np.float64] | None = None,
    s_now_m: float = 0.0,
    phase_s: float = 0.0,
    first_group: int = 0,
) -> StepRequest:
    """Gives the step QP's request for the next n_slots touchdowns of `cadence` along `path`.

    p_feet: (4, 2) feet now (m, world); v_feet: (4, 2) their velocities (m/s); s_now_m: the body's arc length on the
    path now (m); phase_s: time since the last touchdown (s), so the next group lands in step_period_s - phase_s;
    first_group: index (in cadence.groups) of the next group to land.
    """
    feet = np.asarray(params.feet_body_xy)
    hips = np.asarray(params.hips_body_xy)
    slots = cadence.slots(n_slots, first_group)
    legs = np.array([leg for _, leg in slots], dtype=np.intp)
    t_td = np.array([(g + 1) * cadence.step_period_s - phase_s for g, _ in slots])
    t_lo = t_td - cadence.swing_s
    t_mid_stance = t_td + 0.5 * cadence.stance_s

    def pose(t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return path.pose_at(s_now_m + cadence.speed_mps * np.maximum(t, 0.0))

    xy_m, yaw_m = pose(t_mid_stance)
    c, s = np.cos(yaw_m), np.sin(yaw_m)
    f = feet[legs]
    p_nom = np.stack([xy_m[:, 0] + c * f[:, 0] - s * f[:, 1], xy_m[:, 1] + s * f[:, 0] + c * f[:, 1]], axis=1)
    xy_td, yaw_td = pose(t_td)
    c, s = np.cos(yaw_td), np.sin(yaw_td)
    h = hips[legs]
    p_hip = np.stack(
        [xy_td[:, 0] + c * h[:, 0] - s * h[:, 1], xy_td[:, 1] + s * h[:, 0] + c * h[:, 1]], axis=1
    )
    # The body point of each support phase: the middle of the time to the next distinct touchdown.
    t_next = np.array(
        [t_td[t_td > t + 1e-6].min() if np.any(t_td > t + 1e-6) else t + cadence.step_period_s for t in t_td]
    )
    xy_c, yaw_c = pose(0.5 * (t_td + t_next))
    return StepRequest(
        legs=legs,
        t_liftoff=t_lo,
        t_touchdown=t_td,
        p_nominal=p_nom,
        p_hip=p_hip,
        hip_height=np.full(n_slots, params.hip_height_m),
        c_body=xy_c,
        yaw_body=yaw_c,
        p_feet=np.asarray(p_feet, dtype=np.float64).reshape(4, 2),
        v_feet=np.zeros((4, 2)) if v_feet is None else np.asarray(v_feet, dtype=np.float64).reshape(4, 2),
    )
