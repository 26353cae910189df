"""bench_swing_select: time to select one swing leg's policies — flat ground, beside a box, crossing another leg;
and per leg in a trot's tick (two diagonal legs planned in one call, which share the stance legs' set-up).

Each case replans its legs from states along their own swings (as the loop does every 3 ms) a few hundred times.
"""

from __future__ import annotations

import time

import numpy as np

from planning.robot import load_robot
from planning.swing.params import SwingParams
from planning.swing.planner import SwingPlanner
from planning.swing.types import BodyMotion, Box, BoxGround, GroundHeightFn, SwingRequest, flat_ground


def _case(name: str) -> tuple[SwingRequest, GroundHeightFn, dict[int, np.ndarray], BodyMotion]:
    body = BodyMotion(0.0, np.array([0.05, 0.0, 0.52]), np.eye(3))
    stance = {
        1: np.array([0.35, -0.165, 0.0]),
        2: np.array([-0.25, 0.165, 0.0]),
        3: np.array([-0.25, -0.165, 0.0]),
    }
    start, target, T = np.array([0.20, 0.165, 0.0]), np.array([0.50, 0.165, 0.0]), 0.35
    ground: GroundHeightFn = flat_ground
    if name == "box":
        ground = BoxGround([Box(0.40, 0.46, 0.05, 0.30, 0.10)])  # just before the touchdown
    elif name == "crossing":
        stance[1] = np.array([0.33, 0.0, 0.0])  # FR stands in FL's way
        start, target, T = np.array([0.15, 0.0, 0.0]), np.array([0.52, 0.0, 0.0]), 0.45
    return SwingRequest(0, start, np.zeros(3), target, T), ground, stance, body


def _trot_pair(calls: int) -> dict[str, object]:
    """FL and RR swing together over flat ground (FR and RL in stance): time per call over 2 legs."""
    robot = load_robot("spot")
    planner = SwingPlanner(robot, SwingParams())
    body = BodyMotion(0.0, np.array([0.05, 0.0, 0.52]), np.eye(3), np.array([0.6, 0.0, 0.0]))
    stance = {1: np.array([0.30, -0.165, 0.0]), 2: np.array([-0.30, 0.165, 0.0])}
    reqs = [
        SwingRequest(0, np.array([0.20, 0.165, 0.0]), np.zeros(3), np.array([0.50, 0.165, 0.0]), 0.25),
        SwingRequest(3, np.array([-0.40, -0.165, 0.0]), np.zeros(3), np.array([-0.10, -0.165, 0.0]), 0.25),
    ]
    first = planner.plan(0.0, reqs, flat_ground, stance, body)
    times, evals = [], []
    horizon = 0.25 - 0.03
    for k in range(calls):
        t = horizon * k / calls
        rs = []
        for r in reqs:
            p, v, _ = first[r.leg].sample(t)
            rs.append(SwingRequest(r.leg, p, v, r.p_touchdown, r.t_touchdown))
        b = BodyMotion(t, body.p_world_body + body.v_world_body * t, body.R_world_body, body.v_world_body)
        t0 = time.perf_counter()
        plans = planner.plan(t, rs, flat_ground, stance, b)
        times.append((time.perf_counter() - t0) / len(rs))
        evals += [pl.evaluations for pl in plans.values()]
    ms = np.array(times) * 1e3
    return {
        "p50_ms": round(float(np.percentile(ms, 50)), 4),
        "p99_ms": round(float(np.percentile(ms, 99)), 4),
        "evaluations_mean": round(float(np.mean(evals)), 2),
        "evaluations_max": int(np.max(evals)),
        "evaluations_bound": planner.max_evaluations,
        "per": "leg (call time / 2)",
    }


def _run(name: str, calls: int) -> dict[str, object]:
    robot = load_robot("spot")
    planner = SwingPlanner(robot, SwingParams())
    req, ground, stance, body = _case(name)
    first = planner.plan(0.0, [req], ground, stance, body)[0]
    times, evals = [], []
    horizon = req.t_touchdown - 0.03
    for k in range(calls):
        t = horizon * k / calls
        p, v, _ = first.sample(t)
        r = SwingRequest(0, p, v, req.p_touchdown, req.t_touchdown)
        b = BodyMotion(t, body.p_world_body, body.R_world_body)
        t0 = time.perf_counter()
        plan = planner.plan(t, [r], ground, stance, b)[0]
        times.append(time.perf_counter() - t0)
        evals.append(plan.evaluations)
    ms = np.array(times) * 1e3
    return {
        "p50_ms": round(float(np.percentile(ms, 50)), 4),
        "p99_ms": round(float(np.percentile(ms, 99)), 4),
        "evaluations_mean": round(float(np.mean(evals)), 2),
        "evaluations_max": int(np.max(evals)),
        "evaluations_bound": planner.max_evaluations,
        "tier": first.tier.name,
        "policy": "/".join(first.policy_names),
    }


def bench_swing_select(calls: int = 300) -> dict[str, object]:
    """Returns p50/p99 (ms) and evaluation counts per case; the top-level p50/p99 are the flat case's."""
    out: dict[str, object] = {case: _run(case, calls) for case in ("flat", "box", "crossing")}
    out["trot_pair"] = _trot_pair(calls)
    flat = out["flat"]
    assert isinstance(flat, dict)
    return {"p50_ms": flat["p50_ms"], "p99_ms": flat["p99_ms"], "case": "flat", **out}


if __name__ == "__main__":
    import json

    print(json.dumps(bench_swing_select(), indent=2))
