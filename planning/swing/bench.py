"""bench_swing_select: time to select one swing leg's policies — flat ground, beside a box, crossing another leg;
and per leg in a trot's tick (two diagonal legs planned in one call, which share the stance legs' set-up).

Each case replans its legs from states along their own swings (as the loop does every 3 ms) a few hundred times.
Per case: wall time (``p50_ms``, ``p99_ms``), this thread's CPU time (``cpu_p50_us``, ``cpu_p99_us``: other
processes on the machine do not add to it) and, measured in a second pass, the CPU time of the bare geometry calls
inside each replan (``geometry_cpu_us``: the ground lookups and the leg IK; the rest is the selection's own work).
With the product's parameters most of these replans reuse the last selection (``SwingParams.reuse_selection_s``);
``full_analysis`` gives the same cases with the full tier analysis on every replan (``reuse_selection_s=0``).

Run: ``python -m planning.swing.bench`` (everything), ``--full`` (the full-analysis rows alone), ``--calls N``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from planning.robot import load_robot
from planning.swing.params import SwingParams
from planning.swing.planner import SwingPlanner
from planning.swing.types import (
    BodyMotion,
    Box,
    BoxGround,
    FlatGround,
    GroundHeightFn,
    SwingRequest,
    flat_ground,
)


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
    times, cpu, evals = [], [], []
    horizon = 0.25 - 0.03
    for k in range(calls):
        t = horizon * k / calls
        rs = []
        for r in reqs:
            p, v, _ = first[r.leg].sample(t)
            rs.append(SwingRequest(r.leg, p, v, r.p_touchdown, r.t_touchdown))
        b = BodyMotion(t, body.p_world_body + body.v_world_body * t, body.R_world_body, body.v_world_body)
        t0, c0 = time.perf_counter(), time.thread_time()
        plans = planner.plan(t, rs, flat_ground, stance, b)
        cpu.append((time.thread_time() - c0) / len(rs))
        times.append((time.perf_counter() - t0) / len(rs))
        evals += [pl.evaluations for pl in plans.values()]
    ms = np.array(times) * 1e3
    cpu_us = np.array(cpu) * 1e6
    return {
        "p50_ms": round(float(np.percentile(ms, 50)), 4),
        "p99_ms": round(float(np.percentile(ms, 99)), 4),
        "cpu_p50_us": round(float(np.percentile(cpu_us, 50)), 1),
        "cpu_p99_us": round(float(np.percentile(cpu_us, 99)), 1),
        "evaluations_mean": round(float(np.mean(evals)), 2),
        "evaluations_max": int(np.max(evals)),
        "evaluations_bound": planner.max_evaluations,
        "per": "leg (call time / 2)",
    }


class _Geometry:
    """Times the bare geometry calls (the ground lookups and the leg IK) inside one planner, in this thread's CPU
    time, by wrapping the ground height function and the robot's IK methods of that planner's robot instance."""

    _IK = ("knee_of_foot", "ik_leg", "ik_leg_many", "knee_body", "knee_body_many")

    def __init__(self, robot: object) -> None:
        self.spent = 0.0
        for name in self._IK:
            setattr(robot, name, self._timed(getattr(robot, name)))

    def _timed(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any) -> Any:
            t0 = time.thread_time()
            try:
                return fn(*args)
            finally:
                self.spent += time.thread_time() - t0

        return timed

    def ground(self, ground: GroundHeightFn) -> GroundHeightFn:
        if isinstance(ground, FlatGround):
            return ground  # the planner skips terrain sampling on flat ground
        return self._timed(ground)


def _run(name: str, calls: int, geometry: bool = False, full: bool = False) -> dict[str, object]:
    """Replans the case's leg ``calls`` times: wall and thread CPU time per call (p50, p99), evaluations; with
    ``geometry``, the CPU time of the bare geometry calls inside each call instead (p50, p99, µs); with ``full``,
    every replan runs the full tier analysis (no reused selection)."""
    robot = load_robot("spot")
    geo = _Geometry(robot) if geometry else None
    planner = SwingPlanner(robot, SwingParams(reuse_selection_s=0.0) if full else SwingParams())
    req, ground, stance, body = _case(name)
    if geo is not None:
        ground = geo.ground(ground)
    first = planner.plan(0.0, [req], ground, stance, body)[0]
    times, cpu, geo_s, evals = [], [], [], []
    horizon = req.t_touchdown - 0.03
    for k in range(calls):
        t = horizon * k / calls
        p, v, _ = first.sample(t)
        r = SwingRequest(0, p, v, req.p_touchdown, req.t_touchdown)
        b = BodyMotion(t, body.p_world_body, body.R_world_body)
        g0 = 0.0 if geo is None else geo.spent
        t0, c0 = time.perf_counter(), time.thread_time()
        plan = planner.plan(t, [r], ground, stance, b)[0]
        cpu.append(time.thread_time() - c0)
        times.append(time.perf_counter() - t0)
        evals.append(plan.evaluations)
        if geo is not None:
            geo_s.append(geo.spent - g0)
    if geo is not None:
        us = np.array(geo_s) * 1e6
        return {
            "p50_us": round(float(np.percentile(us, 50)), 1),
            "p99_us": round(float(np.percentile(us, 99)), 1),
        }
    ms = np.array(times) * 1e3
    cpu_us = np.array(cpu) * 1e6
    return {
        "p50_ms": round(float(np.percentile(ms, 50)), 4),
        "p99_ms": round(float(np.percentile(ms, 99)), 4),
        "cpu_p50_us": round(float(np.percentile(cpu_us, 50)), 1),
        "cpu_p99_us": round(float(np.percentile(cpu_us, 99)), 1),
        "evaluations_mean": round(float(np.mean(evals)), 2),
        "evaluations_max": int(np.max(evals)),
        "evaluations_bound": planner.max_evaluations,
        "tier": first.tier.name,
        "policy": "/".join(first.policy_names),
    }


_CASES = ("flat", "box", "crossing")


def bench_full_analysis(calls: int = 300) -> dict[str, object]:
    """The cases with the full tier analysis on every replan (SwingParams.reuse_selection_s = 0), per case as
    bench_swing_select's."""
    return {case: _run(case, calls, full=True) for case in _CASES}


def bench_swing_select(calls: int = 300) -> dict[str, object]:
    """Returns p50/p99 (ms) and evaluation counts per case; the top-level p50/p99 are the flat case's; and the
    cases again with the full tier analysis on every replan (``full_analysis``)."""
    out: dict[str, object] = {case: _run(case, calls) for case in _CASES}
    for case in _CASES:
        # the ground lookups and the leg IK alone, timed inside the same replans (a second pass: their timers
        # would otherwise add to the times above)
        r = out[case]
        assert isinstance(r, dict)
        r["geometry_cpu_us"] = _run(case, calls, geometry=True)
    out["trot_pair"] = _trot_pair(calls)
    out["full_analysis"] = bench_full_analysis(calls)
    flat = out["flat"]
    assert isinstance(flat, dict)
    return {"p50_ms": flat["p50_ms"], "p99_ms": flat["p99_ms"], "case": "flat", **out}


if __name__ == "__main__":
    import argparse
    import json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="only the full tier analysis on every replan")
    ap.add_argument("--calls", type=int, default=300, help="replans per case")
    a = ap.parse_args()
    print(json.dumps(bench_full_analysis(a.calls) if a.full else bench_swing_select(a.calls), indent=2))
