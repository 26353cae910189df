"""The studio's Robustness tab: sweep the open maneuver over two axes, watch the success heat map fill in, click a
cell to list its failed cases, choose one to replay it on the live robot.

Under the heat map, its cells as buttons: one row per value of the heat map's y axis, one button per x value, each
showing successes/runs (✗ when a run failed). Clicking one lists that cell's failed cases in the "failed case"
dropdown; choosing a case replays it at once (the button replays the chosen one again).

The sweep goes through the server's sweep manager (the same queue, workers and case store as POST /sweeps); the
open maneuver travels with it even when unsaved. A replay resets the live robot on the case's terrain, starts the
maneuver and pushes it when the case did (within a tick of the time: the live session is paced, not a replay of
the headless run bit for bit); a start offset, friction or sensor noise of the case is not replayed.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

# Presets of two axes: name → (axes, note shown under the dropdown). Push times are set from the maneuver.
PRESETS: dict[str, tuple[dict[str, list[Any]], str]] = {
    "push impulse × direction": (
        {"push_impulse_ns": [0, 5, 10, 15, 20], "push_direction_deg": [0, 90, 180, 270]},
        "one push at mid-maneuver: 17 runs",
    ),
    "push impulse × time": (
        {"push_impulse_ns": [5, 10, 15, 20], "push_t_s": [0.25, 0.5, 0.75]},
        "sideways pushes at a quarter, half, three quarters of the maneuver: 12 runs",
    ),
    "terrain family × seed": (
        {"terrain": ["flat", "slope", "rough", "stairs"], "seed": [0, 1, 2]},
        "the maneuver at the start of each terrain; seeds are scene layouts: 12 runs",
    ),
}


class RobustnessPanel:
    """The widgets of the Robustness tab of one browser tab."""

    def __init__(
        self,
        client: Any,
        services: Any,
        notify: Callable[[str, str, str], None],
        authorized: Callable[[str], bool],
        maneuver: Callable[[], Any],
        session: Callable[[], Any],
    ) -> None:
        self.client = client
        self.services = services
        self.notify = notify
        self.authorized = authorized
        self.maneuver = maneuver
        self.session = session
        self.job: Any = None
        self.spec_doc: dict[str, Any] | None = None
        self.failed: dict[str, str] = {}  # dropdown label → case key (every failed case of the sweep)
        self.cells: dict[tuple[str, str], list[str]] = {}  # heat map cell (x label, y label) → its case keys
        self.cell: tuple[str, str] | None = None  # the cell clicked last
        self.rows: list[Any] = []  # the cell buttons: one button group per y label
        self._grid_of: tuple[Any, ...] | None = None  # (job id, x labels, y labels) the buttons were made for
        self._choosing = False  # set while the dropdown's options are written (its callback must not replay)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def build(self) -> None:
        gui = self.client.gui
        self.dd_preset = gui.add_dropdown("axes", tuple(PRESETS), initial_value=next(iter(PRESETS)))
        self.md_note = gui.add_markdown(PRESETS[next(iter(PRESETS))][1])
        self.btn_run = gui.add_button("Run sweep of the open maneuver")
        self.btn_cancel = gui.add_button("Cancel", disabled=True)
        self.md_status = gui.add_markdown("no sweep yet")
        self.img = gui.add_image(
            np.full((24, 240, 3), 255, dtype=np.uint8), label="success heat map", format="png"
        )
        self.grid = gui.add_folder("cells: click one for its failed cases")
        self.dd_failed = gui.add_dropdown("failed case", ("—",), initial_value="—")
        self.btn_replay = gui.add_button("Replay on the live robot")

        @self.dd_failed.on_update
        def _(e: Any) -> None:
            if not self._choosing and str(e.target.value) in self.failed:
                self.replay(str(e.target.value))

        @self.dd_preset.on_update
        def _(e: Any) -> None:
            self.md_note.content = PRESETS[str(e.target.value)][1]

        @self.btn_run.on_click
        def _(_: Any) -> None:
            self.run()

        @self.btn_cancel.on_click
        def _(_: Any) -> None:
            if self.job is not None and self.authorized("cancel a sweep"):
                from server.sweeps import manager_of

                manager_of(self.services).cancel(self.job.id)

        @self.btn_replay.on_click
        def _(_: Any) -> None:
            self.replay(str(self.dd_failed.value))

    def stop(self) -> None:
        self._stop.set()

    # ---- running --------------------------------------------------------------------------------------------------
    def spec_for(self, maneuver: Any, preset: str) -> dict[str, Any]:
        """The sweep spec of the preset for a maneuver (push times in seconds of its duration)."""
        axes = {k: list(v) for k, v in PRESETS[preset][0].items()}
        dur = float(maneuver.duration)
        if "push_t_s" in axes:
            axes["push_t_s"] = [round(f * dur, 2) for f in axes["push_t_s"]]
        return {
            "format": "footfall/sweep@1",
            "name": "studio",
            "run": {"maneuver": maneuver.name},
            "defaults": {"push": {"t_s": round(dur / 2, 2), "direction_deg": 90}},
            "axes": axes,
            "summary": {"heatmap": list(axes)[:2]},
        }

    def run(self) -> None:
        if not self.authorized("run a sweep"):
            return
        m = self.maneuver()
        if m is None:
            return
        from server.sweeps import SweepQueueFull, SweepRejected, manager_of

        manager = manager_of(self.services)
        doc = self.spec_for(m, str(self.dd_preset.value))
        try:
            spec, cases = manager.prepare(doc, inline={m.name: m.model_dump(by_alias=True, mode="json")})
            self.job = manager.submit(spec, cases)
        except (SweepRejected, SweepQueueFull) as e:
            self.notify("Sweep not started", str(e)[:300], "red")
            return
        self.spec_doc = doc
        self.maneuver_doc = m
        self.btn_cancel.disabled = False
        self.notify("Sweep", f"{self.job.runs} runs of {m.name} queued", "green")
        if self._thread is None or not self._thread.is_alive():
            self._thread = threading.Thread(target=self._watch, name="footfall-studio-sweep", daemon=True)
            self._thread.start()

    def _watch(self) -> None:
        """Redraws the heat map and the status about once a second until the sweep ends."""
        while not self._stop.is_set():
            job = self.job
            if job is None:
                return
            self.refresh()
            if job.status in ("done", "cancelled", "failed"):
                self.btn_cancel.disabled = True
                return
            time.sleep(1.0)

    def refresh(self) -> None:
        from planning.sweep.heatmap import render
        from planning.sweep.summary import summarize

        job = self.job
        p = job.progress()
        rate = "—" if p["success_rate"] is None else f"{100 * p['success_rate']:.0f} %"
        eta = "" if not p["eta_s"] else f", ETA {p['eta_s']:.0f} s"
        self.md_status.content = (
            f"**{job.status}**: {p['done']}/{p['total']} runs, success {p['successes']} ({rate}), "
            f"{p['crashed']} crashed{eta}"
        )
        s = summarize(job.spec, job.cases, dict(job.records))
        if s["heatmap"] is not None:
            self.img.image = render(s["heatmap"], f"{job.spec.runs()[0].name()}: success")
        failed = {}
        for c in job.cases:
            r = job.records.get(c["key"])
            if r is None or (r["status"] == "done" and r["report"].get("success")):
                continue
            axes = ", ".join(f"{k}={_short(v)}" for k, v in c["axes"].items())
            why = r["report"].get("failure_reason") if r["status"] == "done" else f"crashed: {r['error']}"
            failed[f"{axes}: {str(why)[:50]}"] = c["key"]
        if list(failed) != list(self.failed):
            self.failed = failed
            if self.cell is None:
                self._set_choices(tuple(failed) or ("—",))
        if s["heatmap"] is not None:
            self._update_cells(s["heatmap"])

    # ---- the heat map's cells -------------------------------------------------------------------------------------
    def _set_choices(self, options: tuple[str, ...]) -> None:
        self._choosing = True
        try:
            self.dd_failed.options = options
            self.dd_failed.value = options[
                0
            ]  # a heading (or the first case): choosing a case is then a change
        finally:
            self._choosing = False

    def _update_cells(self, heat: dict[str, Any]) -> None:
        """Makes (for a new sweep) or relabels the cell buttons from the heat map's counts."""
        from planning.sweep.summary import heatmap_cell_keys

        job = self.job
        xs, ys = list(heat["x_labels"]), list(heat["y_labels"])
        if self._grid_of != (job.id, xs, ys):
            for row in self.rows:
                with contextlib.suppress(Exception):
                    row.remove()
            self.rows = []
            self.cells = heatmap_cell_keys(job.spec, job.cases, heat["x"], heat["y"])
            self.cell = None
            with self.grid:
                for y in reversed(ys):  # as drawn: the largest y on top
                    row = self.client.gui.add_button_group(f"{heat['y']}={y}", self._cell_labels(heat, xs, y))
                    row.on_click(
                        lambda e, y=y: self.select_cell(xs[list(e.target.options).index(e.target.value)], y)
                    )
                    self.rows.append(row)
            self._grid_of = (job.id, xs, ys)
            return
        for row, y in zip(self.rows, reversed(ys), strict=True):
            labels = self._cell_labels(heat, xs, y)
            if tuple(row.options) != labels:
                row.options = labels

    @staticmethod
    def _cell_labels(heat: dict[str, Any], xs: list[str], y: str) -> tuple[str, ...]:
        j = list(heat["y_labels"]).index(y)
        out = []
        for i, x in enumerate(xs):
            ok, done = heat["successes"][j][i], heat["done"][j][i]
            out.append(f"{heat['x']}={x}: {ok}/{done}" + (" ✗" if ok < done else ""))
        return tuple(out)

    def select_cell(self, x: str, y: str) -> list[str]:
        """Lists the failed cases of the heat map's cell (x, y) in the dropdown; returns their labels."""
        keys = set(self.cells.get((x, y), []))
        labels = [label for label, key in self.failed.items() if key in keys]
        self.cell = (x, y)
        head = f"cell {x}, {y}: " + (f"choose one of {len(labels)} failed" if labels else "no failed case")
        self._set_choices((head, *labels))
        return labels

    # ---- replay ---------------------------------------------------------------------------------------------------
    def replay(self, label: str) -> None:
        key = self.failed.get(label)
        session = self.session()
        if key is None or self.job is None or session is None or not self.authorized("replay a case"):
            return
        case = next(c for c in self.job.cases if c["key"] == key)
        p = case["params"]
        from planning.maneuver import parse_maneuver
        from planning.terrain.spec import spec_from_mapping

        terrain = spec_from_mapping({"name": p["terrain"], "params": p["terrain_params"]}).text()
        try:
            session.reset(terrain)
            session.start_maneuver(parse_maneuver(p["maneuver"]))
        except Exception as e:  # noqa: BLE001 - a session error is the user's to see
            self.notify("Replay failed", str(getattr(e, "message", e))[:300], "red")
            return
        if p["seed"]:
            self.notify("Replay", f"the live robot has the seed-0 layout of {p['terrain']}, not seed {p['seed']}",
                        "yellow")  # fmt: skip
        push = p["push"]
        if push["impulse_ns"] > 0:
            f = push["impulse_ns"] / push["duration_s"]
            a = math.radians(push["direction_deg"])
            force = (f * math.cos(a), f * math.sin(a), 0.0)
            threading.Thread(target=self._push_at, args=(session, push["t_s"], force, push["duration_s"]),
                             daemon=True).start()  # fmt: skip

    def _push_at(
        self, session: Any, t_s: float, force: tuple[float, float, float], duration_s: float
    ) -> None:
        gen = session.generation
        deadline = time.time() + 10 * t_s + 30
        while time.time() < deadline and not self._stop.is_set():
            if session.generation != gen:
                return  # the user started something else
            if session.sim.t >= t_s:
                try:
                    session.push(force, duration_s)
                except Exception:  # noqa: BLE001 - the session may have crashed or gone
                    pass
                return
            time.sleep(0.005)


def _short(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)
