"""The swing planner's calls in a closed-loop walk, recorded once and replayed through this tree's planner.

``record FILE``: runs a headless walk (``--walk``: a trot on flat ground, or the stairs climb with the terrain
maps) for ``--duration`` s and stores every ``SwingPlanner.plan`` call: its inputs (time, swing requests, the ground
height function, stance feet, body motion), the planner's parameters at that call (a terrain mode may switch them)
and what it planned (policies, tier, five points of each leg's trajectory). ``replay FILE``: feeds the same calls,
in the same order, to one fresh planner of this tree, timing each call in this thread's CPU time, and prints the
p50/p99 per swing leg and how many selections differ from the recorded ones (and the largest trajectory difference
among those that agree). Replaying one recording through two checkouts, alternating, gives their costs side by
side on the same inputs (``PYTHONPATH=OTHER_TREE python -m benchmarks.swing_replay replay FILE``).

Run: ``python -m benchmarks.swing_replay record /tmp/sw.pkl --walk stairs --duration 6``, then
``python -m benchmarks.swing_replay replay /tmp/sw.pkl``.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import pickle
import time
from typing import Any

import numpy as np

from planning.sim.run import RunOptions, WalkCommand, WalkSession
from planning.swing import planner as swing_planner
from planning.swing.params import SwingParams

_WALKS: dict[str, tuple[WalkCommand, str]] = {
    "flat": (WalkCommand(0.8, 0.0, 0.0, "trot"), "flat"),
    "stairs": (WalkCommand(0.0, 0.0, 0.0, "trot", goal=(6.0, 0.0)), "stairs"),
    "clutter": (WalkCommand(0.0, 0.0, 0.0, "trot", goal=(6.0, 0.0)), "clutter"),
}


def _outcome(t: float, plans: dict[int, Any]) -> dict[int, tuple[Any, ...]]:
    return {
        leg: (
            p.horizontal_policy,
            p.vertical_policy,
            int(p.tier),
            p.positions(np.linspace(t, max(p.t_touchdown, t + 1e-3), 5)),
        )
        for leg, p in plans.items()
    }


def record(path: str, walk: str, duration_s: float) -> int:
    """Runs the walk, storing every plan() call with its answer; gives the count."""
    calls: list[tuple[Any, ...]] = []
    plan0 = swing_planner.SwingPlanner.plan

    def plan_rec(
        self: Any,
        t_now: float,
        legs: Any,
        ground: Any = swing_planner.flat_ground,
        stance_feet_world: Any = None,
        body: Any = None,
    ) -> Any:
        # copies: the loop passes views of arrays it later changes in place (the maps are new objects per update)
        stance = None if stance_feet_world is None else {k: np.array(v) for k, v in stance_feet_world.items()}
        reqs = [
            dataclasses.replace(
                r,
                p_world_foot=r.p_world_foot.copy(),
                v_world_foot=r.v_world_foot.copy(),
                p_touchdown=r.p_touchdown.copy(),
            )
            for r in legs
        ]
        args = (t_now, reqs, ground, stance, copy.deepcopy(body))
        out = plan0(self, *args)
        calls.append((self.params, args, _outcome(t_now, out)))
        return out

    swing_planner.SwingPlanner.plan = plan_rec  # type: ignore[method-assign]
    try:
        cmd, terrain = _WALKS[walk]
        report = WalkSession(cmd, RunOptions(terrain=terrain, duration_s=duration_s)).run(None)
    finally:
        swing_planner.SwingPlanner.plan = plan0  # type: ignore[method-assign]
    with open(path, "wb") as f:
        pickle.dump({"walk": walk, "calls": calls, "fell": report["fell"]}, f, protocol=5)
    return len(calls)


def _current(params: SwingParams, full: bool, seen: dict[int, SwingParams]) -> SwingParams:
    """The recorded parameters as this tree's SwingParams (fields added since the recording at their defaults);
    full: the event-driven selection off (the full tier analysis every replan)."""
    out = seen.get(id(params))
    if out is None:
        kept = {
            f.name: getattr(params, f.name)
            for f in dataclasses.fields(SwingParams)
            if hasattr(params, f.name)
        }
        out = SwingParams(**kept)
        if full:
            out = dataclasses.replace(out, reuse_selection_s=0.0)
        seen[id(params)] = out
    return out


def replay(path: str, repeats: int = 3, full: bool = False) -> dict[str, Any]:
    """Replays the recorded calls through a fresh planner ``repeats`` times; CPU µs per swing leg (p50, p99 over
    every call of every pass) and the selections that differ from the recorded ones (first pass). full: the full
    tier analysis every replan (SwingParams.reuse_selection_s = 0) instead of the event-driven selection."""
    from planning.robot import load_robot

    with open(path, "rb") as f:
        rec = pickle.load(f)
    seen: dict[int, SwingParams] = {}
    calls = [(_current(p, full, seen), args, want) for p, args, want in rec["calls"]]
    robot = load_robot("spot")
    per_leg: list[float] = []
    cpu_total = 0.0
    differ = total = reused = 0
    worst = 0.0
    for rep in range(repeats):
        planner = swing_planner.SwingPlanner(robot, calls[0][0])
        for params, (t, legs, ground, stance, body), want in calls:
            planner.set_params(params)
            t0 = time.thread_time()
            got = planner.plan(t, legs, ground, stance, body)
            dt = time.thread_time() - t0
            cpu_total += dt
            if legs:
                per_leg.append(dt / len(legs))
            if rep:
                continue
            reused = planner.reused
            have = _outcome(t, got)
            for leg, (h, v, tier, pos) in want.items():
                total += 1
                gh, gv, gt, gpos = have[leg]
                if (gh, gv, gt) != (h, v, tier):
                    differ += 1
                else:
                    worst = max(worst, float(np.abs(gpos - pos).max()))
    us = np.array(per_leg) * 1e6
    sim_s = max(calls[-1][1][0] - calls[0][1][0], 1e-9)
    return {
        "walk": rec["walk"],
        "calls": len(calls),
        "legs_planned": total,
        "per_leg_cpu_us_p50": round(float(np.percentile(us, 50)), 1),
        "per_leg_cpu_us_p99": round(float(np.percentile(us, 99)), 1),
        # the planner's CPU time per simulated second of the walk (mean over the passes)
        "cpu_ms_per_sim_s": round(cpu_total / repeats / sim_s * 1e3, 1),
        "selections_differ": differ,
        "reused_selections": reused,  # of legs_planned: reused without the tier analysis (first pass)
        "worst_position_diff_m": worst,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("file")
    r.add_argument("--walk", choices=sorted(_WALKS), default="stairs")
    r.add_argument("--duration", type=float, default=6.0)
    p = sub.add_parser("replay")
    p.add_argument("file")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--full", action="store_true", help="the full tier analysis every replan (no reuse)")
    a = ap.parse_args()
    if a.cmd == "record":
        print(json.dumps({"calls": record(a.file, a.walk, a.duration)}))
    else:
        print(json.dumps(replay(a.file, a.repeats, a.full)))


if __name__ == "__main__":
    main()
