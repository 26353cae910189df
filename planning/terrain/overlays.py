"""What the terrain stack shows in the studio and in a session's `/plan`: its maps, its body path and its footholds.

Entries have the generic overlay shape (``{"kind": "points" | "polyline", "points": [[x, y, z], ...], "color":
[r, g, b]}``, world frame, m), so the studio draws each with its own toggle:

- ``terrain_no_step``: the outline of the step-obstacle map (no-step cells with a steppable 4-neighbor), 1 cm over
  the ground-height map, near the body;
- ``terrain_body_obstacles``: the outline of the body-obstacle map, 3 cm over the ground;
- ``body_path_plan``: the body path to the goal (2 cm over the ground);
- ``step_qp_footholds``: the step QP's last footholds; ``step_qp_reference``: the nominal footholds it started from;
- ``depth_cloud``: the last depth scan, thinned (shown on request: it is busy).

Map outlines are computed once per maps object (a new one comes with each scan), not per request.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from planning.terrain.bodypath import BodyPath
from planning.terrain.maps import TerrainMaps
from planning.terrain.sensor import PointCloud
from planning.terrain.stepqp import StepPlan

_CROSS = ndimage.generate_binary_structure(2, 1)


def _points(p: NDArray[np.float64]) -> list[list[float]]:
    return np.round(np.asarray(p, dtype=np.float64).reshape(-1, 3), 3).tolist()


def _thinned(p: NDArray[np.float64], max_points: int) -> NDArray[np.float64]:
    """Every k-th row so at most max_points remain (the same rows for the same input)."""
    if len(p) <= max_points:
        return p
    return p[:: int(np.ceil(len(p) / max_points))][:max_points]


def outline(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Gives the cells of mask with a 4-neighbor outside it (the map's edge does not count as outside)."""
    return mask & ~ndimage.binary_erosion(mask, structure=_CROSS, border_value=1)


def map_overlays(
    maps: TerrainMaps, center_xy: NDArray[np.float64], radius_m: float = 2.0, max_points: int = 1500
) -> dict[str, dict[str, Any]]:
    """Gives the no-step and body-obstacle outlines within radius_m of center_xy (at most max_points each)."""
    xs, ys = maps.cell_centers()
    near = (xs[:, None] - center_xy[0]) ** 2 + (ys[None, :] - center_xy[1]) ** 2 <= radius_m**2
    out: dict[str, dict[str, Any]] = {}
    for name, mask, lift, color in (
        ("terrain_no_step", maps.step_obstacle, 0.01, [0.95, 0.25, 0.2]),
        ("terrain_body_obstacles", maps.body_obstacle, 0.03, [0.6, 0.2, 0.85]),
    ):
        ix, iy = np.nonzero(outline(mask) & near)
        p = np.column_stack([xs[ix], ys[iy], maps.ground_height[ix, iy] + lift])
        out[name] = {
            "kind": "points",
            "points": _points(_thinned(p, max_points)),
            "color": color,
            "point_size": 0.025,
        }
    return out


def plan_overlays(
    maps: TerrainMaps | None,
    path: BodyPath | None,
    plan: StepPlan | None,
    cloud: PointCloud | None,
    max_cloud_points: int = 2500,
) -> dict[str, dict[str, Any]]:
    """Gives the body path, the step QP's footholds and the thinned depth cloud (what exists of them)."""
    out: dict[str, dict[str, Any]] = {}
    if path is not None and len(path.xy) >= 2:
        z = (
            maps.height_at(path.xy[:, 0], path.xy[:, 1]) + 0.02
            if maps is not None
            else np.zeros(len(path.xy))
        )
        out["body_path_plan"] = {
            "kind": "polyline",
            "points": _points(np.column_stack([path.xy, z])),
            "color": [0.2, 0.55, 1.0],
        }
    if plan is not None:
        out["step_qp_footholds"] = {
            "kind": "points",
            "points": _points(plan.footholds),
            "color": [0.1, 0.9, 0.9],
        }
        if plan.p_nominal is not None and maps is not None:
            nom = np.asarray(plan.p_nominal, dtype=np.float64).reshape(-1, 2)
            z = maps.height_at(nom[:, 0], nom[:, 1])
            out["step_qp_reference"] = {
                "kind": "points",
                "points": _points(np.column_stack([nom, z])),
                "color": [0.5, 0.75, 0.75],
            }
    if cloud is not None and cloud.size:
        out["depth_cloud"] = {
            "kind": "points",
            "points": _points(_thinned(cloud.p_world_points, max_cloud_points)),
            "color": [0.85, 0.85, 0.55],
            "point_size": 0.015,
        }
    return out
