"""Shared fixtures of the maneuver tests: the Spot-class robot and a minimal valid maneuver dict."""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import pytest

from planning.robot import RobotModel, load_robot

BASE: dict[str, Any] = {"format": "footfall/maneuver@1", "name": "t", "duration": 4.0}


def _maneuver(**fields: Any) -> dict[str, Any]:
    """Returns a maneuver dict: the minimal valid one with `fields` set."""
    d = copy.deepcopy(BASE)
    d.update(fields)
    return d


@pytest.fixture(scope="session")
def mk() -> Callable[..., dict[str, Any]]:
    """The maker of maneuver dicts: mk(duration=5.0, events=[...])."""
    return _maneuver


@pytest.fixture(scope="session")
def robot() -> RobotModel:
    return load_robot("spot")
