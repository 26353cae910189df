"""Selection of a step path by Eq. 1 of the seed: capture-point error relative to the feet plus placement error.

score = Σ_touchdowns [ Qr Σ_legs |Δ_d - Δ|² + Qp |p_d - p|² ]

with Δ = ξ - p_leg (Eq. 2: the capture point at a touchdown relative to each leg's foothold at that moment; a
leg in the air before its first touchdown counts at that touchdown), _d the potential path, no suffix the
reference, ξ predicted by the LIP along each path (lip.py) and p the touchdown places (xy). The seed writes the
placement term unsquared; we square it so both terms are m² and the weights compare. The integral over time is
taken at the touchdowns (the seed allows either). Qr, Qp have units 1/m².
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from planning.steps.lip import (
    CopEstimate,
    StepPaths,
    batch_of,
    gather_xy,
    predict_batch,
    sort_events,
    state_omega,
)
from planning.steps.state import F64, StepPath, WalkState


@dataclass(frozen=True)
class Weights:
    """q_p: foot placement error weight Qp, 1/m². q_r: capture-point error weight Qr, 1/m²."""

    q_p: float = 1.0
    q_r: float = 1.0

    def __post_init__(self) -> None:
        for name in ("q_p", "q_r"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0.0):
                raise ValueError(f"Weights.{name}: must be finite and >= 0, got {v}")


class WeightPresets:
    """Named weight presets (the seed: accurate footing on a narrow bridge, a stable body with a fragile load)."""

    DEFAULT: ClassVar[Weights] = Weights(q_p=1.0, q_r=1.0)
    PRECISE_FOOTING: ClassVar[Weights] = Weights(q_p=10.0, q_r=0.1)
    STABLE_BODY: ClassVar[Weights] = Weights(q_p=0.1, q_r=10.0)
    NAMES: ClassVar[tuple[str, ...]] = ("default", "precise_footing", "stable_body")

    @classmethod
    def get(cls, name: str) -> Weights:
        """Returns the preset named ``name``; raises ValueError naming the choices otherwise."""
        key = str(name).lower().replace("-", "_").replace(" ", "_")
        if key not in cls.NAMES:
            raise ValueError(f"weights: unknown preset {name!r} (choices: {', '.join(cls.NAMES)})")
        return getattr(cls, key.upper())


@dataclass(frozen=True)
class SelectionParams:
    """estimate: CoP estimate for the LIP prediction ("tracking" or "cof"). tracking_fraction: -, how far the
    CoP moves toward its tracking target over a support segment. feedback_gain: -, capture-point feedback gain
    of the tracking estimate. growth_discount: -, each touchdown's capture-point error is scaled by
    exp(-growth_discount·ω·(t - t_now)) — the LIP amplifies any difference by exp(ω t), so without it (0) the
    last touchdowns drown out the first ones; 1 compares errors as their equivalent now. infeasible_penalty: score per unit of
    constraint violation (m), added only when no candidate is feasible. lazy_threshold: when set, candidates are
    scored in chunks of lazy_chunk in order and the first with a score below it is taken."""

    estimate: CopEstimate = "tracking"
    tracking_fraction: float = 1.0
    feedback_gain: float = 2.0
    growth_discount: float = 1.0
    infeasible_penalty: float = 1e3
    lazy_threshold: float | None = None
    lazy_chunk: int = 8


@dataclass(frozen=True)
class Selection:
    """The selected path and how it was chosen. scores: (N,) (nan where not evaluated lazily). xi_td: (K,2) its
    capture points at its touchdowns; xi_td_reference: (K,2) the reference's; world m."""

    path: StepPath
    score: float
    scores: F64
    index: int
    candidates: list[StepPath]
    xi_td: F64
    xi_td_reference: F64
    feasible: bool = True
    n_evaluated: int = field(default=0)


