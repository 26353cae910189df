"""Closed-loop terrain outcomes as rates over a family of variants, never one seed.

A terrain walk's outcome is chaotic: a last-bit floating-point difference between CPUs or library versions flips
which variants of a family cross (issue 26). So a crossing test runs several variants and asserts how many cross
clean, with the measured count and the bound in its docstring; what fails is printed per variant.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from planning.sim.run import RunOptions, WalkCommand, run_walk


def clean_crossing(r: dict[str, Any], max_no_step: int) -> str | None:
    """Gives None for a clean crossing (no fall, no body collision, crossed, goal reached, at most `max_no_step`
    landings in a no-step place), else what went wrong."""
    if r["fell"]:
        return str(r["failure_reason"])
    if r["body_collisions"]:
        return f"{r['body_collisions']} body collisions"
    if not (r["crossed"] and r["success"]):
        return f"not crossed: {r['failure_reason']}"
    if r["no_step_touchdowns"] > max_no_step:
        return f"{r['no_step_touchdowns']} no-step touchdowns (at most {max_no_step})"
    return None


def crossings(
    variants: Sequence[tuple[str, WalkCommand, RunOptions]], max_no_step: int
) -> tuple[int, dict[str, str | None], list[dict[str, Any]]]:
    """Runs each (label, command, options) and gives how many crossed clean, each variant's failure (None: clean)
    and the reports."""
    outcome: dict[str, str | None] = {}
    reports = []
    for label, cmd, opts in variants:
        r = run_walk(cmd, opts)
        reports.append(r)
        outcome[label] = clean_crossing(r, max_no_step)
        print(f"{label}: {'crossed clean' if outcome[label] is None else outcome[label]}")
    return sum(v is None for v in outcome.values()), outcome, reports
