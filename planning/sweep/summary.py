"""A sweep's summary: success rate per cell with a 95 % Wilson interval, failure reasons grouped, times and errors
as percentiles, and for a repeated sweep how many draws had one outcome at every repeat; as a dict (JSON), a text
table, CSV, and the grid a heat map draws."""

from __future__ import annotations

import csv
import io
import math
import re
from collections import Counter
from typing import Any

import numpy as np

from planning.sweep.spec import DRAW, SweepSpec

Z95 = 1.959963984540054  # the normal quantile of a two-sided 95 % interval


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial rate (0, 1 when n is 0)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, c - h), min(1.0, c + h)


def pct(values: list[Any]) -> dict[str, float] | None:
    """p10, p50, p90 and max of the values (None when there are none)."""
    v = [float(x) for x in values if x is not None and math.isfinite(float(x))]
    if not v:
        return None
    a = np.asarray(v)
    return {
        "p10": round(float(np.percentile(a, 10)), 4),
        "p50": round(float(np.percentile(a, 50)), 4),
        "p90": round(float(np.percentile(a, 90)), 4),
        "max": round(float(a.max()), 4),
    }


_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def reason_group(reason: str | None) -> str:
    """A failure reason with its numbers blanked, so the same failure at other times and places groups."""
    return _NUMBER.sub("#", reason or "unknown")


def _varied(spec: SweepSpec, cases: list[dict[str, Any]]) -> list[str]:
    """The axes with more than one value among the cases, but a repeated sweep's repeat axes and draw number (a
    repeat is the same variant again: it groups only when summary.by names it)."""
    skip = {DRAW, *spec.repeat()}
    return [n for n in axis_names(cases) if n not in skip and len({_label(_ax(c, n)) for c in cases}) > 1]


def default_by(spec: SweepSpec, cases: list[dict[str, Any]]) -> list[str]:
    """The axes that make the cells unless the spec says: every axis with more than one value, but the seed (and a
    repeated sweep's repeat axes and draw number)."""
    return [n for n in _varied(spec, cases) if n != "seed"]


def axis_names(cases: list[dict[str, Any]]) -> list[str]:
    """Every axis of the cases, in order of first appearance (runs of a sweep may have axes of their own)."""
    return list(dict.fromkeys(a for c in cases for a in c["axes"]))


NO_VALUE = "—"  # a case's value on an axis its run does not have


def _ax(case: dict[str, Any], axis: str) -> Any:
    return case["axes"].get(axis, NO_VALUE)


def _label(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list):
        return "[" + ",".join(_label(x) for x in v) + "]"
    return str(v)


class _Binner:
    """Labels an axis's values: each value itself, or for a sampled numeric axis one of `bins` equal bins."""

    def __init__(self, values: list[Any], bins: int, sampled: bool) -> None:
        nums = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
        distinct = sorted(set(map(_label, values)), key=lambda s: _sort_key(s))
        self.edges: list[float] | None = None
        if sampled and len(nums) == len(values) and len(set(nums)) > bins:
            lo, hi = min(nums), max(nums)
            self.edges = list(np.linspace(lo, hi, bins + 1))
            self.labels = [f"{self.edges[i]:.3g}–{self.edges[i + 1]:.3g}" for i in range(bins)]
        else:
            self.labels = distinct

    def __call__(self, v: Any) -> str:
        if self.edges is None:
            return _label(v)
        i = int(np.searchsorted(self.edges, float(v), side="right")) - 1
        return self.labels[min(max(i, 0), len(self.labels) - 1)]


def _sort_key(s: str) -> tuple[int, float, str]:
    try:
        return (0, float(s.split("–")[0]), s)
    except ValueError:
        return (1, 0.0, s)


def _binner(spec: SweepSpec, cases: list[dict[str, Any]], axis: str) -> _Binner:
    """The labels of an axis's values as the summary groups them (a draw number is never binned)."""
    sampled = spec.sampling != "grid" and axis != DRAW
    return _Binner([_ax(c, axis) for c in cases], spec.summary.bins, sampled)


