"""Leg swing trajectories (seed US 2021/0039731): policies, tiers, multi-leg planning and trips."""

from planning.swing.control import swing_joint_command
from planning.swing.params import SwingParams, VerticalLevel
from planning.swing.planner import SwingPlan, SwingPlanner
from planning.swing.policies import DEFAULT_POLICY, HORIZONTAL_NAMES
from planning.swing.trips import TRIP_RESPONSES, classify_trip, legs_crossed
from planning.swing.types import (
    TIER_RGB,
    BodyMotion,
    Box,
    BoxGround,
    FlatGround,
    GroundHeightFn,
    SwingRequest,
    Tier,
    TripEvent,
    TripKind,
    flat_ground,
)

__all__ = [
    "DEFAULT_POLICY",
    "HORIZONTAL_NAMES",
    "TIER_RGB",
    "TRIP_RESPONSES",
    "BodyMotion",
    "Box",
    "BoxGround",
    "FlatGround",
    "GroundHeightFn",
    "SwingParams",
    "SwingPlan",
    "SwingPlanner",
    "SwingRequest",
    "Tier",
    "TripEvent",
    "TripKind",
    "VerticalLevel",
    "classify_trip",
    "flat_ground",
    "legs_crossed",
    "swing_joint_command",
]
