"""The maneuver timeline as an SVG the user works on with the mouse (the dope sheet): one row per leg (swings as
bars, each touchdown's adjust window shaded), one for the body (keyframes as diamonds), gait segments shaded, the
playhead, problems marked where they are.

Every element the user can grab carries `data-ids` (the editor's item ids) and `data-part` (what a drag changes:
`move`, `start`, `end`, `adjust`); the SVG carries the visible time window and the plot geometry, so the page
helper (page.js) turns pointer positions into seconds. Times in seconds.
"""

from __future__ import annotations

import html
from collections.abc import Collection, Sequence
from dataclasses import dataclass

LEG_ROWS = ("FL", "FR", "RL", "RR")
LEG_COLORS = {"FL": "#e4572e", "FR": "#29a3a3", "RL": "#f3a712", "RR": "#6a4c93"}
WIDTH, ROW_H, LEFT, TOP = 300, 18, 30, 14
EDGE_PX = 3.0  # the grab zone at each end of a swing bar (viewBox units; the panel is ~300 px wide)


@dataclass(frozen=True)
class Bar:
    """A swing of one leg from t0 to t1 (s); `explicit` when it comes from events (else from a gait). `lo_id` and
    `td_id` are the editor's ids of its liftoff and touchdown; `adjust_s` the touchdown's ± time window."""

    leg: str
    t0: float
    t1: float
    explicit: bool = True
    severity: str | None = None  # "failure" | "warning" | None
    lo_id: int | None = None
    td_id: int | None = None
    adjust_s: float = 0.0


@dataclass(frozen=True)
class Mark:
    """A point event on a row at time t (s): a keyframe diamond on the body row, or a lone liftoff/touchdown."""

    row: str  # a leg or "body"
    t: float
    severity: str | None = None
    item_id: int | None = None


@dataclass(frozen=True)
class PhysicsMark:
    """What the physics check measured at one event: drawn as a dot under the event on its leg's row, colored by
    its margin (1 unused .. 0 at a limit), red when the check failed on it; `numbers` is its tooltip."""

    leg: str
    t: float
    status: str  # "ok" | "warning" | "failure" | "not reached"
    margin: float
    numbers: str


def margin_color(status: str, margin: float) -> str:
    """Returns a mark's color: red on the failure, grey when the run ended before the event, else green (margin
    ≥ 0.5), yellow (≥ 0.25), orange (below)."""
    if status == "failure":
        return "#ff3b30"
    if status == "not reached":
        return "#6b7280"
    return "#34c759" if margin >= 0.5 else "#ffcc00" if margin >= 0.25 else "#ff9500"


def physics_marks(section: dict[str, object] | None) -> list[PhysicsMark]:
    """Returns the marks of a validation answer's `physics` section (none when the check did not run)."""
    if not section or not section.get("ran"):
        return []
    out = []
    for e in section.get("events") or []:  # type: ignore[attr-defined]
        parts = [f"{e['leg']} {e['type']} at {float(e['t']):.2f} s — {e.get('status', 'ok')}, margin "
                 f"{float(e.get('margin', 1.0)):.2f}",
                 f"peak torque {float(e.get('peak_torque_use', 0.0)):.0%} of limit ({e.get('peak_torque_joint') or '-'})",
                 f"friction use {float(e.get('friction_use', 0.0)):.0%}"]  # fmt: skip
        if e.get("stability_margin_m") is not None:
            parts.append(f"stability margin {float(e['stability_margin_m']) * 100:+.1f} cm")
        if e.get("timing_error_s") is not None:
            parts.append(f"touchdown timing {float(e['timing_error_s']) * 1e3:+.0f} ms, "
                         f"place {float(e.get('place_error_m') or 0.0) * 100:.1f} cm")  # fmt: skip
        elif e.get("type") == "touchdown" and e.get("reached", True):
            parts.append("touchdown not found in the run")
        if e.get("backup_ticks"):
            parts.append(f"{e['backup_ticks']} backup-controller ticks")
        out.append(PhysicsMark(str(e["leg"]), float(e["t"]), str(e.get("status", "ok")),
                               float(e.get("margin", 1.0)), "\n".join(parts)))  # fmt: skip
    return out