def step_totals(reports: list[dict[str, Any]], field: str) -> tuple[int, int] | None:
    """Gives a per-step count of the run reports (field: "near_misses", "near_edge_landings") and the steps, each
    summed over the reports that count it (None: none does)."""
    watched = [rep for rep in reports if rep.get(field) is not None]
    if not watched:
        return None
    return sum(int(rep[field]) for rep in watched), sum(int(rep.get("steps_taken") or 0) for rep in watched)


def _per_step_fields(reports: list[dict[str, Any]], field: str) -> dict[str, Any]:
    """The summary's fields of a per-step count (step_totals): FIELD and FIELD_per_100_steps (None: not counted)."""
    totals = step_totals(reports, field)
    count, steps = totals or (0, 0)
    return {
        field: None if totals is None else count,
        f"{field}_per_100_steps": round(100.0 * count / steps, 2) if totals and steps else None,
    }


# the per-step counts of terrain walks the summary sums (a near miss: NearMissMonitor; a near-edge landing:
# planning.terrain.crossing.edge_distance), with their columns in the table
PER_STEP_COLUMNS = (
    ("near_misses", "near misses /100 steps"),
    ("near_edge_landings", "near edges /100 steps"),
)


def _stats(recs: list[dict[str, Any] | None]) -> dict[str, Any]:
    done = [r for r in recs if r is not None and r["status"] == "done"]
    crashed = [r for r in recs if r is not None and r["status"] == "crashed"]
    reports = [r["report"] for r in done]
    ok = sum(1 for rep in reports if rep.get("success"))
    lo, hi = wilson(ok, len(done))
    reasons = Counter(reason_group(rep.get("failure_reason")) for rep in reports if not rep.get("success"))
    reasons.update(f"crashed: {reason_group((r['error'] or '').splitlines()[0])}" for r in crashed)
    pos_err = [(rep.get("final_pose_error") or {}).get("position_m") for rep in reports]
    # falls by touch by the part and what it touched, a geom's trailing index dropped (terrain_box_low_3 and
    # terrain_box_low_0 are one kind of thing to fall on)
    touched = Counter(
        f"{fc.get('part')} on {touched_kind(fc.get('touched'))}"
        for rep in reports
        if (fc := rep.get("fall_contact"))
    )
    watched = [rep for rep in reports if rep.get("near_misses") is not None]
    return {
        "cases": len(recs),
        "done": len(done),
        "crashed": len(crashed),
        "pending": sum(1 for r in recs if r is None),
        "successes": ok,
        "success_rate": round(ok / len(done), 4) if done else None,
        "ci95": [round(lo, 4), round(hi, 4)],
        "failure_reasons": dict(reasons.most_common()),
        "falls_touched": dict(touched.most_common()),
        "wall_s": pct([r["wall_s"] for r in done]),
        "simulated_s": pct([rep.get("duration_s") for rep in reports]),
        **{k: v for field, _ in PER_STEP_COLUMNS for k, v in _per_step_fields(reports, field).items()},
        "link_clearance_min_m": pct([rep.get("link_clearance_min_m") for rep in watched]),
        "time_to_goal_s": pct([rep.get("time_to_goal_s") for rep in reports]),
        "time_to_cross_s": pct([rep.get("time_to_cross_s") for rep in reports]),
        "final_position_error_m": pct(pos_err),
        "foot_placement_error_m": pct(
            [(rep.get("foot_placement_error_m") or {}).get("median") for rep in reports]
        ),
    }


def touched_kind(name: str | None) -> str:
    """A world geom's name without its trailing index ("terrain_box_low_3" -> "terrain_box_low"; None: "?")."""
    if not name:
        return "?"
    head, sep, tail = name.rpartition("_")
    return head if sep and tail.isdigit() else name


