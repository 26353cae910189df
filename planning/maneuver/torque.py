"""Validation rule: whether the robot's motors can hold the maneuver's keyframe poses (the static torque each stance
joint needs to carry the body's weight, shared equally by the stance feet, against its torque limit).

A warning, not a failure: the split of the weight is an estimate, and the closed loop may lean on the other feet.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from planning.maneuver.body import rotation_from_rpy
from planning.maneuver.problems import Problem

if TYPE_CHECKING:
    from planning.maneuver.validate import Context

GRAVITY = 9.81  # m/s²
JOINTS = ("hip abduction", "hip flexion", "knee")


def check_keyframe_torque(ctx: Context) -> Iterator[Problem]:
    """Warning: a keyframe pose at which a stance joint needs more than its torque limit to hold the body."""
    s = ctx.schedule
    if s is None:
        return
    robot = ctx.robot
    weight = robot.mass_kg * GRAVITY
    for i, k in enumerate(ctx.maneuver.body):
        R = rotation_from_rpy(np.radians(k.rpy))
        p_body = np.array(k.position)
        stance = [leg for leg in range(4) if s.in_stance(leg, k.t)]
        if not stance:
            continue
        f_body = R.T @ np.array([0.0, 0.0, weight / len(stance)])  # ground on foot, body frame
        for leg in stance:
            p_foot = ctx.foot_center(s.foot_position(leg, k.t), s.foot_normal(leg, k.t))
            try:
                q = robot.ik_leg(leg, R.T @ (p_foot - p_body))
            except ValueError:  # out of reach: the reach rule says so
                continue
            tau = np.abs(robot.jacobian_leg(leg, q).T @ f_body)
            over = tau / robot.tau_max[leg]
            j = int(np.argmax(over))
            if over[j] > 1.0:
                name = ("FL", "FR", "RL", "RR")[leg]
                yield Problem(
                    f"body[{i}]",
                    f"keyframe at {k.t:g} s needs about {tau[j]:.1f} N·m at the {name} {JOINTS[j]} to hold the "
                    f"body still, more than its {robot.tau_max[leg, j]:.1f} N·m limit",
                    "warning",
                )
