"""The robot: any quadruped MJCF (plus an optional small description), names resolved once, analytic leg kinematics."""

from planning.robot.model import (
    LEGS,
    ReachError,
    RobotDescriptionError,
    RobotModel,
    available_robots,
    load_robot,
)

__all__ = ["LEGS", "ReachError", "RobotDescriptionError", "RobotModel", "available_robots", "load_robot"]