def failure_kind(rec: dict[str, Any], success: str = "report") -> str | None:
    """Gives what kind of failure a record is (None: a success under the criterion): "crashed", "fell: trunk",
    "fell: upper leg", "fell: lower leg" (a fall by touch, by the part's kind; the run report's fall_contact),
    "fell: body dropped", "no-step touchdown" or "body collision" (success "clean"), else "other"."""
    if rec.get("status") != "done":
        return "crashed"
    rep = (clean_record(rec) if success == "clean" else rec).get("report") or {}
    if rep.get("success"):
        return None
    why = str(rep.get("failure_reason") or "")
    if why.startswith("not clean:"):  # a success that clean_record failed
        return "no-step touchdown" if int(rep.get("no_step_touchdowns") or 0) else "body collision"
    fc = rep.get("fall_contact")
    if fc:
        return f"fell: {fc.get('kind') or 'touch'}"
    if "dropped" in why:
        return "fell: body dropped"
    return "fell: touch" if "touched" in why else "other"  # (reports from before fall_contact)


def clean_record(rec: dict[str, Any]) -> dict[str, Any]:
    """The record with a successful run that touched the terrain with its body or stepped into a no-step cell
    counted as a failure (summary.success: clean)."""
    rep = rec.get("report") if rec.get("status") == "done" else None
    if not rep or not rep.get("success"):
        return rec
    bodies, no_step = int(rep.get("body_collisions") or 0), int(rep.get("no_step_touchdowns") or 0)
    if not bodies and not no_step:
        return rec
    why = ", ".join(
        w for n, w in ((bodies, f"{bodies} body collisions"), (no_step, f"{no_step} no-step touchdowns")) if n
    )
    return {**rec, "report": {**rep, "success": False, "failure_reason": f"not clean: {why}"}}


def summarize(
    spec: SweepSpec, cases: list[dict[str, Any]], records: dict[str, dict[str, Any]]
) -> dict[str, Any]:
    """The summary of the cases given their records by key (a case without a record is pending)."""
    by = list(spec.summary.by) if spec.summary.by is not None else default_by(spec, cases)
    if spec.summary.success == "clean":
        records = {k: clean_record(r) for k, r in records.items()}
    names = axis_names(cases)
    for a in by:
        if a not in names:
            raise ValueError(f"summary.by: {a!r} is not an axis of this sweep (axes: {', '.join(names)})")
    binners = {a: _binner(spec, cases, a) for a in names}
    groups: dict[tuple[str, ...], dict[str, dict[str, Any] | None]] = {}  # cell → {key: record}
    for c in cases:
        k = tuple(binners[a](_ax(c, a)) for a in by)
        groups.setdefault(k, {})[c["key"]] = records.get(c["key"])
    order = sorted(groups, key=lambda k: tuple(_sort_key(s) for s in k))
    cells = [{"axes": dict(zip(by, k, strict=True)), **_stats(list(groups[k].values()))} for k in order]
    multi = _varied(spec, cases)
    two = by[:2] if len(by) >= 2 else (by + [n for n in multi if n not in by])[:2]
    heat = spec.summary.heatmap or (tuple(two) if len(two) == 2 else None)
    heatmap = None
    if heat is not None:
        for a in heat:
            if a not in names:
                raise ValueError(f"summary.heatmap: {a!r} is not an axis of this sweep")
        xa, ya = heat
        grid: dict[tuple[str, str], dict[str, dict[str, Any] | None]] = {}
        for c in cases:
            cell = grid.setdefault((binners[xa](_ax(c, xa)), binners[ya](_ax(c, ya))), {})
            cell[c["key"]] = records.get(c["key"])
        xs = sorted({k[0] for k in grid}, key=_sort_key)
        ys = sorted({k[1] for k in grid}, key=_sort_key)
        heatmap = {
            "x": xa,
            "y": ya,
            "x_labels": xs,
            "y_labels": ys,
            "successes": [[_stats(list(grid.get((x, y), {}).values()))["successes"] for x in xs] for y in ys],
            "done": [[_stats(list(grid.get((x, y), {}).values()))["done"] for x in xs] for y in ys],
        }
    out = {
        "sweep": spec.name,
        "success": spec.summary.success,
        "by": by,
        "overall": _stats([records.get(k) for k in dict.fromkeys(c["key"] for c in cases)]),
        "cells": cells,
        "heatmap": heatmap,
    }
    if spec.repeat():
        out["steady"] = steady(cases, records)
    return out


