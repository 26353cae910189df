"""What the studio sends its browser tabs costs them a redraw each (a software-rendering browser most of a core a
frame): a robot standing still and plan overlays that did not change are not sent again; shadows can be switched off
for every new tab."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from server.settings import Settings, SettingsError
from server.studio.client import STILL_M, StudioClient
from server.studio.overlays import OverlayView


class _Handle:
    def __init__(self) -> None:
        self.visible = True


class _Scene:
    """Counts what an OverlayView adds."""

    def __init__(self) -> None:
        self.added: list[str] = []

    def add_point_cloud(self, node: str, **_: Any) -> _Handle:
        self.added.append(node)
        return _Handle()

    def add_line_segments(self, node: str, **_: Any) -> _Handle:
        self.added.append(node)
        return _Handle()


def _plan(x: float) -> dict[str, Any]:
    return {"overlays": {"body_path": {"kind": "polyline", "points": [[0, 0, 0.5], [x, 0, 0.5]]}}}


def test_an_unchanged_overlay_is_not_sent_again() -> None:
    scene = _Scene()
    view = OverlayView(scene)
    view.update(_plan(1.0))
    view.update(_plan(1.0 + 1e-6))  # below a 0.1 mm change: the same picture
    assert scene.added == ["/overlays/body_path"]
    view.update(_plan(1.01))
    assert len(scene.added) == 2
    view.update({"overlays": {}})  # gone: hidden, then back unchanged: shown without a re-send
    assert not view.handles["body_path"].visible
    view.update(_plan(1.01))
    assert view.handles["body_path"].visible and len(scene.added) == 2
    view.clear()
    view.update(_plan(1.01))  # after a clear it is drawn again
    assert len(scene.added) == 3


def test_a_still_robot_is_not_sent_again() -> None:
    tab = SimpleNamespace(_sent_pose=None)
    pos, quat = np.zeros((5, 3)), np.tile([1.0, 0, 0, 0], (5, 1))
    assert StudioClient._moved(tab, pos, quat)  # type: ignore[arg-type]  # the first pose goes out
    assert not StudioClient._moved(tab, pos + 0.2 * STILL_M, quat)  # type: ignore[arg-type]
    creep = pos.copy()
    sent = 0
    for _ in range(20):  # a slow creep is sent once it adds up to STILL_M, not lost
        creep[2, 0] += 0.3 * STILL_M
        sent += StudioClient._moved(tab, creep, quat)  # type: ignore[arg-type]
    assert 5 <= sent <= 7
    turned = quat.copy()
    turned[1] = [np.cos(0.01), 0, 0, np.sin(0.01)]
    assert StudioClient._moved(tab, creep, turned)  # type: ignore[arg-type]


def test_shadows_setting() -> None:
    assert Settings().studio_shadows
    assert not Settings.from_env({"FOOTFALL_STUDIO_SHADOWS": "0"}).studio_shadows
    with pytest.raises(SettingsError, match="FOOTFALL_STUDIO_SHADOWS"):
        Settings.from_env({"FOOTFALL_STUDIO_SHADOWS": "dim"})