def score_components(
    candidates: list[StepPath],
    reference: StepPath,
    state: WalkState,
    omega: float | None = None,
    params: SelectionParams | None = None,
) -> tuple[F64, F64, F64, F64]:
    """Returns (placement (N,), capture (N,), xi_td (N,K,2), xi_td_reference (K,2)): the unweighted Eq. 1 sums."""
    p = params or SelectionParams()
    w = omega if omega is not None else state_omega(state, 0.5)
    batch = batch_of(candidates).with_first(reference)
    ev = sort_events(batch, state)
    pred = predict_batch(
        batch, state, w, p.estimate, p.tracking_fraction, events=ev, feedback_gain=p.feedback_gain
    )
    feet = gather_xy(ev.p_all, ev.slot_td)  # (N+1,K,4,2)
    rel = pred.xi_td[:, :, None, :] - feet  # Eq. 2
    d_rel = rel[1:] - rel[:1]
    scale = np.exp(-2.0 * p.growth_discount * w * (batch.t_td[1:] - state.t))  # on squared errors
    capture = np.einsum("nk,nkli,nkli->n", scale, d_rel, d_rel)
    d_p = batch.p_td[1:, :, :2] - batch.p_td[:1, :, :2]
    placement = np.einsum("nki,nki->n", d_p, d_p)
    return placement, capture, pred.xi_td[1:], pred.xi_td[0]


def score_paths(
    candidates: list[StepPath],
    reference: StepPath,
    state: WalkState,
    weights: Weights | None = None,
    omega: float | None = None,
    params: SelectionParams | None = None,
) -> F64:
    """Returns the Eq. 1 score (N,) of every candidate against the reference (vectorized)."""
    wt = weights or WeightPresets.DEFAULT
    p = params or SelectionParams()
    placement, capture, _, _ = score_components(candidates, reference, state, omega, p)
    return _combine(placement, capture, candidates, wt, p)


def _combine(
    placement: F64, capture: F64, candidates: list[StepPath], wt: Weights, p: SelectionParams
) -> F64:
    viol = np.array([c.violation for c in candidates])
    return wt.q_p * placement + wt.q_r * capture + p.infeasible_penalty * viol


def score_path(
    path: StepPath,
    reference: StepPath,
    state: WalkState,
    weights: Weights | None = None,
    omega: float | None = None,
    params: SelectionParams | None = None,
) -> float:
    """Returns the Eq. 1 score of one path against the reference (0 for the reference itself)."""
    return float(score_paths([path], reference, state, weights, omega, params)[0])


def select_step_path(
    reference: StepPath,
    candidates: list[StepPath],
    state: WalkState,
    weights: Weights | None = None,
    omega: float | None = None,
    params: SelectionParams | None = None,
) -> Selection:
    """Returns the candidate with the lowest score, or with lazy_threshold set the first one below it."""
    if not candidates:
        raise ValueError("candidates: need at least one potential step path")
    wt = weights or WeightPresets.DEFAULT
    p = params or SelectionParams()
    n = len(candidates)
    scores = np.full(n, np.nan)
    xi_all = np.zeros((n, reference.n_touchdowns, 2))
    xi_ref = np.zeros((reference.n_touchdowns, 2))
    chunk = n if p.lazy_threshold is None else max(1, p.lazy_chunk)
    index = -1
    evaluated = 0
    whole = batch_of(candidates)
    for start in range(0, n, chunk):
        sl = slice(start, start + chunk)
        part: list[StepPath] = candidates if chunk >= n else StepPaths(candidates[sl], whole.rows(sl))
        placement, capture, xi, xi_ref = score_components(part, reference, state, omega, p)
        s = _combine(placement, capture, part, wt, p)
        scores[start : start + len(part)] = s
        xi_all[start : start + len(part)] = xi
        evaluated += len(part)
        if p.lazy_threshold is not None:
            below = np.flatnonzero(s <= p.lazy_threshold)
            if below.size:
                index = start + int(below[0])
                break
    if index < 0:
        index = int(np.nanargmin(scores))
    return Selection(
        path=candidates[index],
        score=float(scores[index]),
        scores=scores,
        index=index,
        candidates=candidates,
        xi_td=xi_all[index],
        xi_td_reference=xi_ref,
        feasible=candidates[index].violation <= 0.0,
        n_evaluated=evaluated,
    )
