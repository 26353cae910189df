"""Trip classification (seed FIG. 16): turns what the simulation saw into a TripEvent for the swing planner.

The responses live in the planner: a normal trip stops forward motion and elevates the foot; a recent normal trip
keeps the foot elevated; knee trips and self-collisions get special horizontal policies.
"""

from __future__ import annotations

import numpy as np

from planning.robot import RobotModel
from planning.swing.types import TripEvent, TripKind

#: The response table of FIG. 16, as the planner applies it (for the studio's help and the logs).
TRIP_RESPONSES: dict[str, str] = {
    "normal trip": "stop forward motion; elevate foot",
    "recent normal trip": "elevate foot",
    "knee trip": "special XY policy (Trip:Knee — move on slowly)",
    "self-collision (crossed)": "special XY policy (Trip:Disentangle — back to its own side first)",
    "self-collision (uncrossed)": "special XY policy (Trip:SideStep — away from the other leg, then on)",
}


def legs_crossed(robot: RobotModel, leg: int, other: int, p_body_feet: np.ndarray) -> bool:
    """True when leg's foot lies on the far side of other's foot, judged along the line between their hips.

    p_body_feet: (4,3) foot positions in the body frame.
    """
    d_hips = robot.p_body_hip[leg, :2] - robot.p_body_hip[other, :2]
    d_feet = p_body_feet[leg, :2] - p_body_feet[other, :2]
    return float(d_hips @ d_feet) < 0.0


def classify_trip(
    robot: RobotModel,
    leg: int,
    t_s: float,
    p_body_feet: np.ndarray,
    foot_hit: bool = False,
    knee_hit: bool = False,
    other_leg: int | None = None,
) -> TripEvent | None:
    """Returns the trip a swing leg had, from the contacts the simulation saw this tick, or None.

    foot_hit: the swing foot touched terrain before its touchdown window; knee_hit: its lower leg or knee touched
    terrain; other_leg: the leg it touched, if any. A self-collision outranks a knee trip, which outranks a foot
    trip.
    """
    if other_leg is not None:
        kind = (
            TripKind.SELF_CROSSED
            if legs_crossed(robot, leg, other_leg, p_body_feet)
            else TripKind.SELF_UNCROSSED
        )
        return TripEvent(kind, t_s, other_leg)
    if knee_hit:
        return TripEvent(TripKind.KNEE, t_s)
    if foot_hit:
        return TripEvent(TripKind.NORMAL, t_s)
    return None
