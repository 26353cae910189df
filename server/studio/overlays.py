"""Plan overlays drawn generically: any `{"kind": "points" | "polyline" | "segments", "points": [...]}` entry of a
session's plan becomes point clouds or line segments (points may say their "point_size", m); each name gets its own
toggle."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

SAME_M = (
    1e-4  # an overlay whose points all moved less than this (m) is not sent again: no re-upload, no redraw
)
DEFAULT_OFF_WORDS = ("potential", "reference", "error", "cloud")  # shown on request only: busy or diagnostic


def default_on(name: str) -> bool:
    """Returns whether an overlay is shown until toggled: all but the busy and diagnostic ones."""
    return not any(w in name for w in DEFAULT_OFF_WORDS)


def overlay_geometry(entry: dict[str, Any]) -> tuple[str, np.ndarray] | None:
    """Returns ("points", (N,3)) or ("segments", (N,2,3)) of one overlay entry, or None when it draws nothing."""
    kind = entry.get("kind")
    try:
        pts = np.asarray(entry.get("points", []), dtype=np.float32).reshape(-1, 3)
    except (TypeError, ValueError):
        return None
    if len(pts) == 0 or not np.isfinite(pts).all():
        return None
    if kind == "points":
        return "points", pts
    if kind == "polyline":
        if len(pts) < 2:
            return None
        return "segments", np.stack([pts[:-1], pts[1:]], axis=1)
    if kind == "segments":
        n = len(pts) // 2
        return ("segments", pts[: 2 * n].reshape(n, 2, 3)) if n else None
    return None


def _color(entry: dict[str, Any]) -> tuple[int, int, int]:
    c = entry.get("color") or (1.0, 1.0, 1.0)
    try:
        return (int(float(c[0]) * 255), int(float(c[1]) * 255), int(float(c[2]) * 255))
    except (TypeError, ValueError, IndexError):
        return (255, 255, 255)


def _point_size(entry: dict[str, Any]) -> float:
    """The entry's "point_size" (m) when it gives a sensible one, else 4 cm."""
    try:
        size = float(entry.get("point_size", 0.04))
    except (TypeError, ValueError):
        return 0.04
    return size if 0.001 <= size <= 0.5 else 0.04


class OverlayView:
    """Draws the overlays of a plan dict under `root`; `enabled` says which names are shown."""

    def __init__(
        self, scene: Any, root: str = "/overlays", on_new: Callable[[str], None] | None = None
    ) -> None:
        self.scene = scene
        self.root = root
        self.enabled: dict[str, bool] = {}
        self.handles: dict[str, Any] = {}
        self.on_new = on_new
        self._drawn: dict[
            str, tuple[str, np.ndarray, tuple[int, int, int], float]
        ] = {}  # what each handle shows

    def set_enabled(self, name: str, on: bool) -> None:
        self.enabled[name] = on
        h = self.handles.get(name)
        if h is not None:
            h.visible = on

    def update(self, plan: dict[str, Any]) -> None:
        overlays = plan.get("overlays", {}) if isinstance(plan, dict) else {}
        for name, entry in overlays.items():
            if name not in self.enabled:
                self.enabled[name] = default_on(name)
                if self.on_new is not None:
                    self.on_new(name)
            if not self.enabled[name] or not isinstance(entry, dict):
                if name in self.handles:
                    self.handles[name].visible = False
                continue
            geo = overlay_geometry(entry)
            if geo is None:
                if name in self.handles:
                    self.handles[name].visible = False
                continue
            kind, arr = geo
            node = f"{self.root}/{name}"
            color = _color(entry)
            size = _point_size(entry)
            h = self.handles.get(name)
            if h is not None and self._unchanged(name, kind, arr, color, size):
                if not h.visible:
                    h.visible = True
                continue
            self._drawn[name] = (kind, arr, color, size)
            if kind == "points":
                self.handles[name] = self.scene.add_point_cloud(
                    node, points=arr, colors=color, point_size=size, point_shape="circle"
                )
            else:
                self.handles[name] = self.scene.add_line_segments(
                    node, points=arr, colors=color, thickness=0.012
                )
        for name, h in self.handles.items():
            if name not in overlays:
                h.visible = False

    def _unchanged(
        self, name: str, kind: str, arr: np.ndarray, color: tuple[int, int, int], size: float
    ) -> bool:
        drawn = self._drawn.get(name)
        if (
            drawn is None
            or drawn[0] != kind
            or drawn[2] != color
            or drawn[3] != size
            or drawn[1].shape != arr.shape
        ):
            return False
        return bool(np.abs(drawn[1] - arr).max(initial=0.0) < SAME_M)

    def clear(self) -> None:
        for h in self.handles.values():
            try:
                h.remove()
            except Exception:  # noqa: BLE001
                pass
        self.handles.clear()
        self._drawn.clear()
