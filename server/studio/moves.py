"""A move's natural parameters, and the move rescaled to new values: a pure function on its document.

A move (maneuvers/moves/*.yaml) is a small maneuver; what a choreographer sets when inserting one is read off what it
does rather than declared:

- **angle** (degrees): how far its trot segments turn in all (cycles × dyaw) plus the yaw its last keyframe holds
  (`turn-left-45`: 45);
- **distance** (m): how far its trot segments carry the body (cycles × the step's length: `trot-forward`: 0.32);
- **amount** (× its own size, 1 as written): how far its keyframes lean, tilt, look and dip away from the standing
  pose (`bow` at 1.5 bows 27° instead of 18°).

`scale_move` writes new values into the events, gaits and keyframes. A gait segment keeps its per-cycle step within
what a trot carries out (MAX_TURN_PER_CYCLE_DEG, MAX_STEP_PER_CYCLE_M): past that it takes more cycles, and what
follows it in the move moves later by the added time (the move grows). Count (back-to-back repeats) stays the
editor's "repeat".
"""

from __future__ import annotations

import copy
import math
from typing import Any

MAX_TURN_PER_CYCLE_DEG = (
    22.5  # a trot cycle turns at most this much when a move is scaled (the shipped spin: 22.5)
)
MAX_STEP_PER_CYCLE_M = 0.12  # ... and steps at most this far (walk-forward: 0.10)
MAX_AMOUNT = 2.0  # a keyframe's lean, tilt and dip at most doubled
MAX_ANGLE_DEG = 360.0
MAX_DISTANCE_M = 3.0


def _cycles(g: dict[str, Any]) -> int:
    return max(1, round((float(g["to"]) - float(g["from"])) / float(g["cycle"])))


def natural_params(doc: dict[str, Any]) -> dict[str, float]:
    """Returns the parameters a move has, at the values it is written with: "angle" and "distance" when it turns or
    travels, "amount" (1.0) when its keyframes move the body away from the standing pose."""
    out: dict[str, float] = {}
    turn = dist = 0.0
    for g in doc.get("gaits") or []:
        step = list(g.get("step") or (0.0, 0.0, 0.0))
        n = _cycles(g)
        turn += n * float(step[2])
        dist += n * math.hypot(float(step[0]), float(step[1]))
    body = doc.get("body") or []
    if body:
        turn += float((body[-1].get("rpy") or (0.0, 0.0, 0.0))[2])
    if abs(turn) > 1e-9:
        out["angle"] = round(turn, 4)
    if dist > 1e-9:
        out["distance"] = round(dist, 4)
    if body and any(_deviates(k, body[-1]) for k in body):
        out["amount"] = 1.0
    return out


def _deviates(kf: dict[str, Any], last: dict[str, Any]) -> bool:
    """Whether a keyframe leans, tilts, looks or dips away from the move's final (standing) pose."""
    rpy = kf.get("rpy") or (0.0, 0.0, 0.0)
    end_rpy = last.get("rpy") or (0.0, 0.0, 0.0)
    p = kf.get("position") or (0.0, 0.0, 0.0)
    end_p = last.get("position") or (0.0, 0.0, 0.0)
    return any(abs(float(a) - float(b)) > 1e-9 for a, b in zip([*p, *rpy], [*end_p, *end_rpy], strict=True))


def scale_move(
    doc: dict[str, Any],
    *,
    standing_height_m: float,
    angle: float | None = None,
    distance: float | None = None,
    amount: float | None = None,
) -> dict[str, Any]:
    """Returns a copy of a move's document with its natural parameters set to new values (None: as written).
    ValueError naming the parameter when the move does not have it or the value is out of range."""
    nat = natural_params(doc)
    out = copy.deepcopy(doc)
    for name, value, hi in (("angle", angle, MAX_ANGLE_DEG), ("distance", distance, MAX_DISTANCE_M),
                            ("amount", amount, MAX_AMOUNT)):  # fmt: skip
        if value is None:
            continue
        if name not in nat:
            have = ", ".join(nat) or "none"
            raise ValueError(f"{name}: the move {doc.get('name')!r} has no {name} to set (it has: {have})")
        if not math.isfinite(value) or abs(value) > hi or (name != "angle" and value < 0):
            lo = -hi if name == "angle" else 0
            raise ValueError(f"{name}: must be between {lo:g} and {hi:g}, got {value:g}")
    turn_k = angle / nat["angle"] if angle is not None else 1.0
    dist_k = distance / nat["distance"] if distance is not None else 1.0
    if amount is not None:
        h = float(standing_height_m)
        for kf in out.get("body") or []:
            p = [float(v) for v in kf.get("position", (0.0, 0.0, h))]
            kf["position"] = [_r(p[0] * amount), _r(p[1] * amount), _r(h + (p[2] - h) * amount)]
            rpy = [float(v) for v in kf.get("rpy") or (0.0, 0.0, 0.0)]
            # yaw is a look (back to 0 at the end) unless the move turns: then it is the angle's
            yaw = rpy[2] if "angle" in nat else _r(rpy[2] * amount)
            kf["rpy"] = [_r(rpy[0] * amount), _r(rpy[1] * amount), yaw]
    for kf in out.get("body") or []:
        if turn_k != 1.0 and kf.get("rpy") is not None:
            kf["rpy"] = [kf["rpy"][0], kf["rpy"][1], _r(float(kf["rpy"][2]) * turn_k)]
        if dist_k != 1.0 and kf.get("position") is not None:
            p = kf["position"]
            kf["position"] = [_r(float(p[0]) * dist_k), _r(float(p[1]) * dist_k), p[2]]
    for ev in out.get("events") or []:
        if dist_k != 1.0 and ev.get("offset") is not None:
            ev["offset"] = [_r(float(v) * dist_k) for v in ev["offset"]]
    # the gaits, each kept within what a trot cycle carries out (more cycles when needed; what follows moves later)
    for i, g in enumerate(out.get("gaits") or []):
        step = [float(v) for v in g.get("step") or (0.0, 0.0, 0.0)]
        n = _cycles(g)
        total = [step[0] * n * dist_k, step[1] * n * dist_k, step[2] * n * turn_k]
        need = max(
            math.ceil(math.hypot(total[0], total[1]) / MAX_STEP_PER_CYCLE_M - 1e-9),
            math.ceil(abs(total[2]) / MAX_TURN_PER_CYCLE_DEG - 1e-9),
            n,
        )
        g["step"] = [_r(total[0] / need), _r(total[1] / need), _r(total[2] / need)]
        if need > n:
            added = (need - n) * float(g["cycle"])
            end = float(g["to"])
            g["to"] = _r(end + added)
            _shift_after(out, end, added, skip_gait=i)
    return out


def _shift_after(doc: dict[str, Any], t_end: float, dt: float, skip_gait: int) -> None:
    """Moves everything of the move at or after t_end (s) later by dt, and the move's end with it."""
    for ev in doc.get("events") or []:
        if float(ev["t"]) >= t_end - 1e-9:
            ev["t"] = _r(float(ev["t"]) + dt)
    for kf in doc.get("body") or []:
        if float(kf["t"]) >= t_end - 1e-9:
            kf["t"] = _r(float(kf["t"]) + dt)
    for j, g in enumerate(doc.get("gaits") or []):
        if j != skip_gait and float(g["from"]) >= t_end - 1e-9:
            g["from"], g["to"] = _r(float(g["from"]) + dt), _r(float(g["to"]) + dt)
    doc["duration"] = _r(float(doc.get("duration") or 0.0) + dt)


def _r(v: float, nd: int = 4) -> float:
    return round(float(v), nd)
