"""Swings over the pipeline's swing ground (issue 26): a box's edge under a swing's path is cleared by the foot's
radius and the swing margin, whatever its place in the map's cells. Open-loop: the swing planner replanned every
3 ms from its own plan's state, as the walk does when the foot tracks it (the closed loop is the clutter sweep)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from planning.robot import load_robot
from planning.swing import BodyMotion, SwingParams, SwingPlanner, SwingRequest
from planning.terrain.decision import DecisionParams, TerrainSwing, swing_ground
from planning.terrain.maps import maps_from_grids

RES = 0.03
H_BOX = 0.092
# the swing rules under test, on the pipeline's swing settings (TerrainSwing leaves them off)
SWING = dataclasses.replace(TerrainSwing(), rise_over_boxes=True, endpoint_zone_m=0.01)


def _maps_with_box(box: tuple[float, float, float, float]) -> object:
    """Flat ground at 0 with a box (x0, x1, y0, y1) H_BOX tall; a cell is the box's when its centre is inside (an
    ideal sensor: the box's edge lies anywhere within the cells at its border)."""
    xs = -0.6 + np.arange(60) * RES
    ys = -0.6 + np.arange(50) * RES
    x0, x1, y0, y1 = box
    inside = (xs[:, None] > x0) & (xs[:, None] < x1) & (ys[None, :] > y0) & (ys[None, :] < y1)
    h = np.where(inside, H_BOX, 0.0).astype(np.float64)
    return maps_from_grids((float(xs[0]), float(ys[0])), RES, h, np.zeros(h.shape, bool))


def _box_gap(p_contact: np.ndarray, r: float, box: tuple[float, float, float, float]) -> float:
    """The smallest distance (m) between the foot's sphere (contact points (N, 3)) and the box."""
    c = p_contact + np.array([0.0, 0.0, r])
    x0, x1, y0, y1 = box
    dx = np.maximum(np.maximum(x0 - c[:, 0], c[:, 0] - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - c[:, 1], c[:, 1] - y1), 0.0)
    dz = np.maximum(c[:, 2] - H_BOX, 0.0)
    return float(np.min(np.sqrt(dx * dx + dy * dy + dz * dz)) - r)


def _fly(
    planner: SwingPlanner,
    ground: object,
    p0: np.ndarray,
    targets: list[tuple[float, np.ndarray]],
    t_td: float,
) -> np.ndarray:
    """The foot's path (contact points, every ms) with the leg replanned every 3 ms from its plan's own state;
    targets: (from when, where) its touchdown is asked for."""
    body = BodyMotion(0.0, np.array([0.0, 0.0, 0.52]), np.eye(3))
    p, v = p0.copy(), np.zeros(3)
    path = [p.copy()]
    t, dt = 0.0, planner.params.replan_period_s
    while t < t_td - 0.02:
        target = [q for t_from, q in targets if t_from <= t][-1]
        plan = planner.plan_one(t, SwingRequest(0, p, v, target, t_td), ground, body=body)
        for k in range(1, 4):
            path.append(plan.sample(t + k * dt / 3)[0])
        t += dt
        pos, vel, _ = plan.sample(t)
        p, v = np.asarray(pos, dtype=float), np.asarray(vel, dtype=float)
    return np.array(path)


@pytest.mark.parametrize(("near_edge_m", "t_moved_s"), [(0.055, 0.02), (0.067, 0.04)])
def test_a_swing_whose_foothold_moves_past_a_box_clears_it_by_the_swing_margin(
    near_edge_m: float, t_moved_s: float
) -> None:
    """A box 9.2 cm tall whose near edge is 5.5-6.7 cm ahead of the lifting foot; the touchdown first on the floor
    beyond one of its corners, then moved 20-40 ms into the swing past the other (clutter seed 848: the foothold
    moved 28 cm across a box 20 ms after lift-off and the foot met its top edge). The foot's sphere keeps the
    swing margin from the box (before: 0-1 mm, the apex held to the first plan's over the floor) and lands where
    it was sent last."""
    robot = load_robot("spot")
    r = float(robot.foot_radius_m)
    margin = DecisionParams().swing_margin_m
    box = (0.30 + near_edge_m, 0.46, 0.11, 0.23)
    ground = swing_ground(_maps_with_box(box), r + margin)
    planner = SwingPlanner(robot, SWING.applied_to(SwingParams()))
    first, moved = np.array([0.448, 0.338, 0.0]), np.array([0.468, 0.055, 0.0])
    path = _fly(planner, ground, np.array([0.30, 0.12, 0.0]), [(0.0, first), (t_moved_s, moved)], 0.27)
    assert _box_gap(path, r, box) >= margin - 0.002
    assert math.dist(path[-1][:2], moved[:2]) < 0.02
