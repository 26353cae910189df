"""The `speed` stage of `footfall bench`: top speeds per gait and direction on flat ground.

One run per gait and direction: the command is ramped in levels (held ``hold_s`` each, the velocity measured over
its last ``measure_s``) until the robot falls or its mean velocity misses the command by more than
``max_error_frac``; the top speed is the last level it held. Commands go through the planner's filter (its
smoothing and acceleration limits, as the joystick's do) with its speed limits lifted (UNLIMITED): the ramp finds
what the robot can do, not what the joystick allows (trot 1.6 m/s forward, 0.6 m/s sideways, 1.2 rad/s).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

#: Spot's published top speed (Boston Dynamics' specification): forward, m/s.
SPOT_PUBLISHED = {"forward": 1.6}

GAITS = ("trot", "pace", "bound", "gallop", "walk")

#: The steering limits during a ramp: above anything the robot reaches (m/s, rad/s), gaits' own limits off.
UNLIMITED = {"max_vx_mps": 5.0, "max_vy_mps": 3.0, "max_yaw_rate_rps": 5.0, "gait_limits": False}


@dataclass(frozen=True)
class Direction:
    """A direction to ramp: which command axis (0 vx, 1 vy, 2 yaw rate), its unit and its levels."""

    name: str
    axis: int
    unit: str
    start: float
    step: float
    stop: float

    def levels(self) -> list[float]:
        n = int(math.floor((self.stop - self.start) / self.step + 1e-9)) + 1
        return [round(self.start + k * self.step, 6) for k in range(n)]


DIRECTIONS = (
    Direction("forward", 0, "m/s", 0.4, 0.2, 3.2),
    Direction("sideways", 1, "m/s", 0.2, 0.1, 1.4),
    Direction("turning", 2, "rad/s", 0.5, 0.25, 3.0),
)


@dataclass(frozen=True)
class RampResult:
    """The top speed held (None: not even the first level) and why the ramp stopped at the next level."""

    gait: str
    direction: str
    unit: str
    top: float | None
    stopped_by: str  # "fall", "tracking" or "end of ramp"
    at: float | None  # the level that stopped it
    mean_at_stop: float | None  # the mean velocity measured at that level (None after a fall)
    levels: list[tuple[float, float]]  # (command, mean measured) per level held
    centroidal: bool
    sim_s: float
    # per level held: the fraction of its measured time with no foot on the ground (the gait's flight phases)
    flight: list[float] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "top": self.top,
            "unit": self.unit,
            "stopped_by": self.stopped_by,
            "at": self.at,
            "mean_at_stop": self.mean_at_stop,
            "levels": [[c, round(m, 4)] for c, m in self.levels],
            "flight_fraction": [round(f, 4) for f in self.flight],
            "solver": "centroidal" if self.centroidal else "balance",
            "sim_s": round(self.sim_s, 2),
        }


def ramp(
    gait: str,
    direction: Direction,
    hold_s: float = 3.0,
    measure_s: float = 1.5,
    max_error_frac: float = 0.10,
    centroidal: bool = False,
    levels: list[float] | None = None,
    setup: Callable[[Any], None] | None = None,
) -> RampResult:
    """Ramps one command axis through its levels in one run; returns the top level held. setup(session), when
    given, may change the session's controller before the ramp starts (for experiments)."""
    from planning.sim.run import RunOptions, WalkCommand, WalkSession

    if not 0.0 < measure_s <= hold_s:
        raise ValueError(f"ramp: measure_s must be in (0, hold_s], got {measure_s} (hold_s {hold_s})")
    sess = WalkSession(WalkCommand(gait=gait, centroidal=centroidal), RunOptions(duration_s=1e9))
    # what the robot can do, not what the joystick allows: the steering limits (and each gait's own) lifted
    steering = sess.controller.planner.steering
    steering.params = replace(steering.params, **UNLIMITED)
    if setup is not None:
        setup(sess)
    rec = sess.recorder
    held: list[tuple[float, float]] = []
    flight: list[float] = []
    top: float | None = None
    stopped_by, at, mean_at = "end of ramp", None, None
    for level in levels if levels is not None else direction.levels():
        cmd = [0.0, 0.0, 0.0]
        cmd[direction.axis] = level
        sess.controller.steer(*cmd)
        sess.loop.run(hold_s - measure_s)
        t_measure = sess.world.t
        if not sess.loop.fell:
            sess.loop.run(measure_s)
        if sess.loop.fell:
            stopped_by, at = "fall", level
            break
        t = np.asarray(rec.t)
        keep = t >= t[-1] - measure_s
        if direction.axis < 2:
            mean = float(np.mean([rec.v_body[k][direction.axis] for k in np.flatnonzero(keep)]))
        else:
            mean = float(np.mean(np.asarray(rec.yaw_rate)[keep]))
        if abs(mean - level) > max_error_frac * abs(level):
            stopped_by, at, mean_at = "tracking", level, mean
            break
        held.append((level, mean))
        flight.append(rec.flight_fraction(t_measure) or 0.0)
        top = level
    return RampResult(
        gait,
        direction.name,
        direction.unit,
        top,
        stopped_by,
        at,
        mean_at,
        held,
        centroidal,
        sess.world.t,
        flight,
    )


