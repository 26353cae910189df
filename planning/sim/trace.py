"""A walk's per-leg trace: what each leg did and what the planners asked of it, sampled through the run.

Why a walk fell on a terrain is rarely in its report alone: the report says what touched what, and the trace says
how the leg got there. Every `every_s` seconds of simulated time the trace takes one row per leg: the body's pose,
the gait, how the body faces its path (terrain walks), the leg's phase and contact, its foot, its swing plan
(touchdown target and time, the plan's tier and its horizontal and vertical policies), and on a terrain the
foothold the terrain pipeline chose for the leg's next touchdown, the steppable region under it and whether it lies
in that region's inset (where a foot's centre keeps its whole sole on the region). `footfall walk --trace FILE`
writes it as CSV (TRACE_COLUMNS; an empty cell where a value does not apply).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from planning.robot import LEGS
from planning.sim.world import RobotState

# The trace's columns, in order (lengths m, angles deg, times s; world frame).
TRACE_COLUMNS: tuple[str, ...] = (
    "t_s",
    "leg",
    "body_x",
    "body_y",
    "body_z",
    "yaw_deg",
    "pitch_deg",
    "roll_deg",
    "gait",
    "facing",
    "phase",
    "contact",
    "foot_x",
    "foot_y",
    "foot_z",
    "target_x",
    "target_y",
    "target_z",
    "touchdown_s",
    "tier",
    "horizontal_policy",
    "vertical_policy",
    "chosen_x",
    "chosen_y",
    "chosen_z",
    "region",
    "in_inset",
)

_PHASES = ("stance", "swing", "late")
# the sampling period of `--trace` unless `--trace-every` says, s
DEFAULT_TRACE_EVERY_S = 0.01
# the shortest sampling period a trace takes, s (the control loop's own tick is 2 ms)
MIN_TRACE_EVERY_S = 0.002
# the most rows a trace keeps (4 legs every 10 ms for 600 s); later samples are dropped and counted
MAX_TRACE_ROWS = 240_000


def check_trace_every(every_s: float) -> str | None:
    """Gives why a sampling period is not accepted (None: accepted)."""
    if not (math.isfinite(every_s) and every_s >= MIN_TRACE_EVERY_S):
        return f"{every_s:g} s: must be at least {MIN_TRACE_EVERY_S:g} s (the control tick)"
    return None


def trace_args_error(trace: str | None, every_s: float | None) -> str | None:
    """Gives why a command line's --trace FILE and --trace-every S (None: not given) are not accepted (None:
    accepted): a period without a file, a period below the control tick, a file in no directory."""
    if trace is None:
        return None if every_s is None else "--trace-every: only with --trace FILE"
    why = None if every_s is None else check_trace_every(every_s)
    if why is not None:
        return f"--trace-every {why}"
    parent = Path(trace).expanduser().resolve().parent
    return None if parent.is_dir() else f"--trace {trace}: no such directory {parent}"


def _r(v: float, nd: int = 4) -> float | str:
    return round(float(v), nd) if math.isfinite(float(v)) else ""


class LegTrace:
    """A monitor of the walk's loop (called with each tick's RobotState) that samples the rows described in the
    module docstring every every_s seconds. controller: the walk's controller (its handler's phases and swing plans,
    its gait); pipeline: the terrain pipeline (None on flat ground or walking blind)."""

    def __init__(self, controller: Any, pipeline: Any, every_s: float = DEFAULT_TRACE_EVERY_S) -> None:
        why = check_trace_every(every_s)
        if why is not None:
            raise ValueError(f"LegTrace: every_s {why}")
        self.controller = controller
        self.pipeline = pipeline
        self.every_s = float(every_s)
        self.rows: list[tuple[Any, ...]] = []
        self.dropped = 0
        self._next_t = -math.inf

    def __call__(self, s: RobotState) -> None:
        if s.t + 1e-9 < self._next_t:
            return
        self._next_t = s.t + self.every_s
        if len(self.rows) + 4 > MAX_TRACE_ROWS:
            self.dropped += 4
            return
        R = s.R_world_body
        yaw = math.degrees(math.atan2(R[1, 0], R[0, 0]))
        pitch = math.degrees(-math.asin(max(-1.0, min(1.0, float(R[2, 0])))))
        roll = math.degrees(math.atan2(R[2, 1], R[2, 2]))
        body = (*(_r(v) for v in s.p_world_body), _r(yaw, 2), _r(pitch, 2), _r(roll, 2))
        h = self.controller.handler
        pl = self.pipeline
        facing = getattr(pl, "facing", "") if pl is not None else ""
        last = getattr(pl, "last", None) if pl is not None else None
        world = getattr(pl, "world", None) if pl is not None else None
        regions = getattr(world, "regions", None) if world is not None else None
        gait = getattr(self.controller, "gait", "")
        for leg, name in enumerate(LEGS):
            phase = int(h.phase[leg])
            plan = h.plans.get(leg) if phase != 0 else None
            if plan is not None:
                target: tuple[Any, ...] = (
                    *(_r(v) for v in plan.p_touchdown),
                    _r(plan.t_touchdown),
                    plan.tier.name,
                    plan.horizontal_policy,
                    plan.vertical_policy,
                )
            else:
                target = ("",) * 7
            chosen: tuple[Any, ...] = ("",) * 5
            if last is not None:
                pc = np.asarray(last.memory.p_chosen[leg], dtype=np.float64)
                if np.all(np.isfinite(pc)):
                    label: int | str = ""
                    inset: int | str = ""
                    if regions is not None:
                        res = regions.resolution_m
                        ox, oy = regions.origin_xy
                        i = int(round((float(pc[0]) - ox) / res))
                        j = int(round((float(pc[1]) - oy) / res))
                        if 0 <= i < regions.labels.shape[0] and 0 <= j < regions.labels.shape[1]:
                            label, inset = int(regions.labels[i, j]), int(bool(regions.inset[i, j]))
                    chosen = (*(_r(v) for v in pc), label, inset)
            self.rows.append(
                (
                    _r(s.t),
                    name,
                    *body,
                    gait,
                    facing,
                    _PHASES[phase] if 0 <= phase < len(_PHASES) else str(phase),
                    int(bool(s.contact[leg])),
                    *(_r(v) for v in s.p_world_foot[leg]),
                    *target,
                    *chosen,
                )
            )

    def write_csv(self, path: str | Path) -> Path:
        """Writes the rows as CSV with a header (TRACE_COLUMNS); gives the path."""
        out = Path(path)
        with out.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(TRACE_COLUMNS)
            w.writerows(self.rows)
        return out