def steady(cases: list[dict[str, Any]], records: dict[str, dict[str, Any]]) -> dict[str, int]:
    """How many draws of a repeated sweep had one outcome at every repeat: "draws" (those judged: every repeat
    done), "steady" of them, "always" (success at every repeat), "never" (at none), "flipping" (draws − steady),
    and "left_out" (a repeat still pending or crashed: a crash is no outcome of the walk). records: by key, with
    the summary's success rule applied."""
    by_draw: dict[Any, list[dict[str, Any] | None]] = {}
    for c in cases:
        by_draw.setdefault(c["axes"][DRAW], []).append(records.get(c["key"]))
    always = never = flipping = left_out = 0
    for recs in by_draw.values():
        if any(r is None or r["status"] != "done" for r in recs):
            left_out += 1
            continue
        outcomes = {bool(r["report"].get("success")) for r in recs if r is not None}
        if outcomes == {True}:
            always += 1
        elif outcomes == {False}:
            never += 1
        else:
            flipping += 1
    return {
        "draws": always + never + flipping,
        "steady": always + never,
        "always": always,
        "never": never,
        "flipping": flipping,
        "left_out": left_out,
    }


def _format_steady(s: dict[str, int]) -> str:
    """The steady count as one line of text."""
    line = (
        f"steady: {s['steady']} of {s['draws']} draws have one outcome at every repeat "
        f"({s['always']} always, {s['never']} never, {s['flipping']} flip)"
    )
    if s["left_out"]:
        line += f"; {s['left_out']} draws left out (a repeat pending or crashed)"
    return line


def _ci(c: dict[str, Any]) -> str:
    return f"{c['ci95'][0] * 100:.0f}–{c['ci95'][1] * 100:.0f} %"


def _rate(c: dict[str, Any]) -> str:
    return (
        "—" if c["success_rate"] is None else f"{c['successes']}/{c['done']} {c['success_rate'] * 100:.0f} %"
    )


