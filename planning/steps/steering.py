"""Steering input: limits, acceleration limits and smoothing of a (vx, vy, yaw_rate) command."""

from __future__ import annotations

import math
from dataclasses import dataclass

from planning.steps.gait import Gait
from planning.steps.state import SteeringCommand


@dataclass(frozen=True)
class SteeringParams:
    """Limits and smoothing of the steering command (heading frame).

    max_vx_mps: forward speed limit, m/s (the gait's own max_speed_mps also applies).
    max_vx_back_mps: backward speed limit, m/s. max_vy_mps: lateral speed limit, m/s.
    max_yaw_rate_rps: rad/s (a gait's own max_vy_mps / max_yaw_rate_rps replace these two). max_accel_x_mps2, max_accel_y_mps2: m/s². max_yaw_accel_rps2: rad/s².
    tau_s: first-order smoothing time constant, s (0 = no smoothing).
    gait_limits: each gait's own max_speed_mps caps the command (off: only the limits here apply; the speed bench
    turns it off to find what the robot can do). lateral_scale_ref_mps: a gait whose max speed is below this
    has its sideways, backward and turning limits scaled down in proportion (m/s).
    """

    max_vx_mps: float = 2.5  # the bound's and the gallop's cap (trot_fast 2.0: each gait's own)
    max_vx_back_mps: float = 0.8
    max_vy_mps: float = 0.6
    max_yaw_rate_rps: float = 1.2
    max_accel_x_mps2: float = 1.5
    max_accel_y_mps2: float = 1.0
    max_yaw_accel_rps2: float = 3.0
    tau_s: float = 0.15
    gait_limits: bool = True
    lateral_scale_ref_mps: float = 1.6

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if name != "gait_limits" and not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"SteeringParams.{name}: must be finite and >= 0, got {value}")


def _clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


class SteeringFilter:
    """Clamps a command to the limits, low-passes it and limits its rate of change; holds the filtered command."""

    def __init__(self, params: SteeringParams | None = None) -> None:
        self.params = params or SteeringParams()
        self.command = SteeringCommand()

    def reset(self, command: SteeringCommand | None = None) -> None:
        self.command = command or SteeringCommand()

    def limit(self, cmd: SteeringCommand, gait: Gait | None = None) -> SteeringCommand:
        """Returns cmd clamped to the speed limits (and to the gait's max speed; a stand allows no motion)."""
        p = self.params
        if not p.gait_limits:
            gait = None if gait is None or not gait.is_stand else gait
        vx_max = p.max_vx_mps if gait is None else min(p.max_vx_mps, gait.max_speed_mps)
        ref = p.lateral_scale_ref_mps
        scale = 1.0 if gait is None or ref <= 0.0 else min(gait.max_speed_mps / ref, 1.0)
        vy_max, wz_max = p.max_vy_mps * scale, p.max_yaw_rate_rps * scale
        if gait is not None and gait.max_vy_mps is not None:
            vy_max = gait.max_vy_mps
        if gait is not None and gait.max_yaw_rate_rps is not None:
            wz_max = gait.max_yaw_rate_rps
        return SteeringCommand(
            vx=_clip(cmd.vx, -p.max_vx_back_mps * scale, vx_max),
            vy=_clip(cmd.vy, -vy_max, vy_max),
            yaw_rate=_clip(cmd.yaw_rate, -wz_max, wz_max),
        )

    def update(self, cmd: SteeringCommand, dt: float, gait: Gait | None = None) -> SteeringCommand:
        """Returns the filtered command after dt s towards the (limited) target cmd."""
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f"dt: must be finite and >= 0, got {dt}")
        p = self.params
        target = self.limit(cmd, gait)
        alpha = 1.0 if p.tau_s <= 0.0 else 1.0 - math.exp(-dt / p.tau_s)
        cur = self.command

        def step(c: float, tgt: float, rate: float) -> float:
            d = alpha * (tgt - c)
            # Near the target the low-pass step is tiny; take the rest in one go to settle exactly.
            if abs(tgt - c) < 1e-4:
                d = tgt - c
            return c + _clip(d, -rate * dt, rate * dt)

        self.command = SteeringCommand(
            vx=step(cur.vx, target.vx, p.max_accel_x_mps2),
            vy=step(cur.vy, target.vy, p.max_accel_y_mps2),
            yaw_rate=step(cur.yaw_rate, target.yaw_rate, p.max_yaw_accel_rps2),
        )
        return self.command
