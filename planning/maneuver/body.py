"""The body reference of a maneuver: a C1 curve through its keyframes (or over its feet when it has none).

Between knots each coordinate of [x, y, z, roll, pitch, yaw] is a cubic Hermite segment with shape-preserving
(Fritsch–Butland) slopes: it passes through every keyframe, never overshoots one (a crouch to 0.40 m does not dip
below 0.40 m), and rests at the first knot, the last knot and at every turning point. Angles are interpolated as
roll/pitch/yaw (R = Rz(yaw) Ry(pitch) Rx(roll)); yaw is not wrapped, so a keyframe at 360° is a full turn.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from planning.geometry import rpy_rates_to_omega, rpy_to_R
from planning.maneuver.expand import Schedule, build_schedule, start_feet, support_frame
from planning.maneuver.problems import ManeuverError, Problem
from planning.maneuver.spec import Maneuver

if TYPE_CHECKING:
    from planning.robot import RobotModel

MIN_KNOT_GAP_S = 1e-6  # closer knots would make the slopes blow up, s


def _slopes(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Returns knot slopes (K,D): weighted harmonic mean of the neighboring secants, 0 at ends and extrema."""
    m = np.zeros_like(y)
    if len(t) < 3:
        return m
    h = np.diff(t)[:, None]  # (K-1,1)
    d = np.diff(y, axis=0) / h  # (K-1,D) secants
    h0, h1, d0, d1 = h[:-1], h[1:], d[:-1], d[1:]
    w0, w1 = 2.0 * h1 + h0, h1 + 2.0 * h0
    same = d0 * d1 > 0.0
    den = w0 * d1 + w1 * d0  # same sign as the secants where they agree, so never 0 there
    m[1:-1] = np.where(same, (w0 + w1) * d0 * d1 / np.where(same, den, 1.0), 0.0)
    return m


# one rotation convention for the whole project: planning.geometry (re-exported here under the names this module
# has always offered)
omega_world_from_rpy = rpy_rates_to_omega
rotation_from_rpy = rpy_to_R


class BodyReference:
    """The body pose the maneuver asks for over time: p_world_body (m) and rpy (rad), with rates and a weight."""

    def __init__(
        self,
        t_knot: np.ndarray,
        pose_knot: np.ndarray,
        weight_knot: np.ndarray,
        *,
        from_keyframes: bool = True,
    ) -> None:
        """t_knot (K,) strictly increasing s; pose_knot (K,6) [x, y, z, roll, pitch, yaw] m and rad; weight (K,)."""
        t = np.asarray(t_knot, dtype=float).reshape(-1)
        pose = np.asarray(pose_knot, dtype=float).reshape(len(t), 6)
        if len(t) == 0 or np.any(np.diff(t) < MIN_KNOT_GAP_S):
            raise ValueError(
                f"body reference knots must be increasing in time, at least {MIN_KNOT_GAP_S} s apart"
            )
        self.t_knot = t
        self.pose_knot = pose
        self.weight_knot = np.asarray(weight_knot, dtype=float).reshape(len(t))
        self.slope_knot = _slopes(t, pose)
        self.from_keyframes = from_keyframes

    @classmethod
    def from_maneuver(
        cls, maneuver: Maneuver, robot: RobotModel, schedule: Schedule | None = None
    ) -> BodyReference:
        """Returns the reference of a maneuver: its keyframes after the start pose, or the support of its feet.

        The start pose is [0, 0, standing height] level at t = 0 (replaced by a keyframe at t = 0). Without
        keyframes the body follows the center of where the feet are or are about to land (sampled at each
        liftoff and at the last touchdown), at standing height above their mean height, facing their heading.
        """
        h = float(robot.standing_height_m)
        start = np.array([0.0, 0.0, h, 0.0, 0.0, 0.0])
        if maneuver.body:
            w0 = maneuver.body[0].weight
            ts, poses, ws = [0.0], [start], [w0]
            for i, k in enumerate(maneuver.body):
                pose = np.array([*k.position, *np.radians(k.rpy)])
                if k.t < MIN_KNOT_GAP_S and len(ts) == 1:
                    ts[0], poses[0], ws[0] = 0.0, pose, k.weight
                    continue
                if k.t < ts[-1] + MIN_KNOT_GAP_S:
                    raise ManeuverError(
                        [
                            Problem(
                                f"body[{i}].t",
                                f"keyframe at {k.t:g} s does not come after the previous one at {ts[-1]:g} s "
                                f"(by at least {MIN_KNOT_GAP_S:g} s)",
                            )
                        ]
                    )
                ts.append(k.t)
                poses.append(pose)
                ws.append(k.weight)
            return cls(np.array(ts), np.array(poses), np.array(ws), from_keyframes=True)
        sched = schedule if schedule is not None else build_schedule(maneuver, robot)
        nominal_xy = start_feet(robot)[:, :2]
        times = sorted({s.t_liftoff for sw in sched.swings for s in sw})
        last_td = max((s.t_touchdown for sw in sched.swings for s in sw), default=0.0)
        ts, poses = [0.0], [start]
        for t in [*times, last_td]:
            if t < ts[-1] + MIN_KNOT_GAP_S:
                continue
            targets = np.array([sched.foot_target(i, t) for i in range(4)])
            x, y, yaw = support_frame(targets, nominal_xy)
            yaw = poses[-1][5] + (yaw - poses[-1][5] + math.pi) % (2 * math.pi) - math.pi  # unwrap
            ts.append(t)
            poses.append(np.array([x, y, float(targets[:, 2].mean()) + h, 0.0, 0.0, yaw]))
        return cls(np.array(ts), np.array(poses), np.ones(len(ts)), from_keyframes=False)

    def _segment(self, t: float) -> int:
        return min(max(int(np.searchsorted(self.t_knot, t, side="right")) - 1, 0), len(self.t_knot) - 2)

    def pose_and_rate(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Returns (pose (6,), pose rate (6,)): [x, y, z, roll, pitch, yaw] in m and rad, and its time derivative."""
        tk = self.t_knot
        if len(tk) == 1 or t <= tk[0]:
            return self.pose_knot[0].copy(), np.zeros(6)
        if t >= tk[-1]:
            return self.pose_knot[-1].copy(), np.zeros(6)
        k = self._segment(t)
        h = tk[k + 1] - tk[k]
        s = (t - tk[k]) / h
        s2, s3 = s * s, s * s * s
        y0, y1 = self.pose_knot[k], self.pose_knot[k + 1]
        m0, m1 = self.slope_knot[k] * h, self.slope_knot[k + 1] * h
        pose = (2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * m0 + (3 * s2 - 2 * s3) * y1 + (s3 - s2) * m1
        rate = (
            (6 * s2 - 6 * s) * y0 + (3 * s2 - 4 * s + 1) * m0 + (6 * s - 6 * s2) * y1 + (3 * s2 - 2 * s) * m1
        ) / h
        return pose, rate

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Returns (p_world_body (3,) m, v_world_body (3,) m/s, rpy (3,) rad, omega_world (3,) rad/s) at time t s."""
        pose, rate = self.pose_and_rate(t)
        return pose[:3], rate[:3], pose[3:], omega_world_from_rpy(pose[3:], rate[3:])

    def weight(self, t: float) -> float:
        """Returns the pose weight at time t: linear between knots, held before the first and after the last."""
        return float(np.interp(t, self.t_knot, self.weight_knot))

    @property
    def final_pose(self) -> np.ndarray:
        """Returns the last knot's pose (6,) [x, y, z, roll, pitch, yaw] (m, rad)."""
        return self.pose_knot[-1].copy()
