"""Static balance for the slow gaits: the body shifted into the coming support triangle before a leg lifts.

In a gait with three feet down most of the time (a crawl), the ground projection of the centre of mass has to lie
inside the triangle of the three legs that stay down while the fourth swings, or the body tips over the edge of that
triangle (the diagonal of a lateral-sequence crawl). These are pure functions over feet positions (world xy) and the
contact plan: which leg lifts next and when, which leg (if any) swings now. They return where the centre of mass
should be (xy); the walk controller turns that into the balance target's position.

The shift is the smallest move that puts the point inside the triangle shrunk toward its incentre (a homothety, so
the margin scales with the triangle's inradius and no robot dimension enters here); a point already inside with that
margin is not moved, so the forward motion is left alone where the support allows it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planning.steps.state import F64, N_LEGS, B


@dataclass(frozen=True)
class SupportShiftParams:
    """Static balance in the slow gaits: the gaits with a duty factor of at least min_duty (-; 0.8: the crawl, not
    the walk at 0.75) get the liftoff hold and the body shift when they are on. Both are off.

    hold (off): a due liftoff waits, at most max_hold_s (s) from when it fell due, while the centre of mass is not
    inside the triangle of the three feet that stay down (shrunk by hold_margin_fraction, -) or while one of those
    feet is not loaded (the ground does not push it: a foot just landed on nothing, or unloaded). Without it the
    stones family's crawl falls when a front foot lifts with the centre of mass on its side of the diagonal: the
    hind foot opposite unloads and slides off its stone. On, the stones family crossed clean 42 of 50 against 38
    (falls 7 -> 3), but the clutter family 20 against 29: a held liftoff keeps its touchdown time, so the swing
    over a box is shorter (docs/terrain-notes.md, sessions 9 and 13).
    hold_clock (off; with hold): the walk controller holds the gait clock while a liftoff waits (GaitClock.hold,
    at most max_hold_s per liftoff), so the held swing keeps its duration and the legs after it their four-foot
    phases. With both on, the clutter family crossed clean 28 of 50 against 29 (falls 21 -> 18), but the stones
    family's first 29 draws 19 against 23 (the body target moves on while the clock waits: 3 bodies dropped).
    hold_body (off; with hold_clock): the body waits for its feet: while the gait clock is held for a waiting
    liftoff because one of the feet staying down is not loaded, the body target does not advance along the
    command (its position and heading stand still, its velocity and yaw rate targets are zero), so the legs are
    not left stretched behind a body that went on. With hold and hold_clock, the stones family crossed clean 38 of
    50 against main's 38 (9 gains, 9 losses; the plain hold: 42). hold_body_for_com (off): the body waits also
    while the liftoff waits only for the centre of mass; that stops the very motion that carries the centre of
    mass into the triangle, so the holds ran out and the leg lifted with the centre of mass still outside (stones
    family 26 of 50 against 38; docs/terrain-notes.md, session 14).
    shift (off): the body target moves into the support triangle (shrunk toward its incentre by margin_fraction, -:
    the margin from each edge is this times the inradius), ramped over ramp_s (s) before each liftoff. It rolled the
    flat crawl more (session 9: its four-foot phases, 0.08 s, are too short to cross a diagonal), and with longer
    four-foot phases at the crossings the stones family lost 7 draws for 3 gained in its first 29 (session 13)."""

    shift: bool = False
    min_duty: float = 0.8
    margin_fraction: float = 0.3
    ramp_s: float = 0.2
    hold: bool = False
    hold_clock: bool = False
    hold_body: bool = False
    hold_body_for_com: bool = False
    hold_com: bool = (
        True  # the hold also waits for the centre of mass (False: only for the three feet's load)
    )
    hold_margin_fraction: float = 0.0
    max_hold_s: float = 0.15

    def __post_init__(self) -> None:
        if not 0.0 <= self.margin_fraction < 1.0:
            raise ValueError(
                f"SupportShiftParams.margin_fraction: must be in [0, 1), got {self.margin_fraction}"
            )
        if not 0.0 <= self.hold_margin_fraction < 1.0:
            raise ValueError(
                f"SupportShiftParams.hold_margin_fraction: must be in [0, 1), got {self.hold_margin_fraction}"
            )
        if not self.ramp_s > 0.0:
            raise ValueError(f"SupportShiftParams.ramp_s: must be > 0, got {self.ramp_s}")


def incentre(tri: F64) -> tuple[F64, float]:
    """Returns the incentre (2,) and the inradius (m) of a triangle (3, 2); a degenerate triangle gives its
    vertices' mean and 0."""
    a = float(np.linalg.norm(tri[1] - tri[2]))
    b = float(np.linalg.norm(tri[2] - tri[0]))
    c = float(np.linalg.norm(tri[0] - tri[1]))
    per = a + b + c
    d = tri[1] - tri[0]
    e = tri[2] - tri[0]
    area = 0.5 * abs(float(d[0] * e[1] - d[1] * e[0]))
    if per <= 1e-12 or area <= 1e-12:
        return tri.mean(axis=0), 0.0
    centre = (a * tri[0] + b * tri[1] + c * tri[2]) / per
    return centre, 2.0 * area / per


