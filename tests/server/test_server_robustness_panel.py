"""The studio's Robustness tab without a browser: its spec, the heat map and failed cases it shows from a sweep's
records, and a replay that resets the live robot and pushes it when the case did."""

from __future__ import annotations

import time
from types import SimpleNamespace
from typing import Any

import numpy as np

from planning.maneuver import find_maneuver, load_maneuver
from planning.sweep import expand, parse_spec
from server.studio.robustness import RobustnessPanel
from server.sweeps import SweepJob


class _Widget(SimpleNamespace):
    def on_click(self, fn: Any) -> Any:
        self.click = fn
        return fn

    on_update = on_click

    def __enter__(self) -> _Widget:  # a folder
        return self

    def __exit__(self, *exc: Any) -> None:
        pass

    def remove(self) -> None:
        self.removed = True


class _Gui:
    def __getattr__(self, name: str) -> Any:
        def add(*args: Any, **kw: Any) -> _Widget:
            w = _Widget(
                kind=name,
                args=args,
                value=kw.get("initial_value"),
                options=args[1] if len(args) > 1 else None,
            )
            if name == "add_image":
                w.image = args[0]
            return w

        return add


class _Session:
    def __init__(self) -> None:
        self.generation = 0
        self.sim = SimpleNamespace(t=0.0)
        self.calls: list[tuple[str, Any]] = []

    def reset(self, terrain: str) -> None:
        self.calls.append(("reset", terrain))

    def start_maneuver(self, m: Any) -> None:
        self.calls.append(("start", m.name))

    def push(self, force: tuple[float, float, float], duration: float) -> None:
        self.calls.append(("push", (round(self.sim.t, 2), tuple(round(f, 3) for f in force), duration)))


def test_panel_shows_the_heat_map_and_replays_a_failed_case() -> None:
    stand = load_maneuver(find_maneuver("stand"))
    session = _Session()
    panel = RobustnessPanel(SimpleNamespace(gui=_Gui()), SimpleNamespace(), lambda *a: None, lambda what: True,
                            lambda: stand, lambda: session)  # fmt: skip
    panel.build()
    doc = panel.spec_for(stand, "push impulse × direction")
    assert doc["run"] == {"maneuver": "stand"} and doc["defaults"]["push"]["t_s"] == 5.0
    spec = parse_spec(doc)
    cases = expand(spec)
    job = SweepJob("j1", spec, cases, len({c["key"] for c in cases}), status="running", started=time.time())
    for c in cases:  # a made-up outcome: pushes of 15 N·s and more fall
        ok = c["axes"]["push_impulse_ns"] < 15
        job.records[c["key"]] = {"status": "done", "attempts": 1, "wall_s": 1.0, "error": None,
                                 "report": {"success": ok, "failure_reason": None if ok else "fell: trunk"}}  # fmt: skip
    panel.job = job
    panel.refresh()
    assert "17/17 runs" in panel.md_status.content
    img = panel.img.image
    assert img.ndim == 3 and img.shape[0] > 60 and img.shape[1] > 200
    colors = {tuple(int(v) for v in px) for px in img.reshape(-1, 3)}
    assert (220, 60, 60) in colors and (50, 180, 60) in colors  # failed cells red, survived green
    assert len(panel.failed) == 8  # 15 and 20 N·s in four directions
    label = next(k for k in panel.failed if "push_impulse_ns=20" in k and "push_direction_deg=180" in k)
    panel.replay(label)
    assert session.calls[:2] == [("reset", "flat"), ("start", "stand")]
    session.sim.t = 5.01
    for _ in range(200):
        if len(session.calls) == 3:
            break
        time.sleep(0.01)
    kind, (t, force, duration) = session.calls[2]
    assert kind == "push" and t >= 5.0 and duration == 0.1
    assert np.allclose(force, (-200.0, 0.0, 0.0), atol=1e-6)  # 20 N·s over 0.1 s toward 180°
    # the cells under the heat map: a row per direction, a button per impulse; a failed cell lists its failed cases
    rows = {r.args[0]: r for r in panel.rows}
    assert set(rows) == {f"push_direction_deg={d}" for d in (0, 90, 180, 270)}
    row = rows["push_direction_deg=180"]
    assert row.options[-1] == "push_impulse_ns=20: 0/1 ✗" and row.options[1] == "push_impulse_ns=5: 1/1"
    row.value = row.options[-1]
    row.click(SimpleNamespace(target=row))
    assert panel.cell == ("20", "180")
    assert panel.dd_failed.options[1:] == (label,) and "1 failed" in panel.dd_failed.options[0]
    n = len(session.calls)
    panel.dd_failed.value = label  # the user chooses the case: it replays at once
    panel.dd_failed.click(SimpleNamespace(target=panel.dd_failed))
    assert session.calls[n : n + 2] == [("reset", "flat"), ("start", "stand")]
    assert panel.select_cell("5", "180") == []  # a cell that did not fail lists nothing
    panel.stop()
