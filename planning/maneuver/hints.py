"""Hints: passive maneuvers (tracks [body] only) played beside an active one.

A hint modifies the active maneuver's body targets where both drive the same thing: over the hint's span, its body
motion relative to its own start pose (height, lean, turn) is added to the active targets. Where the active
maneuver does not drive the body (tracks without ``body``) or outside the hint's span, the hint is ignored.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from planning.maneuver.body import BodyReference
from planning.maneuver.load import SHIPPED_LIBRARY, find_maneuver, load_maneuver
from planning.maneuver.problems import ManeuverError, Problem
from planning.maneuver.scale import scale_to_robot
from planning.maneuver.spec import Maneuver
from planning.robot import RobotModel


def load_hints(
    maneuver: Maneuver, robot: RobotModel, library_dirs: Sequence[str | Path] = (SHIPPED_LIBRARY,)
) -> list[tuple[float, Maneuver, BodyReference]]:
    """Returns (start time, hint maneuver, its body reference) of each hint; raises ManeuverError naming bad ones."""
    out: list[tuple[float, Maneuver, BodyReference]] = []
    problems: list[Problem] = []
    for i, h in enumerate(maneuver.hints):
        path = f"hints[{i}].maneuver"
        try:
            hm = scale_to_robot(
                load_maneuver(find_maneuver(h.maneuver, library_dirs, allow_paths=False)), robot
            )
        except ManeuverError as e:
            problems.append(
                Problem(path, e.problems[0].message if e.problems else f"cannot load {h.maneuver!r}")
            )
            continue
        if tuple(hm.tracks) != ("body",):
            problems.append(
                Problem(path, f"{h.maneuver!r} drives {list(hm.tracks)}; a hint must be passive ([body])")
            )
            continue
        if h.t + hm.duration > maneuver.duration + 1e-9:
            problems.append(
                Problem(
                    f"hints[{i}].t",
                    f"{h.maneuver!r} runs to {h.t + hm.duration:g} s, past the end at "
                    f"{maneuver.duration:g} s",
                )
            )
            continue
        out.append((h.t, hm, BodyReference.from_maneuver(hm, robot)))
    if problems:
        raise ManeuverError(problems)
    return out


class HintedBody:
    """The active body reference with the hints' motions added over their spans (same sample() as BodyReference)."""

    def __init__(
        self, base: BodyReference, hints: list[tuple[float, Maneuver, BodyReference]], active: Maneuver
    ):
        self.base = base
        self.hints = [(t0, t0 + hm.duration, ref, ref.sample(0.0)) for t0, hm, ref in hints]
        self.enabled = "body" in active.tracks

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Returns (p_world_body (3,), v (3,), rpy (3,), ω_world (3,)) at t: base plus every active hint's delta."""
        p, v, rpy, om = (np.array(a, dtype=float) for a in self.base.sample(t))
        if not self.enabled:
            return p, v, rpy, om
        for t0, t1, ref, (p0, _, rpy0, _) in self.hints:
            if t0 <= t <= t1:
                hp, hv, hrpy, hom = ref.sample(t - t0)
                p += hp - p0
                v += hv
                rpy += hrpy - rpy0
                om += hom
        return p, v, rpy, om
