import numpy as np
import pytest

from planning.robot import load_robot
from planning.swing import BodyMotion, SwingPlanner


@pytest.fixture(scope="session")
def robot():
    return load_robot("spot")


@pytest.fixture
def planner(robot):
    return SwingPlanner(robot)


def _standing_body(t0: float = 0.0, x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> BodyMotion:
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return BodyMotion(t0, np.array([x, y, 0.52]), R)


@pytest.fixture
def standing_body():
    """A body standing still at the nominal height: standing_body(t0, x, y, yaw) -> BodyMotion."""
    return _standing_body