#: The steered family at a speed: straight, small yaw rates both ways, a larger one, and straight from a start turned
#: by 0.3 rad (MuJoCo's pyramidal friction cone is not isotropic, so that walk differs physically): (yaw rate rad/s,
#: start yaw rad).
STEERED_FAMILY = ((0.0, 0.0), (0.2, 0.0), (-0.2, 0.0), (0.4, 0.0), (0.0, 0.3))


def steered_family(
    gait: str,
    vx: float,
    family: tuple[tuple[float, float], ...] = STEERED_FAMILY,
    duration_s: float = 6.0,
    settle_s: float = 3.5,
) -> list[dict[str, Any]]:
    """Walks the gait from a stand at vx with each (yaw rate, start yaw) of the family (the joystick's limits
    lifted, as in the ramps); returns per walk whether it fell and its mean forward speed after settle_s."""
    from planning.sim.run import RunOptions, WalkCommand, WalkSession

    if not 0.0 <= settle_s < duration_s:
        raise ValueError(
            f"steered_family: settle_s must be in [0, duration_s), got {settle_s} ({duration_s})"
        )
    out = []
    for yaw_rate, start_yaw in family:
        sess = WalkSession(
            WalkCommand(vx, 0.0, yaw_rate, gait=gait),
            RunOptions(duration_s=duration_s, start_offset=(0.0, 0.0, start_yaw)),
        )
        steering = sess.controller.planner.steering
        steering.params = replace(steering.params, **UNLIMITED)
        sess.loop.run(settle_s)
        n0 = len(sess.recorder.t)
        if not sess.loop.fell:
            sess.loop.run(duration_s - settle_s)
        fell = sess.loop.fell
        v = None if fell else float(np.mean([vb[0] for vb in sess.recorder.v_body[n0:]]))
        w = None if fell else float(np.mean(sess.recorder.yaw_rate[n0:]))
        out.append(
            {"yaw_rate": yaw_rate, "start_yaw": start_yaw, "fell": fell, "mean_vx": v, "mean_yaw_rate": w}
        )
    return out


def bench_speed(
    gaits: tuple[str, ...] = GAITS,
    directions: tuple[Direction, ...] = DIRECTIONS,
    centroidal: bool = False,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Returns {gait: {direction: ramp result}} and Spot's published figures beside them."""
    out: dict[str, Any] = {}
    for g in gaits:
        out[g] = {}
        for d in directions:
            if progress is not None:
                progress(f"bench: speed, {g} {d.name}")
            out[g][d.name] = ramp(g, d, centroidal=centroidal).as_dict()
    return {
        "by_gait": out,
        "spot_published": dict(SPOT_PUBLISHED),
        "criterion": "fall or > 10 % tracking error",
    }


def format_speed_table(result: dict[str, Any]) -> str:
    """The top speeds as a Markdown table, Spot's published figures beside them; when the forward ramps measured
    it, a last column gives the fraction of time with no foot on the ground at each gait's top forward speed."""
    by_gait = result["by_gait"]
    dirs = [d.name for d in DIRECTIONS if any(d.name in v for v in by_gait.values())]
    units = {d.name: d.unit for d in DIRECTIONS}
    with_flight = any(row.get("forward", {}).get("flight_fraction") is not None for row in by_gait.values())
    lines = [
        "| gait | "
        + " | ".join(f"{d} ({units[d]})" for d in dirs)
        + (" | flight at top forward (% of time) |" if with_flight else " |"),
        "| --- |" + " --- |" * (len(dirs) + with_flight),
    ]
    for g, row in by_gait.items():
        cells = []
        for d in dirs:
            r = row.get(d)
            if r is None:
                cells.append("")
                continue
            top = "–" if r["top"] is None else f"{r['top']:g}"
            why = {"fall": "falls", "tracking": "tracks > 10 % off", "end of ramp": "ramp ended"}[
                r["stopped_by"]
            ]
            cells.append(top if r["at"] is None else f"{top} ({r['at']:g} {why})")
        if with_flight:
            fl = row.get("forward", {}).get("flight_fraction") or []
            cells.append(f"{100 * fl[-1]:.1f}" if fl else "–")
        lines.append(f"| {g} | " + " | ".join(cells) + " |")
    spot = result.get("spot_published", {})
    lines.append(
        "| Spot (published) | "
        + " | ".join(f"{spot[d]:g}" if d in spot else "–" for d in dirs)
        + (" | – |" if with_flight else " |")
    )
    return "\n".join(lines)


if __name__ == "__main__":
    import json
    import sys

    if len(sys.argv) == 4 and sys.argv[1] == "--family":  # python -m benchmarks.speed --family GAIT VX
        for row in steered_family(sys.argv[2], float(sys.argv[3])):
            print(json.dumps(row))
        sys.exit(0)
    res = bench_speed(progress=lambda m: print(m, file=sys.stderr))
    print(json.dumps(res, indent=2))
    print(format_speed_table(res))