def shrink_triangle(tri: F64, fraction: float) -> F64:
    """Returns the triangle (3, 2) shrunk toward its incentre by ``fraction`` (each edge moves inward by fraction
    times the inradius)."""
    centre, _ = incentre(tri)
    return centre + (1.0 - fraction) * (tri - centre)


def _closest_on_segment(p: F64, a: F64, b: F64) -> F64:
    ab = b - a
    den = float(ab @ ab)
    s = 0.0 if den <= 1e-18 else min(max(float((p - a) @ ab) / den, 0.0), 1.0)
    return a + s * ab


def project_into_triangle(p: F64, tri: F64) -> F64:
    """Returns the point of the triangle (3, 2), interior included, closest to p (2,)."""
    signs = []
    for i in range(3):
        a, b = tri[i], tri[(i + 1) % 3]
        signs.append(float((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])))
    if all(s >= 0.0 for s in signs) or all(s <= 0.0 for s in signs):
        return p.copy()
    best = tri[0]
    best_d = np.inf
    for i in range(3):
        q = _closest_on_segment(p, tri[i], tri[(i + 1) % 3])
        d = float(np.sum((q - p) ** 2))
        if d < best_d:
            best, best_d = q, d
    return np.asarray(best, dtype=np.float64).copy()


def support_target(
    p_com_xy: F64,
    feet_xy: F64,
    stance: B,
    t_liftoff: F64,
    t_now: float,
    params: SupportShiftParams | None = None,
) -> F64:
    """Returns where the centre of mass should be (xy) for static balance, from its nominal position p_com_xy.

    feet_xy: (4, 2) each foot where it stands, a swinging foot where it will land. stance: (4,) feet down now.
    t_liftoff: (4,) s, the next liftoff of each foot down now (inf: none planned, nan for a foot in the air).
    With exactly one foot in the air, the point stays in the triangle of the other three (shrunk); with all four
    down, it moves into the triangle of the three that stay when the next one lifts, ramped over params.ramp_s
    before that liftoff. Otherwise (two or more in the air, no liftoff planned) p_com_xy is returned unchanged.
    """
    p = params or SupportShiftParams()
    out = np.asarray(p_com_xy, dtype=np.float64).copy()
    down = np.asarray(stance, dtype=bool)
    n_down = int(down.sum())
    if n_down < N_LEGS - 1:
        return out
    lo = np.where(down, np.asarray(t_liftoff, dtype=np.float64), np.inf)
    lo = np.where(np.isnan(lo), np.inf, lo)
    nxt = int(np.argmin(lo))
    tau = float(lo[nxt]) - t_now
    goal = out
    if np.isfinite(tau):
        w = min(max(1.0 - tau / p.ramp_s, 0.0), 1.0)
        if w > 0.0:
            keep = [leg for leg in range(N_LEGS) if leg != nxt]
            tri = shrink_triangle(np.asarray(feet_xy, dtype=np.float64)[keep], p.margin_fraction)
            goal = out + w * (project_into_triangle(out, tri) - out)
    if n_down == N_LEGS - 1:
        keep = [leg for leg in range(N_LEGS) if down[leg]]
        tri = shrink_triangle(np.asarray(feet_xy, dtype=np.float64)[keep], p.margin_fraction)
        goal = project_into_triangle(goal, tri)
    return goal


def inside_triangle(p: F64, tri: F64) -> bool:
    """Whether p (2,) lies in the triangle (3, 2), its edges included."""
    return bool(np.allclose(project_into_triangle(p, tri), p, rtol=0.0, atol=1e-12))


def liftoff_ready(
    p_com_xy: F64,
    feet_xy: F64,
    stance: B,
    loaded: B,
    leg: int,
    margin_fraction: float = 0.0,
    check_com: bool = True,
) -> bool:
    """Whether ``leg`` may lift for static balance: the other three feet down (stance) and loaded, and p_com_xy
    inside their triangle shrunk by margin_fraction (when check_com). With another foot in the air the check does not apply (True).

    feet_xy: (4, 2) where each foot stands. stance: (4,) feet down by the plan. loaded: (4,) feet the ground pushes.
    """
    keep = [other for other in range(N_LEGS) if other != leg]
    down = np.asarray(stance, dtype=bool)
    if not bool(np.all(down[keep])):
        return True
    if not bool(np.all(np.asarray(loaded, dtype=bool)[keep])):
        return False
    if not check_com:
        return True
    tri = shrink_triangle(np.asarray(feet_xy, dtype=np.float64)[keep], margin_fraction)
    return inside_triangle(np.asarray(p_com_xy, dtype=np.float64), tri)
