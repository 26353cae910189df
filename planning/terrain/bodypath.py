"""The body path: a planar path (horizontal position and yaw) for the body from the body-obstacle map and a goal.

A potential field first (fast): a unit pull toward the goal plus pushes away from body obstacles along the body
SDF's gradient, felt at the points of the body's footprint. When the field traps the body (no progress toward the
goal for a while) or its path fails validation, an A* grid search on the body map (cells whose disk of the body's
half width is free) takes over, then the path is shortened by line of sight. Every path is validated by sweeping
the footprint (circles along the body's long axis) along it. Momentum is not modeled: positions only.
Off the map, space counts as free.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from planning.terrain.maps import TerrainMaps


@dataclass(frozen=True)
class BodyPathParams:
    """Body path. step_m: field step (m); goal_tol_m: reached within (m); repulse_m: obstacles felt within this
    clearance (m); k_repulse: push strength relative to the unit pull; footprint_x_m: circle centers along the body
    x axis (m); footprint_r_m: circle radius (m) (three circles of 0.2 m cover a 0.9 × 0.26 m body plus margin);
    max_iters: field iterations; stall_iters, stall_m: trapped when the goal distance shrank by less than stall_m
    over stall_iters steps; grid_m: A* cell (m); grid_margin_m: A* region beyond start, goal and map (m);
    grid_heading: a move of the A* search (and a shortcut of its path) is free when the whole footprint at the move's
    heading is clear, not only the disk at its centre (with the disk alone a path grazes a tall box with the
    footprint's end circles where it turns at a corner), and keeps grid_clear_m (m) more from body obstacles than
    the footprint (the path's yaw turns from the body's over its first 0.3 m, and the body lags its path's yaw). Off:
    on the clutter family it gave 14 of 50 clean against 22 (docs/terrain-notes.md, session 11); sample_m: spacing of the output path (m)."""

    step_m: float = 0.05
    goal_tol_m: float = 0.05
    repulse_m: float = 0.35
    k_repulse: float = 2.5
    footprint_x_m: tuple[float, ...] = (-0.3, 0.0, 0.3)
    footprint_r_m: float = 0.17
    max_iters: int = 600
    stall_iters: int = 30
    stall_m: float = 0.15
    grid_m: float = 0.06
    grid_margin_m: float = 1.0
    grid_heading: bool = False
    grid_clear_m: float = 0.05
    sample_m: float = 0.05


@dataclass(frozen=True, eq=False)
class BodyPath:
    """A planar body path. xy: (N, 2) world (m); yaw: (N,) (rad, unwrapped); s: (N,) arc length (m); method:
    'field', 'grid' or 'straight'; valid: the footprint sweep found no collision; min_clearance_m: the sweep's
    smallest clearance (m)."""

    xy: NDArray[np.float64]
    yaw: NDArray[np.float64]
    s: NDArray[np.float64]
    method: str
    valid: bool
    min_clearance_m: float

    @property
    def length_m(self) -> float:
        return float(self.s[-1])

    def pose_at(self, s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gives (xy (.., 2), yaw (..)) at arc length s (clamped to the path)."""
        sa = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.s[-1])
        x = np.interp(sa, self.s, self.xy[:, 0])
        y = np.interp(sa, self.s, self.xy[:, 1])
        return np.stack([x, y], axis=-1), np.interp(sa, self.s, self.yaw)


def _clearance(maps: TerrainMaps | None, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Body SDF at points (.., 2), +inf off the map."""
    if maps is None:
        return np.full(xy.shape[:-1], np.inf)
    d = np.asarray(maps.sdf_body(xy[..., 0], xy[..., 1]), dtype=np.float64)
    return np.where(maps.in_map(xy[..., 0], xy[..., 1]), d, np.inf)


def footprint_points(
    xy: NDArray[np.float64], yaw: NDArray[np.float64], offsets: tuple[float, ...]
) -> NDArray[np.float64]:
    """Gives the footprint circle centers (.., n, 2) for poses xy (.., 2), yaw (..)."""
    off = np.asarray(offsets)
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    return np.stack([xy[..., None, 0] + c * off, xy[..., None, 1] + s * off], axis=-1)


def sweep_points_clearance(
    maps: TerrainMaps | None, xy: NDArray[np.float64], yaw: NDArray[np.float64], offsets: tuple[float, ...]
) -> NDArray[np.float64]:
    """Gives the body SDF (.., n) (m, +inf off the map) at the footprint circle centers of poses xy (.., 2),
    yaw (..) (the footprint radius not subtracted)."""
    return _clearance(maps, footprint_points(xy, yaw, offsets))


def sweep_clearance(maps: TerrainMaps | None, path: BodyPath, params: BodyPathParams) -> float:
    """Gives the smallest clearance (m) of the footprint swept along the path (negative: a collision)."""
    n = max(int(np.ceil(path.length_m / 0.02)), 1) + 1
    xy, yaw = path.pose_at(np.linspace(0.0, path.length_m, n))
    pts = footprint_points(xy, yaw, params.footprint_x_m)
    return float(np.min(_clearance(maps, pts)) - params.footprint_r_m)


def _make_path(points: NDArray[np.float64], yaw0: float, goal_yaw: float | None, sample_m: float) -> tuple:
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate([[True], seg > 1e-9])
    points = points[keep]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    if s[-1] < 1e-9:
        yaw = np.array([yaw0 if goal_yaw is None else goal_yaw])
        return points[:1], yaw, np.zeros(1)
    n = max(int(np.ceil(s[-1] / sample_m)), 1) + 1
    ss = np.linspace(0.0, s[-1], n)
    xy = np.stack([np.interp(ss, s, points[:, 0]), np.interp(ss, s, points[:, 1])], axis=1)
    d = np.gradient(xy, axis=0)
    heading = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    # Smooth the heading a little; blend from the start yaw and into the goal yaw over the first/last 0.3 m.
    k = max(int(round(0.15 / sample_m)), 1)
    kern = np.ones(2 * k + 1) / (2 * k + 1)
    heading = np.convolve(np.pad(heading, k, mode="edge"), kern, mode="valid")
    yaw0u = heading[0] + np.angle(np.exp(1j * (yaw0 - heading[0])))
    w0 = np.clip(1.0 - ss / 0.3, 0.0, 1.0)
    yaw = w0 * yaw0u + (1 - w0) * heading
    if goal_yaw is not None:
        gy = yaw[-1] + np.angle(np.exp(1j * (goal_yaw - yaw[-1])))
        w1 = np.clip(1.0 - (ss[-1] - ss) / 0.3, 0.0, 1.0)
        yaw = (1 - w1) * yaw + w1 * gy
    return xy, yaw, ss


def plan_body_path(
    maps: TerrainMaps | None,
    start_xy: ArrayLike,
    start_yaw: float,
    goal_xy: ArrayLike,
    params: BodyPathParams | None = None,
    goal_yaw: float | None = None,
) -> BodyPath:
    """Gives a body path from (start_xy, start_yaw) to goal_xy: the potential field's, else the grid search's."""
    p = params or BodyPathParams()
    start = np.asarray(start_xy, dtype=np.float64).reshape(2)
    goal = np.asarray(goal_xy, dtype=np.float64).reshape(2)
    if not (np.all(np.isfinite(start)) and np.all(np.isfinite(goal)) and np.isfinite(start_yaw)):
        raise ValueError("plan_body_path: start_xy, start_yaw and goal_xy must be finite")
    pts = _field(maps, start, goal, p)
    if pts is not None:
        path = _finish(maps, pts, start_yaw, goal_yaw, "field", p)
        if path.valid:
            return path
    grid_pts = _grid_search(maps, start, goal, p)
    if grid_pts is not None:
        path = _finish(maps, grid_pts, start_yaw, goal_yaw, "grid", p)
        if path.valid or pts is None:
            return path
    if pts is not None:
        return _finish(maps, pts, start_yaw, goal_yaw, "field", p)
    return _finish(maps, np.stack([start, goal]), start_yaw, goal_yaw, "straight", p)


def _finish(
    maps: TerrainMaps | None, pts: NDArray[np.float64], yaw0: float, goal_yaw: float | None, method: str,
    p: BodyPathParams,
) -> BodyPath:  # fmt: skip
    xy, yaw, s = _make_path(pts, yaw0, goal_yaw, p.sample_m)
    path = BodyPath(xy, yaw, s, method, True, np.inf)
    clear = sweep_clearance(maps, path, p)
    start_clear = clear
    if maps is not None:
        # A start already in collision (e.g. maps that just appeared) must not invalidate every path: judge the
        # part beyond the first 0.3 m.
        n0 = int(np.searchsorted(s, 0.3))
        if n0 < len(s) - 1:
            rest = BodyPath(xy[n0:], yaw[n0:], s[n0:] - s[n0], method, True, np.inf)
            start_clear = sweep_clearance(maps, rest, p)
    return BodyPath(xy, yaw, s, method, bool(start_clear >= 0.0), clear)


def _field(
    maps: TerrainMaps | None, start: NDArray[np.float64], goal: NDArray[np.float64], p: BodyPathParams
):
    x = start.copy()
    pts = [x.copy()]
    dists = [float(np.linalg.norm(goal - x))]
    heading = np.arctan2(goal[1] - x[1], goal[0] - x[0])
    for it in range(p.max_iters):
        to_goal = goal - x
        dist = float(np.linalg.norm(to_goal))
        if dist < p.goal_tol_m:
            pts.append(goal.copy())
            return np.array(pts)
        force = to_goal / dist
        if maps is not None:
            fp = footprint_points(x[None], np.array([heading]), p.footprint_x_m)[0]
            d = _clearance(maps, fp) - p.footprint_r_m
            near = np.isfinite(d) & (d < p.repulse_m)
            if near.any():
                g = np.atleast_2d(maps.sdf_body_grad(fp[near, 0], fp[near, 1]))
                w = p.k_repulse * ((p.repulse_m - d[near]) / p.repulse_m) ** 2
                force = force + (w[:, None] * g).sum(axis=0)
        n = float(np.linalg.norm(force))
        if n < 1e-6:
            return None
        step = force / n * min(p.step_m, dist)
        x = x + step
        heading = float(np.arctan2(step[1], step[0]))
        pts.append(x.copy())
        dists.append(float(np.linalg.norm(goal - x)))
        if it >= p.stall_iters and dists[-1 - p.stall_iters] - dists[-1] < p.stall_m:
            return None
    return None


def _grid_search(
    maps: TerrainMaps | None, start: NDArray[np.float64], goal: NDArray[np.float64], p: BodyPathParams
):
    """A* on a grid over start, goal and the map; a cell is free when the body's disk there is clear."""
    lo = np.minimum(start, goal) - p.grid_margin_m
    hi = np.maximum(start, goal) + p.grid_margin_m
    if maps is not None:
        xs, ys = maps.cell_centers()
        lo = np.minimum(lo, [xs[0], ys[0]])
        hi = np.maximum(hi, [xs[-1], ys[-1]])
    g = p.grid_m
    nx = int(np.ceil((hi[0] - lo[0]) / g)) + 1
    ny = int(np.ceil((hi[1] - lo[1]) / g)) + 1
    gx = lo[0] + np.arange(nx) * g
    gy = lo[1] + np.arange(ny) * g
    cx, cy = np.meshgrid(gx, gy, indexing="ij")
    clear = _clearance(maps, np.stack([cx, cy], axis=-1)) - p.footprint_r_m
    free = clear >= 0.0
    s_idx = (int(round((start[0] - lo[0]) / g)), int(round((start[1] - lo[1]) / g)))
    g_idx = (int(round((goal[0] - lo[0]) / g)), int(round((goal[1] - lo[1]) / g)))
    free[s_idx] = True
    free[g_idx] = True
    # Prefer cells away from obstacles: a small extra cost near them.
    extra = np.where(np.isfinite(clear), np.clip(0.3 - clear, 0.0, 0.3), 0.0)
    moves = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)]
    # Per move, the cells the body may enter along it: the whole footprint clear at the move's heading.
    free_by_move = []
    for dx, dy in moves:
        if not p.grid_heading:
            free_by_move.append(free)
            continue
        fp = footprint_points(
            np.stack([cx, cy], axis=-1), np.full(cx.shape, np.arctan2(dy, dx)), p.footprint_x_m
        )
        ok = free & (np.min(_clearance(maps, fp), axis=-1) - p.footprint_r_m >= p.grid_clear_m)
        ok[s_idx] = True
        ok[g_idx] = True
        free_by_move.append(ok)
    cost = {s_idx: 0.0}
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    heap = [(0.0, s_idx)]
    gi = np.array(g_idx)
    while heap:
        _, cur = heapq.heappop(heap)
        if cur == g_idx:
            break
        c0 = cost[cur]
        for m, (dx, dy) in enumerate(moves):
            nb = (cur[0] + dx, cur[1] + dy)
            if not (0 <= nb[0] < nx and 0 <= nb[1] < ny) or not free_by_move[m][nb]:
                continue
            c = c0 + g * (np.hypot(dx, dy) + 2.0 * extra[nb])
            if c < cost.get(nb, np.inf):
                cost[nb] = c
                parent[nb] = cur
                h = g * float(np.linalg.norm(gi - np.array(nb)))
                heapq.heappush(heap, (c + h, nb))
    if g_idx not in cost:
        return None
    cells = [g_idx]
    while cells[-1] != s_idx:
        cells.append(parent[cells[-1]])
    cells.reverse()
    pts = np.array([[gx[i], gy[j]] for i, j in cells])
    pts[0], pts[-1] = start, goal
    return _shortcut(maps, pts, p)


def _shortcut(maps: TerrainMaps | None, pts: NDArray[np.float64], p: BodyPathParams) -> NDArray[np.float64]:
    """Drops waypoints while the straight segment between kept ones stays clear for the body's disk."""
    out = [pts[0]]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1:
            seg = np.linspace(pts[i], pts[j], max(int(np.linalg.norm(pts[j] - pts[i]) / 0.03), 2))
            if p.grid_heading:
                d = pts[j] - pts[i]
                seg = footprint_points(seg, np.full(len(seg), np.arctan2(d[1], d[0])), p.footprint_x_m)
            if np.min(_clearance(maps, seg)) - p.footprint_r_m >= (p.grid_clear_m if p.grid_heading else 0.0):
                break
            j -= 1
        out.append(pts[j])
        i = j
    return np.array(out)