def _ids(*ids: int | None) -> str:
    return " ".join(str(i) for i in ids if i is not None)


def timeline_svg(
    duration_s: float,
    bars: Sequence[Bar],
    marks: Sequence[Mark],
    gaits: Sequence[tuple[float, float, str]] = (),
    scrub_t: float | None = None,
    *,
    view: tuple[float, float] | None = None,
    selected: Collection[int] = (),
    beats: Sequence[float] = (),
    physics: Sequence[PhysicsMark] = (),
) -> str:
    """Returns an inline SVG of the timeline showing `view` = (t0, t1) s (default: the whole maneuver)."""
    d = max(duration_s, 1e-3)
    v0, v1 = view if view is not None else (0.0, d)
    v1 = max(v1, v0 + 1e-3)
    inner = WIDTH - LEFT - 6
    rows = [*LEG_ROWS, "body"]
    height = TOP + ROW_H * len(rows) + 16

    def x(t: float) -> float:
        return LEFT + inner * min(max((t - v0) / (v1 - v0), 0.0), 1.0)

    def y(row: str) -> float:
        return TOP + ROW_H * rows.index(row)

    sel = set(selected)
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="100%" viewBox="0 0 {WIDTH} {height}" '
        f'data-footfall-timeline="1" data-v0="{v0:.4f}" data-v1="{v1:.4f}" data-left="{LEFT}" data-inner="{inner}" '
        f'data-width="{WIDTH}" data-duration="{d:.4f}" '
        'style="font: 10px sans-serif; background: #1f2227; border-radius: 4px; user-select: none; '
        'touch-action: none">'
    ]
    out.append(
        f'<rect data-part="background" x="0" y="0" width="{WIDTH}" height="{height}" fill="transparent"/>'
    )
    for g0, g1, name in gaits:
        out.append(f'<rect x="{x(g0):.1f}" y="{TOP - 4}" width="{max(1.0, x(g1) - x(g0)):.1f}" '
                   f'height="{ROW_H * 4 + 2}" fill="#3a4150" opacity="0.6" pointer-events="none"/>'
                   f'<text x="{x(g0) + 2:.1f}" y="{TOP - 5}" fill="#9aa4b5">{html.escape(name)}</text>')  # fmt: skip
    for tb in beats:
        if v0 <= tb <= v1:
            out.append(f'<line x1="{x(tb):.1f}" x2="{x(tb):.1f}" y1="{TOP - 4}" y2="{TOP + ROW_H * 5}" '
                       'stroke="#5a6475" stroke-dasharray="1 2" pointer-events="none"/>')  # fmt: skip
    for row in rows:
        yy = y(row)
        out.append(f'<text x="2" y="{yy + 12:.1f}" fill="#c8ccd4">{row}</text>')
        out.append(
            f'<line x1="{LEFT}" x2="{LEFT + inner}" y1="{yy + 9:.1f}" y2="{yy + 9:.1f}" stroke="#444b57" '
            'pointer-events="none"/>'
        )
    for b in bars:
        if b.explicit and b.td_id is not None and b.adjust_s > 0:
            a0, a1 = x(b.t1 - b.adjust_s), x(b.t1 + b.adjust_s)
            out.append(
                f'<rect data-ids="{b.td_id}" data-part="adjust" x="{a0:.1f}" y="{y(b.leg) + 1:.1f}" '
                f'width="{max(1.0, a1 - a0):.1f}" height="16" fill="{LEG_COLORS.get(b.leg, "#888")}" opacity="0.22" '
                f'style="cursor: ew-resize"><title>{b.leg} touchdown may move ± {b.adjust_s:.2f} s</title></rect>'
            )
    for b in bars:
        color = LEG_COLORS.get(b.leg, "#888")
        stroke = {"failure": "#ff3b30", "warning": "#ffcc00"}.get(b.severity or "", "none")
        is_sel = b.explicit and ({b.lo_id, b.td_id} & sel)
        if is_sel:
            stroke = "#ffffff"
        x0, x1 = x(b.t0), x(b.t1)
        ids = _ids(b.lo_id, b.td_id)
        grab = f'data-ids="{ids}" data-part="move" style="cursor: grab"' if b.explicit and ids else ""
        out.append(
            f'<rect {grab} x="{x0:.1f}" y="{y(b.leg) + 3:.1f}" width="{max(2.0, x1 - x0):.1f}" height="12" '
            f'rx="3" fill="{color}" opacity="{1.0 if b.explicit else 0.45}" stroke="{stroke}" stroke-width="2">'
            f"<title>{b.leg} swing {b.t0:.2f} → {b.t1:.2f} s</title></rect>"
        )
        if b.explicit and b.lo_id is not None and b.td_id is not None:
            for part, xe, i in (("start", x0, b.lo_id), ("end", x1, b.td_id)):
                out.append(
                    f'<rect data-ids="{i}" data-part="{part}" x="{xe - EDGE_PX / 2:.1f}" y="{y(b.leg) + 3:.1f}" '
                    f'width="{EDGE_PX}" height="12" fill="#ffffff" opacity="0.35" style="cursor: ew-resize"/>'
                )
    for m in marks:
        yy = y(m.row) + 9
        fill = {"failure": "#ff3b30", "warning": "#ffcc00"}.get(m.severity or "", "#e8e8e8")
        xx = x(m.t)
        grab = (
            f'data-ids="{m.item_id}" data-part="move" style="cursor: grab"' if m.item_id is not None else ""
        )
        stroke = ' stroke="#4cc9f0" stroke-width="2"' if m.item_id in sel else ""
        out.append(
            f'<path {grab} d="M {xx:.1f} {yy - 6:.1f} L {xx + 5:.1f} {yy:.1f} L {xx:.1f} {yy + 6:.1f} L {xx - 5:.1f} '
            f'{yy:.1f} Z" fill="{fill}"{stroke}><title>{m.row} at {m.t:.2f} s</title></path>'
        )
    # the physics check's measurements: a dot under each event (the failure's larger, ringed)
    for pm in physics:
        if not (v0 - 1e-9 <= pm.t <= v1 + 1e-9) or pm.leg not in LEG_ROWS:
            continue
        big = pm.status == "failure"
        ring = ' stroke="#ffffff" stroke-width="1.2"' if big else ""
        out.append(
            f'<circle data-physics="{html.escape(pm.status)}" data-margin="{pm.margin:.3f}" cx="{x(pm.t):.1f}" '
            f'cy="{y(pm.leg) + 16:.1f}" r="{3.2 if big else 2.2}" fill="{margin_color(pm.status, pm.margin)}"{ring}>'
            f"<title>{html.escape(pm.numbers)}</title></circle>"
        )
    # time axis (drag on it to move the playhead)
    ya = TOP + ROW_H * len(rows) + 2
    out.append(
        f'<rect data-part="playhead" x="{LEFT}" y="{ya - 4}" width="{inner}" height="16" fill="transparent" '
        'style="cursor: col-resize"/>'
    )
    span = v1 - v0
    step = next((s for s in (0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0) if span / s <= 10), 20.0)
    k = int(v0 // step)
    while k * step <= v1 + 1e-9:
        t = k * step
        if t >= v0 - 1e-9:
            out.append(f'<line x1="{x(t):.1f}" x2="{x(t):.1f}" y1="{ya - 3}" y2="{ya}" stroke="#9aa4b5" '
                       f'pointer-events="none"/><text x="{x(t) - 4:.1f}" y="{ya + 10}" fill="#9aa4b5" '
                       f'pointer-events="none">{t:g}</text>')  # fmt: skip
        k += 1
    if scrub_t is not None and v0 <= scrub_t <= v1:
        xs = x(scrub_t)
        out.append(
            f'<line data-part="playhead" x1="{xs:.1f}" x2="{xs:.1f}" y1="{TOP - 4}" y2="{ya}" stroke="#4cc9f0" '
            'stroke-width="2" style="cursor: col-resize"/>'
        )
    out.append("</svg>")
    return "".join(out)
