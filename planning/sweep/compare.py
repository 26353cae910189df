"""`footfall sweep --compare A B`: two sweeps' results on the same cases, paired case by case.

A change to the robot's code, or to a spec's run (a walk's speed, a duration), is judged by running the sweep before
and after it and comparing the two result directories. Cases pair by their draw: the values of the sweep's axes
(and the run's label), so a case of A and a case of B pair when they ran the same variant; the run parameters
that differ between paired cases besides the code version (e.g. `walk.speed_mps`) are listed. What counts is each
pair's outcome: the cases B gains (A failed, B
succeeded), the cases it loses, and the exact two-sided sign test over those discordant pairs (McNemar's exact
test): the chance of a split at least that lopsided if the change made no difference. On 12 draws a gain of 2 and
a loss of 0 is p = 0.5: no evidence either way.

Repeated sweeps (sampling.repeat) pair the same way, each repeat a case (its repeat value and draw number are
axes). When both sides repeated their draws, each draw's success fraction over its paired repeats is compared too:
the draws whose fraction went up, down or stayed, and the sign test over the ups and downs (the draws, unlike the
repeats of one draw, are independent).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from planning.sweep.spec import DRAW
from planning.sweep.summary import clean_record, failure_kind, reason_group, step_totals, wilson


class CompareError(ValueError):
    """A results directory that cannot be compared (absent, or holding no case results)."""


def load_results(out_dir: str | Path) -> tuple[dict[str, dict[str, Any]], str]:
    """Gives a results directory's finished case records keyed by their draw (the axes' values, JSON with sorted
    keys), and the success criterion its sweep counted ("clean" or "success"; "clean" where summary.json does not
    say)."""
    d = Path(out_dir)
    cases = d / "cases"
    if not cases.is_dir():
        raise CompareError(f"{d}: no sweep results here (no cases/ directory)")
    success = "clean"
    try:
        success = str(json.loads((d / "summary.json").read_text()).get("success", "clean"))
    except (OSError, ValueError):
        pass
    out: dict[str, dict[str, Any]] = {}
    for f in sorted(cases.glob("*.json")):
        try:
            rec = json.loads(f.read_text())
        except (OSError, ValueError):
            continue  # cut short by an interruption: not a result
        if rec.get("status") not in ("done", "crashed") or "case" not in rec:
            continue
        out[json.dumps(rec["case"].get("axes") or rec["case"]["params"], sort_keys=True)] = rec
    if not out:
        raise CompareError(f"{d}: no finished cases in {cases}")
    return out, success


def outcome(rec: dict[str, Any], success: str) -> tuple[bool, str]:
    """Gives whether a record counts as a success under the criterion, and its failure reason ("" on success)."""
    if rec.get("status") != "done":
        return False, f"crashed: {rec.get('error') or 'no report'}"
    r = clean_record(rec) if success == "clean" else rec
    rep = r["report"]
    ok = bool(rep.get("success"))
    return ok, "" if ok else str(rep.get("failure_reason") or "failed")


def sign_test_p(gains: int, losses: int) -> float:
    """Gives the exact two-sided sign test's p-value for gains against losses (McNemar's exact test on the
    discordant pairs): 1.0 with none."""
    n = gains + losses
    if n == 0:
        return 1.0
    k = min(gains, losses)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def rate_test_p(n_a: int, exposure_a: float, n_b: int, exposure_b: float) -> float:
    """Gives the exact two-sided p-value that two Poisson counts (n_a events over exposure_a, n_b over exposure_b)
    come from one rate: given their sum, B's count is binomial with B's share of the exposure (1.0 with no events
    or no exposure)."""
    n = n_a + n_b
    if n == 0 or exposure_a <= 0.0 or exposure_b <= 0.0:
        return 1.0
    q = exposure_b / (exposure_a + exposure_b)
    pmf = [math.comb(n, i) * q**i * (1.0 - q) ** (n - i) for i in range(n + 1)]
    here = pmf[n_b] * (1.0 + 1e-9)
    return min(1.0, sum(x for x in pmf if x <= here))


def _report(rec: dict[str, Any]) -> dict[str, Any]:
    """A finished record's run report ({} for a crashed one)."""
    return rec.get("report") or {} if rec.get("status") == "done" else {}


