"""Closed-loop terrain outcomes as rates over a family of variants, never one seed.

A terrain walk's outcome is chaotic: a last-bit floating-point difference between CPUs or library versions flips
which variants of a family cross (issue 26). So a crossing test runs several variants and asserts how many cross
clean, with the measured count and the bound in its docstring; what fails is printed per variant.

A rate test stops as soon as its verdict is decided (`decided`): once `needed` variants have crossed clean, or once
too few are left to reach `needed`. The variants left then could not change the assertion, and the suite's time goes
to walks that can. They are printed as not run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from planning.sim.run import NEAR_MISS_EVENTS, RunOptions, WalkCommand, run_walk
from planning.terrain.crossing import NEAR_MISS_M

T = TypeVar("T")


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


def near_misses_listed(r: dict[str, Any]) -> None:
    """Asserts that a terrain walk's report lists its near misses (a leg or the body within NEAR_MISS_M of the
    terrain, not touching it) as it counts them: the first NEAR_MISS_EVENTS, each closer than NEAR_MISS_M, the
    closest no farther than the run's least clearance."""
    events = r["near_miss_events"]
    assert len(events) == min(r["near_misses"], NEAR_MISS_EVENTS), r["near_misses"]
    assert all(0.0 < e["gap_m"] < NEAR_MISS_M and e["part"] for e in events), events
    if events:
        assert r["link_clearance_min_m"] <= min(e["gap_m"] for e in events)
        assert r["near_misses_per_100_steps"] > 0.0


def decided(passed: int, done: int, total: int, needed: int) -> bool:
    """Whether "at least `needed` of `total` pass" is already settled after `done` runs of which `passed` passed."""
    return passed >= needed or passed + (total - done) < needed


def until_decided(items: Sequence[T], needed: int | None) -> Iterator[tuple[T, Callable[[bool], None]]]:
    """Yields (item, record) for each item in order until the rate "at least `needed` of them pass" is decided
    (None: every item); the caller runs the item and calls record(passed). The items left are printed as not run."""
    passed = done = 0

    def record(ok: bool) -> None:
        nonlocal passed, done
        passed += int(ok)
        done += 1

    for i, item in enumerate(items):
        if needed is not None and decided(passed, i, len(items), needed):
            print(f"{len(items) - i} variant(s) not run: {passed} of {i} passed, at least {needed} needed")
            return
        n = done
        yield item, record
        assert done == n + 1, "until_decided: record(passed) was not called once for the item"


def crossings(
    variants: Sequence[tuple[str, WalkCommand, RunOptions]],
    max_no_step: int,
    needed: int | None = None,
    check: Callable[[dict[str, Any]], str | None] | None = None,
) -> tuple[int, dict[str, str | None], list[dict[str, Any]]]:
    """Runs each (label, command, options) and gives how many crossed clean, each variant's failure (None: clean)
    and the reports; with `needed`, only until "at least `needed` cross clean" is decided (until_decided); `check`
    (a report -> what else went wrong, or None) is asked of each clean crossing too."""
    outcome: dict[str, str | None] = {}
    reports = []
    for (label, cmd, opts), record in until_decided(variants, needed):
        r = run_walk(cmd, opts)
        reports.append(r)
        near_misses_listed(r)
        outcome[label] = clean_crossing(r, max_no_step)
        if outcome[label] is None and check is not None:
            outcome[label] = check(r)
        print(f"{label}: {'crossed clean' if outcome[label] is None else outcome[label]}")
        record(outcome[label] is None)
    return sum(v is None for v in outcome.values()), outcome, reports