def format_table(summary: dict[str, Any]) -> str:
    """The summary as a text table: one row per cell, then the whole sweep and its failure reasons."""
    by = summary["by"]
    head = [*by, "success", "95 % CI", "crashed", "pos. error p50/p90 m", "wall s p50", "top failure"]
    cells = [*summary["cells"], {"axes": dict.fromkeys(by, ""), **summary["overall"]}]
    # the per-step counts some cell has, each a column after "crashed"
    counted = [(f, title) for f, title in PER_STEP_COLUMNS if any(c.get(f) is not None for c in cells)]
    head[len(by) + 3 : len(by) + 3] = [title for _, title in counted]
    rows = []
    for c in cells:
        e = c["final_position_error_m"]
        w = c["wall_s"]
        top = next(iter(c["failure_reasons"]), "")
        rows.append(
            [
                *(c["axes"][a] for a in by),
                _rate(c),
                _ci(c),
                str(c["crashed"]),
                "" if e is None else f"{e['p50']:.3f}/{e['p90']:.3f}",
                "" if w is None else f"{w['p50']:.1f}",
                top[:60],
            ]
        )
        rows[-1][len(by) + 3 : len(by) + 3] = [
            "" if (v := c.get(f"{f}_per_100_steps")) is None else f"{v:.2f} ({c[f]})" for f, _ in counted
        ]
    if by:
        rows[-1][0] = "all"
    else:
        head = head[len(by) :]
    widths = [max(len(str(r[i])) for r in [head, *rows]) for i in range(len(head))]
    lines = ["  ".join(str(v).ljust(widths[i]) for i, v in enumerate(r)).rstrip() for r in [head, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    lines.insert(len(lines) - 1, "  ".join("-" * w for w in widths))
    if summary.get("steady"):
        lines.append(_format_steady(summary["steady"]))
    reasons = summary["overall"]["failure_reasons"]
    if reasons:
        lines.append("failure reasons (numbers blanked as #):")
        lines += [f"  {n:5d}  {r}" for r, n in reasons.items()]
    touched = summary["overall"].get("falls_touched")
    if touched:
        lines.append("falls by touch, by the part and what it touched:")
        lines += [f"  {n:5d}  {r}" for r, n in touched.items()]
    if summary["overall"]["pending"]:
        lines.append(f"{summary['overall']['pending']} cases have not run yet (run the sweep again to go on)")
    return "\n".join(lines)


def cells_csv(summary: dict[str, Any]) -> str:
    """One CSV row per cell: its axes, counts, rate, interval, the top failure and percentiles."""
    by = summary["by"]
    out = io.StringIO()
    w = csv.writer(out)
    w.writerow(
        [*by, "cases", "done", "crashed", "pending", "successes", "success_rate", "ci95_low", "ci95_high"]
        + ["final_position_error_m_p50", "final_position_error_m_p90", "wall_s_p50", "top_failure_reason"]
    )
    for c in summary["cells"]:
        e = c["final_position_error_m"] or {}
        ws = c["wall_s"] or {}
        w.writerow(
            [*(c["axes"][a] for a in by), c["cases"], c["done"], c["crashed"], c["pending"], c["successes"]]
            + [c["success_rate"], c["ci95"][0], c["ci95"][1], e.get("p50"), e.get("p90"), ws.get("p50")]
            + [next(iter(c["failure_reasons"]), "")]
        )
    return out.getvalue()


def cases_csv(cases: list[dict[str, Any]], records: dict[str, dict[str, Any]]) -> str:
    """One CSV row per case: its axes, status, success, failure reason, attempts, wall time, near misses, near-edge
    landings, no-step landings, what a fall by touch met (the world geom; the run report's fall_contact) and key."""
    names = axis_names(cases)
    out = io.StringIO()
    w = csv.writer(out)
    w.writerow(
        [
            *names,
            "status",
            "success",
            "failure_reason",
            "attempts",
            "wall_s",
            "near_misses",
            "near_edge_landings",
            "no_step_touchdowns",
            "fall_touched",
            "key",
        ]
    )
    for c in cases:
        r = records.get(c["key"])
        rep = (r or {}).get("report") or {}
        w.writerow(
            [*(_label(_ax(c, a)) for a in names)]
            + [r["status"] if r else "pending", rep.get("success") if r and r["status"] == "done" else ""]
            + [rep.get("failure_reason") or (r or {}).get("error") or "", (r or {}).get("attempts", "")]
            + [
                (r or {}).get("wall_s", ""),
                "" if rep.get("near_misses") is None else rep["near_misses"],
                "" if rep.get("near_edge_landings") is None else rep["near_edge_landings"],
                "" if rep.get("no_step_touchdowns") is None else rep["no_step_touchdowns"],
                (rep.get("fall_contact") or {}).get("touched") or "",
                c["key"],
            ]
        )
    return out.getvalue()


def heatmap_cell_keys(
    spec: SweepSpec, cases: list[dict[str, Any]], x: str, y: str
) -> dict[tuple[str, str], list[str]]:
    """The case keys in each cell (x label, y label) of the heat map over axes x and y, binned as summarize() bins
    them (so the labels are the heat map's)."""
    bx, by = _binner(spec, cases, x), _binner(spec, cases, y)
    cells: dict[tuple[str, str], list[str]] = {}
    for c in cases:
        keys = cells.setdefault((bx(_ax(c, x)), by(_ax(c, y))), [])
        if c["key"] not in keys:
            keys.append(c["key"])
    return cells