def _flat(d: Any, prefix: str = "") -> dict[str, Any]:
    if not isinstance(d, dict):
        return {prefix: d}
    out: dict[str, Any] = {}
    for k, v in d.items():
        out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def differing_params(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    """Gives the run parameters (dotted names) whose values differ between two cases' params."""
    fa, fb = _flat(a), _flat(b)
    return sorted(k for k in set(fa) | set(fb) if fa.get(k) != fb.get(k))


def _label(rec: dict[str, Any]) -> str:
    axes = rec["case"].get("axes") or {}
    parts = []
    for k, v in axes.items():
        if k == "run":
            parts.append(str(v))
            continue
        name = k.removeprefix("terrain.")
        parts.append(f"{name}={v:.4g}" if isinstance(v, float) else f"{name}={v}")
    return " ".join(parts) or rec["key"]


def _per_step(
    a: dict[str, dict[str, Any]], b: dict[str, dict[str, Any]], keys: list[str], field: str
) -> dict[str, Any] | None:
    """A per-step count (step_totals' field) on the paired walks both sides counted it on: each side's count and
    steps, and the exact test of one rate (None: no such walk)."""
    both = [k for k in keys if _report(a[k]).get(field) is not None and _report(b[k]).get(field) is not None]
    if not both:
        return None
    na = step_totals([_report(a[k]) for k in both], field) or (0, 0)
    nb = step_totals([_report(b[k]) for k in both], field) or (0, 0)
    return {
        "walks": len(both),
        "a": na[0],
        "a_steps": na[1],
        "b": nb[0],
        "b_steps": nb[1],
        "rate_test_p": round(rate_test_p(na[0], na[1], nb[0], nb[1]), 4),
    }


def compare(a_dir: str | Path, b_dir: str | Path) -> dict[str, Any]:
    """Gives the paired comparison of two results directories (see the module docstring): the counts on the
    paired cases, each side's rate with its Wilson 95 % interval, the gains, the losses, the sign test's p, the run
    parameters that differ between paired cases, and the changed cases (each with both outcomes)."""
    a, a_success = load_results(a_dir)
    b, b_success = load_results(b_dir)
    keys = [k for k in a if k in b]
    if not keys:
        hint = ""
        if _repeated(a) != _repeated(b):
            hint = "; one of them repeated its draws (sampling.repeat) and the other did not"
        raise CompareError(f"{a_dir} and {b_dir} share no draw (their sweeps' axes took other values{hint})")
    changed: list[dict[str, Any]] = []
    n_a = n_b = gains = losses = 0
    draws: dict[Any, list[int]] = {}  # a repeated sweep's draw → [A's successes, B's successes] on its pairs
    for k in keys:
        ok_a, why_a = outcome(a[k], a_success)
        ok_b, why_b = outcome(b[k], b_success)
        n_a += ok_a
        n_b += ok_b
        draw = (a[k]["case"].get("axes") or {}).get(DRAW)
        if draw is not None:  # (paired by their axes, so B's case has the same draw)
            tally = draws.setdefault(draw, [0, 0])
            tally[0] += ok_a
            tally[1] += ok_b
        if ok_a != ok_b:
            gains += ok_b
            losses += ok_a
        if ok_a != ok_b or (not ok_a and reason_group(why_a) != reason_group(why_b)):
            changed.append(
                {
                    "case": _label(b[k]),
                    "change": "gain"
                    if ok_b and not ok_a
                    else "loss"
                    if ok_a and not ok_b
                    else "other failure",
                    "a": why_a or "success",
                    "b": why_b or "success",
                }
            )
    n = len(keys)
    # near misses and near-edge landings on the paired walks both sides counted them on (terrain walks: see
    # NearMissMonitor, planning.terrain.crossing.edge_distance)
    near = _per_step(a, b, keys, "near_misses")
    edges = _per_step(a, b, keys, "near_edge_landings")
    # the kinds of failure on the paired cases, each side (failure_kind)
    kinds: dict[str, list[int]] = {}
    for k in keys:
        for side, rec, crit in ((0, a[k], a_success), (1, b[k], b_success)):
            kind = failure_kind(rec, crit)
            if kind is not None:
                kinds.setdefault(kind, [0, 0])[side] += 1
    differ = sorted(
        {d for k in keys for d in differing_params(a[k]["case"]["params"], b[k]["case"]["params"])}
    )
    return {
        "a": str(a_dir),
        "b": str(b_dir),
        "success": b_success,
        "paired": n,
        "a_only": len(a) - n,
        "b_only": len(b) - n,
        "a_successes": n_a,
        "b_successes": n_b,
        "a_ci95": [round(x, 4) for x in wilson(n_a, n)],
        "b_ci95": [round(x, 4) for x in wilson(n_b, n)],
        "gains": gains,
        "losses": losses,
        "sign_test_p": round(sign_test_p(gains, losses), 4),
        "params_differ": differ,
        "changed": changed,
        "draws": _draws(draws) if draws else None,
        "near_misses": near,
        "near_edge_landings": edges,
        "failure_kinds": {
            k: {"a": v[0], "b": v[1]} for k, v in sorted(kinds.items(), key=lambda kv: -sum(kv[1]))
        },
    }


def _repeated(results: dict[str, dict[str, Any]]) -> bool:
    """Whether a results directory's cases carry draw numbers (its sweep repeated its draws)."""
    return any(DRAW in (r["case"].get("axes") or {}) for r in results.values())


def _draws(tallies: dict[Any, list[int]]) -> dict[str, Any]:
    """The per-draw comparison of a repeated sweep: of the draws paired, those whose success fraction over their
    paired repeats went up in B, down, or stayed, and the exact sign test over the ups and downs. tallies: draw →
    [A's successes, B's successes] on the same paired repeats (so the fractions share their denominator)."""
    up = sum(1 for sa, sb in tallies.values() if sb > sa)
    down = sum(1 for sa, sb in tallies.values() if sb < sa)
    return {
        "paired": len(tallies),
        "up": up,
        "down": down,
        "same": len(tallies) - up - down,
        "sign_test_p": round(sign_test_p(up, down), 4),
    }


def format_compare(c: dict[str, Any]) -> str:
    """The comparison as text: the two rates, the gains and losses with the sign test, then the changed cases."""

    def rate(s: int, ci: list[float]) -> str:
        return f"{s}/{c['paired']} ({ci[0] * 100:.0f}–{ci[1] * 100:.0f} %)"

    lines = [
        f"paired cases: {c['paired']} (only in A: {c['a_only']}, only in B: {c['b_only']}); "
        f"success: {c['success']}",
        "the paired runs differ in: " + (", ".join(c["params_differ"]) or "nothing but the code"),
        f"A {c['a']}: {rate(c['a_successes'], c['a_ci95'])}",
        f"B {c['b']}: {rate(c['b_successes'], c['b_ci95'])}",
        f"B gains {c['gains']}, loses {c['losses']}; exact sign test on the {c['gains'] + c['losses']} changed "
        f"outcomes: p = {c['sign_test_p']:.3g}"
        + ("  (no evidence of a difference)" if c["sign_test_p"] > 0.05 else ""),
    ]
    d = c.get("draws")
    if d:
        lines.append(
            f"per draw (its success fraction over its paired repeats): B up on {d['up']}, down on {d['down']}, "
            f"the same on {d['same']} of {d['paired']} draws; exact sign test: p = {d['sign_test_p']:.3g}"
        )
    from planning.terrain.crossing import NEAR_EDGE_M, NEAR_MISS_M

    for field, what in (
        (
            "near_misses",
            f"near misses (a leg or the body within {100 * NEAR_MISS_M:g} cm of the terrain, not touching it)",
        ),
        (
            "near_edge_landings",
            f"near-edge landings (the sole within {100 * NEAR_EDGE_M:g} cm of an edge, not a no-step one)",
        ),
    ):
        nm = c.get(field)
        if not nm:
            continue

        def per(k: str, nm: dict[str, Any] = nm) -> str:
            steps = nm[f"{k}_steps"]
            return f"{nm[k]} in {steps} steps ({100.0 * nm[k] / steps:.2f} per 100)" if steps else f"{nm[k]}"

        lines.append(
            f"{what} over the {nm['walks']} "
            f"paired walks: A {per('a')}, B {per('b')}; exact test of one rate: p = {nm['rate_test_p']:.3g}"
        )
    fk = c.get("failure_kinds")
    if fk:
        lines.append(
            "failures by kind, A → B: " + ", ".join(f"{kind} {v['a']} → {v['b']}" for kind, v in fk.items())
        )
    if c["changed"]:
        lines.append("cases whose outcome changed:")
        for ch in c["changed"]:
            lines.append(f"  {ch['change']:<13} {ch['case']}")
            lines.append(f"  {'':<13}   A: {ch['a']}")
            lines.append(f"  {'':<13}   B: {ch['b']}")
    return "\n".join(lines)
