"""The regions climb's foothold decisions, recorded once and replayed through this tree's code call by call.

``record FILE``: runs ``footfall walk --terrain stairs --goal 6,0`` headless for
``--duration`` s and stores every ``decide`` and ``choose_footholds`` call of the terrain pipeline (their inputs and
what they gave). ``replay FILE``: feeds the same inputs, in the same order, to this tree's functions (a fresh step
QP, which then sees the same warm starts; the polygon cache emptied with each new map, as the pipeline does) and
prints each function's CPU time per call in this thread (p50, mean, total) and the largest difference from the
recorded answers (footholds and their largest shift and mean setback in m, the step QP's footholds, the commands). Replaying one recording through two checkouts, alternating, gives
their costs side by side on the same inputs (``PYTHONPATH=OTHER_TREE python -m benchmarks.footholds_replay replay
FILE``), and whether the new code decides the same.

Run: ``python -m benchmarks.footholds_replay record /tmp/fh.pkl --duration 10`` (``--terrain clutter``: the same walk
there), then ``... replay /tmp/fh.pkl``.
"""

from __future__ import annotations

import argparse
import json
import pickle
import time
from typing import Any

import numpy as np

import planning.terrain.decision as decision
from benchmarks.loop_profile import _WALKS
from planning.sim.run import RunOptions, WalkSession


def _decide_out(d: Any) -> tuple[Any, ...]:
    c = d.command
    return (
        np.array([c.vx, c.vy, c.yaw_rate], dtype=np.float64),
        d.gait,
        d.body_height_m,
        d.body_pitch_rad,
        d.speed_cap_mps,
    )


def record(path: str, duration_s: float, terrain: str = "stairs") -> int:
    """Runs the regions climb (or the same walk on another terrain, its goal 6 m ahead), storing every decide /
    choose_footholds call with its answer; gives the count."""
    calls: list[tuple[Any, ...]] = []
    decide0, choose0 = decision.decide, decision.choose_footholds
    qp_params: list[Any] = []

    def decide_rec(view: Any, world: Any, last: Any, params: Any) -> Any:
        d = decide0(view, world, last, params)
        calls.append(("decide", (view, world, last, params), _decide_out(d)))
        return d

    def choose_rec(
        view: Any, path_: Any, world: Any, memory: Any, qp: Any, params: Any, cache: Any = None
    ) -> Any:
        if not qp_params:
            qp_params.append(qp.params)
        d = choose0(view, path_, world, memory, qp, params, cache)
        plan = None if d.plan is None else d.plan.footholds.copy()
        out = (d.p_world_touchdown.copy(), plan, np.array([d.max_shift_m, d.back_m]))
        calls.append(("footholds", (view, path_, world, memory, params), out))
        return d

    decision.decide, decision.choose_footholds = decide_rec, choose_rec  # type: ignore[assignment]
    try:
        cmd, _, _ = _WALKS["stairs"]
        report = WalkSession(cmd, RunOptions(terrain=terrain, duration_s=duration_s)).run(None)
    finally:
        decision.decide, decision.choose_footholds = decide0, choose0  # type: ignore[assignment]
    with open(path, "wb") as f:
        pickle.dump({"qp_params": qp_params[0], "calls": calls, "fell": report["fell"]}, f, protocol=5)
    return len(calls)


def _diff(a: Any, b: Any) -> float:
    if a is None or b is None:
        return 0.0 if a is None and b is None else np.inf
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return np.inf
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    return 0.0 if bool(np.all(same)) else float(np.nanmax(np.abs(a - b)))


def replay(path: str, repeat: int = 1) -> dict[str, Any]:
    """Replays a recording through this tree's decide and choose_footholds; CPU µs per call and differences."""
    with open(path, "rb") as f:
        rec = pickle.load(f)
    cpu: dict[str, list[float]] = {"decide": [], "footholds": []}
    worst = {"decide": 0.0, "footholds": 0.0, "plan": 0.0}
    mismatched = {"decide": 0, "footholds": 0}
    for rep in range(repeat):
        qp = decision.StepQP(rec["qp_params"])
        cache: dict[Any, Any] = {}
        regions = None
        for kind, args, out in rec["calls"]:
            if kind == "decide":
                c0 = time.thread_time()
                d = decision.decide(*args)
                cpu[kind].append(time.thread_time() - c0)
                got = _decide_out(d)
                dv = _diff(got[0], out[0])
                dv = max(dv, max(abs(float(x) - float(y)) for x, y in zip(got[2:], out[2:], strict=True)))
                if got[1] != out[1]:
                    dv = np.inf
            else:
                view, path_, world, memory, params = args
                if world.regions is not regions:
                    regions, cache = world.regions, {}
                c0 = time.thread_time()
                fd = decision.choose_footholds(view, path_, world, memory, qp, params, cache)
                cpu[kind].append(time.thread_time() - c0)
                plan = None if fd.plan is None else fd.plan.footholds
                worst["plan"] = max(worst["plan"], _diff(plan, out[1]))
                dv = max(_diff(fd.p_world_touchdown, out[0]), _diff([fd.max_shift_m, fd.back_m], out[2]))
            if rep == 0:
                worst[kind] = max(worst[kind], dv)
                mismatched[kind] += dv > 0.0
    return {
        **{
            f"{k}_us": {
                "p50": round(1e6 * float(np.median(v)), 1),
                "mean": round(1e6 * float(np.mean(v)), 1),
                "total_ms": round(1e3 * float(np.sum(v)) / repeat, 1),
                "calls": len(v) // repeat,
            }
            for k, v in cpu.items()
        },
        "max_difference": worst,
        "calls_differing": mismatched,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("record", "replay"))
    ap.add_argument("file")
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--terrain", default="stairs", help="record: the terrain walked (default stairs)")
    a = ap.parse_args()
    if a.mode == "record":
        print(json.dumps({"calls": record(a.file, a.duration, a.terrain)}))
    else:
        print(json.dumps(replay(a.file, a.repeat), indent=1))


if __name__ == "__main__":
    main()
