"""The maneuver timeline as an SVG: one row per leg (swings as bars), one for the body (keyframes as diamonds),
gait segments shaded, the scrub time as a cursor, problems marked where they are."""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass

LEG_ROWS = ("FL", "FR", "RL", "RR")
LEG_COLORS = {"FL": "#e4572e", "FR": "#29a3a3", "RL": "#f3a712", "RR": "#6a4c93"}
WIDTH, ROW_H, LEFT, TOP = 300, 18, 30, 14


@dataclass(frozen=True)
class Bar:
    """A swing of one leg from t0 to t1 (s); `explicit` when it comes from events (else from a gait)."""

    leg: str
    t0: float
    t1: float
    explicit: bool = True
    severity: str | None = None  # "failure" | "warning" | None


@dataclass(frozen=True)
class Mark:
    """A point event on a row at time t (s): a keyframe diamond on the body row, or a lone liftoff/touchdown."""

    row: str  # a leg or "body"
    t: float
    severity: str | None = None


def timeline_svg(
    duration_s: float,
    bars: Sequence[Bar],
    marks: Sequence[Mark],
    gaits: Sequence[tuple[float, float, str]] = (),
    scrub_t: float | None = None,
) -> str:
    """Returns an inline SVG of the timeline; times in seconds."""
    d = max(duration_s, 1e-3)
    inner = WIDTH - LEFT - 6
    rows = [*LEG_ROWS, "body"]
    height = TOP + ROW_H * len(rows) + 16

    def x(t: float) -> float:
        return LEFT + inner * min(max(t / d, 0.0), 1.0)

    def y(row: str) -> float:
        return TOP + ROW_H * rows.index(row)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="100%" viewBox="0 0 {WIDTH} {height}" '
        'style="font: 10px sans-serif; background: #1f2227; border-radius: 4px">'
    ]
    for g0, g1, name in gaits:
        out.append(f'<rect x="{x(g0):.1f}" y="{TOP - 4}" width="{max(1.0, x(g1) - x(g0)):.1f}" '
                   f'height="{ROW_H * 4 + 2}" fill="#3a4150" opacity="0.6"/>'
                   f'<text x="{x(g0) + 2:.1f}" y="{TOP - 5}" fill="#9aa4b5">{html.escape(name)}</text>')  # fmt: skip
    for row in rows:
        yy = y(row)
        out.append(f'<text x="2" y="{yy + 12:.1f}" fill="#c8ccd4">{row}</text>')
        out.append(
            f'<line x1="{LEFT}" x2="{LEFT + inner}" y1="{yy + 9:.1f}" y2="{yy + 9:.1f}" stroke="#444b57"/>'
        )
    for b in bars:
        color = LEG_COLORS.get(b.leg, "#888")
        stroke = {"failure": "#ff3b30", "warning": "#ffcc00"}.get(b.severity or "", "none")
        out.append(
            f'<rect x="{x(b.t0):.1f}" y="{y(b.leg) + 3:.1f}" width="{max(2.0, x(b.t1) - x(b.t0)):.1f}" height="12" '
            f'rx="3" fill="{color}" opacity="{1.0 if b.explicit else 0.45}" stroke="{stroke}" stroke-width="2">'
            f"<title>{b.leg} swing {b.t0:.2f} → {b.t1:.2f} s</title></rect>"
        )
    for m in marks:
        yy = y(m.row) + 9
        fill = {"failure": "#ff3b30", "warning": "#ffcc00"}.get(m.severity or "", "#e8e8e8")
        xx = x(m.t)
        out.append(
            f'<path d="M {xx:.1f} {yy - 6:.1f} L {xx + 5:.1f} {yy:.1f} L {xx:.1f} {yy + 6:.1f} L {xx - 5:.1f} '
            f'{yy:.1f} Z" fill="{fill}"><title>{m.row} at {m.t:.2f} s</title></path>'
        )
    # time axis
    ya = TOP + ROW_H * len(rows) + 2
    step = 0.5 if d <= 4 else 1.0 if d <= 10 else 5.0
    k = 0
    while k * step <= d + 1e-9:
        t = k * step
        out.append(f'<line x1="{x(t):.1f}" x2="{x(t):.1f}" y1="{ya - 3}" y2="{ya}" stroke="#9aa4b5"/>'
                   f'<text x="{x(t) - 4:.1f}" y="{ya + 10}" fill="#9aa4b5">{t:g}</text>')  # fmt: skip
        k += 1
    if scrub_t is not None:
        xs = x(scrub_t)
        out.append(
            f'<line x1="{xs:.1f}" x2="{xs:.1f}" y1="{TOP - 4}" y2="{ya}" stroke="#4cc9f0" stroke-width="2"/>'
        )
    out.append("</svg>")
    return "".join(out)
