"""The authoring panel of one studio tab: a maneuver being edited, its timeline, its items as GUI folders, its
touchdown targets and body keyframes as 3D markers (dragged with transform controls), validation on the items.

The document is kept as plain lists of item dicts (events, keyframes, gaits, objectives) whose identity survives
edits; `document()` writes them out in file order (events and keyframes sorted by time, as the format requires)
together with the map from file index back to item, so a problem at ``events[3].t`` lands on the right folder.
Coordinates in the GUI are the maneuver frame; the 3D markers add the session's world offset (the ground height
at the start).
"""

from __future__ import annotations

import copy
import json
import logging
import re
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from planning.maneuver import ManeuverError, check_maneuver, parse_maneuver, validate_maneuver
from planning.maneuver.load import read_yaml
from planning.maneuver.spec import NAME_PATTERN
from server.storage import Conflict, StorageError, dump_yaml
from server.studio import fields as F
from server.studio import moves, music
from server.studio.timeline import LEG_COLORS, LEG_ROWS, Bar, Mark, physics_marks, timeline_svg

log = logging.getLogger("footfall.studio")
FORMAT = "footfall/maneuver@1"
# the format's names, defaults and limits, read off its pydantic models (server.studio.fields), never restated here
WEIGHT_DEFAULTS = F.weight_defaults()
WEIGHT_NAMES = tuple(WEIGHT_DEFAULTS)
GAITS = F.GAITS
OBJECTIVES = F.OBJECTIVES
TARGET_MODES = ("at", "offset", "in place")
TRUNK_DIMS_M = (0.84, 0.24, 0.16)
UNDO_DEPTH = 200  # edits kept for undo
# the editing keys (label, key, modifier, action): none of them is one of the keys viser flies its camera with
EDIT_KEYS = (("undo", "Z", "cmd/ctrl", "undo"), ("redo", "Z", "cmd/ctrl+shift", "redo"), ("redo ", "Y", "cmd/ctrl", "redo"),
             ("copy the timeline selection", "C", "cmd/ctrl", "copy"),
             ("paste at the playhead", "V", "cmd/ctrl", "paste"),
             ("delete the timeline selection", "delete", None, "delete"))  # fmt: skip
MOVES_DIR = (
    Path(__file__).resolve().parents[2] / "maneuvers" / "moves"
)  # small maneuvers inserted at the playhead
MAX_REPEAT = 8  # how many times a move may be inserted back to back
GRID_CHOICES = {"off": 0.0, "0.01 s": 0.01, "0.05 s": 0.05, "0.1 s": 0.1, "0.25 s": 0.25}
_PATH_RE = re.compile(r"^(events|body|gaits|objectives)\[(\d+)\]")


def _hex_rgb(h: str) -> tuple[int, int, int]:
    return (int(h[1:3], 16), int(h[3:5], 16), int(h[5:7], 16))


def _r(x: float, nd: int = 4) -> float:
    return float(round(float(x), nd))


def move_names(user_dir: Path | None = None) -> list[str]:
    """Returns the names of the moves (small maneuvers in maneuvers/moves/, and the user's), sorted."""
    dirs = [MOVES_DIR] + ([user_dir] if user_dir is not None else [])
    return sorted({p.stem for d in dirs for p in d.glob("*.yaml")})


def rpy_deg_from_wxyz(wxyz: Any) -> list[float]:
    """Returns [roll, pitch, yaw] in degrees (ZYX: yaw, then pitch, then roll) of a wxyz quaternion."""
    import viser.transforms as tf

    rpy = tf.SO3(np.asarray(wxyz, dtype=float)).as_rpy_radians()
    return [_r(np.degrees(rpy.roll), 2), _r(np.degrees(rpy.pitch), 2), _r(np.degrees(rpy.yaw), 2)]


def wxyz_from_rpy_deg(rpy: Any) -> np.ndarray:
    import viser.transforms as tf

    r, p, y = np.radians(np.asarray(rpy, dtype=float))
    return np.asarray(tf.SO3.from_rpy_radians(r, p, y).wxyz)


@dataclass
class ItemUi:
    """The GUI of one item (a step, a keyframe, a gait, an objective): its folder and problem line."""

    folder: Any
    problems: Any
    label: str
    handles: dict[str, Any] = field(default_factory=dict)
    relabel: Callable[[], str] | None = None  # the folder's title from the item as it is now (times change)


class ManeuverEditor:
    """The maneuver being authored in one studio tab."""

    def __init__(
        self,
        client: Any,
        services: Any,
        *,
        notify: Callable[[str, str, str], None],
        authorized: Callable[[str], bool],
        start_preview: Callable[[Any], None],
        world_offset: Callable[[], np.ndarray],
    ) -> None:
        self.client = client
        self.gui = client.gui
        self.scene = client.scene
        self.services = services
        self.notify = notify
        self.authorized = authorized
        self.start_preview = start_preview
        self.world_offset = world_offset
        # what the tab's picked robot loads (robot_picker sets it; None: the server's robot)
        self.robot_load: Callable[[], str | None] = lambda: None
        self.lock = threading.RLock()
        # the document
        self.meta: dict[str, Any] = {}
        self.events: list[dict[str, Any]] = []
        self.keyframes: list[dict[str, Any]] = []
        self.gaits: list[dict[str, Any]] = []
        self.objectives: list[dict[str, Any]] = []
        self.weights: dict[str, float] | None = None
        self.source_name: str | None = None
        self.source: str | None = None
        self.etag: str | None = None
        self.dirty = False
        # what validation said
        self.result: Any = None
        self.problems_by_item: dict[int, list[Any]] = {}
        self.general_problems: list[Any] = []
        self.physics: dict[str, Any] | None = None  # the last physics check's section (for the document at
        self._physics_rev = -1  # this edit count: marks of an older document are not drawn)
        # gui
        self.item_ui: dict[int, ItemUi] = {}
        self._holder_items: list[Any] = []
        self.markers: dict[int, Any] = {}
        self.gizmo: Any = None
        self.gizmo_item: int | None = None
        self.scrub_nodes: list[Any] = []
        self._validate_timer: threading.Timer | None = None
        self._checks_running = 0  # background validations running now (close waits for them)
        self._checks_done = threading.Condition()
        # edits so far, and the edit count of the document whose problems are shown: a check of an older document
        # (a quiet-period timer that fired before the latest edit) must not overwrite a newer one's problems
        self._rev = 0
        self._shown_rev = -1
        self._suspend = False  # set while the GUI is written from the document (its callbacks must not echo)
        # the timeline: its visible window (None: the whole maneuver), the selected items, the clipboard (copies with
        # times relative to the first), the snapping grid (s, 0: off), undo and redo (whole-document states)
        self.view: tuple[float, float] | None = None
        self.selected: set[int] = set()
        self.clipboard: list[tuple[str, dict[str, Any]]] = []
        self.grid_s = 0.05
        self.beats: music.Beats | None = (
            None  # the loaded music's pulse (shown as a grid, snapped to on request)
        )
        self._undo: list[dict[str, Any]] = []
        self._redo: list[dict[str, Any]] = []
        self._last_op = -1

    # ================================================================================================================
    # document
    # ================================================================================================================
    def load_document(
        self, data: dict[str, Any], *, name: str | None, source: str | None, etag: str | None
    ) -> None:
        """Replaces the edited document (a parsed file) and rebuilds the panel's items."""
        data = json.loads(json.dumps(data, default=str))
        with self.lock:
            self.meta = {k: data.get(k) for k in ("format", "name", "title", "description", "duration", "start",
                                                  "tracks", "friction", "music") if k in data}  # fmt: skip
            self.meta.setdefault("format", FORMAT)
            self.events = [dict(e) for e in data.get("events") or [] if isinstance(e, dict)]
            self.keyframes = [dict(k) for k in data.get("body") or [] if isinstance(k, dict)]
            self.gaits = [dict(g) for g in data.get("gaits") or [] if isinstance(g, dict)]
            self.objectives = [dict(o) for o in data.get("objectives") or [] if isinstance(o, dict)]
            w = data.get("weights")
            self.weights = dict(w) if isinstance(w, dict) else None
            self.source_name, self.source, self.etag = name, source, etag
            self.dirty = False
            self._undo, self._redo = [self._state()], []
            self.selected.clear()
            self.view = None
        self._write_static_fields()
        self._music_from_document()
        self._show_in_library(name)
        self.rebuild_items()
        self.request_validation(0.0)

    def _show_in_library(self, name: str | None) -> None:
        """Makes the library dropdown show the open maneuver (listing it first if it is new)."""
        dd = getattr(self, "dd_library", None)
        if dd is None or not name:
            return
        try:
            if name not in dd.options:
                dd.options = [e["name"] for e in self.services.store.list()]
            if name in dd.options:
                dd.value = name
        except Exception:  # noqa: BLE001 - the client may be gone
            pass

    def new_document(self) -> None:
        h = float(getattr(self.services.robot, "standing_height_m", 0.52))
        self.load_document(
            {"format": FORMAT, "name": "my-maneuver", "title": "My maneuver", "duration": 3.0, "start": "stand",
             "tracks": ["legs", "body"], "body": [{"t": 3.0, "position": [0.0, 0.0, round(h, 3)],
                                                   "rpy": [0, 0, 0], "weight": 5.0}]},
            name=None, source=None, etag=None,
        )  # fmt: skip

    def open(self, name: str) -> bool:
        """Loads a library maneuver into the editor; returns False (after telling the user) when it cannot."""
        try:
            stored = self.services.store.get(name)
            data, _ = read_yaml(stored.text)
        except (StorageError, ManeuverError) as e:
            self.notify("Cannot open", str(e), "red")
            return False
        if not isinstance(data, dict):
            self.notify("Cannot open", f"{name}: not a maneuver document", "red")
            return False
        self.load_document(data, name=name, source=stored.source, etag=stored.etag)
        return True

    def document(self) -> tuple[dict[str, Any], list[int], list[int]]:
        """Returns (document in file order, file event index → item id, file keyframe index → item id)."""
        with self.lock:
            doc: dict[str, Any] = {k: v for k, v in self.meta.items() if v is not None}
            ev = sorted(enumerate(self.events), key=lambda p: (float(p[1].get("t", 0.0)), p[0]))
            kf = sorted(enumerate(self.keyframes), key=lambda p: (float(p[1].get("t", 0.0)), p[0]))
            if ev:
                doc["events"] = [copy.deepcopy(e) for _, e in ev]
            if self.gaits:
                doc["gaits"] = copy.deepcopy(self.gaits)
            if kf:
                doc["body"] = [copy.deepcopy(k) for _, k in kf]
            if self.weights:
                doc["weights"] = dict(self.weights)
            if self.objectives:
                doc["objectives"] = copy.deepcopy(self.objectives)
            return doc, [id(e) for _, e in ev], [id(k) for _, k in kf]

    def yaml_text(self) -> str:
        return dump_yaml(self.document()[0])

    def _state(self) -> dict[str, Any]:
        """Returns a copy of the whole document as edited (what undo goes back to)."""
        return copy.deepcopy({"meta": self.meta, "events": self.events, "keyframes": self.keyframes,
                              "gaits": self.gaits, "objectives": self.objectives, "weights": self.weights})  # fmt: skip

    def _restore(self, st: dict[str, Any]) -> None:
        with self.lock:
            st = copy.deepcopy(st)
            self.meta, self.events, self.keyframes = st["meta"], st["events"], st["keyframes"]
            self.gaits, self.objectives, self.weights = st["gaits"], st["objectives"], st["weights"]
            self.selected.clear()
            self.dirty = True
            self._rev += 1
        self._write_static_fields(keep_scrub=True)
        self.rebuild_items()
        self.request_validation(0.0)

    def undo(self) -> bool:
        """Goes back one edit; False when there is none."""
        with self.lock:
            if len(self._undo) < 2:
                return False
            self._redo.append(self._undo.pop())
            st = self._undo[-1]
        self._restore(st)
        return True

    def redo(self) -> bool:
        with self.lock:
            if not self._redo:
                return False
            st = self._redo.pop()
            self._undo.append(st)
        self._restore(st)
        return True

    def _changed(self, structural: bool = False) -> None:
        if self._suspend:
            return
        self.dirty = True
        self._rev += 1
        with self.lock:
            self._undo.append(self._state())
            del self._undo[:-UNDO_DEPTH]
            self._redo.clear()
        if structural:
            self.rebuild_items()
        self._refresh_header()
        self.request_validation()

    # ================================================================================================================
    # the panel
    # ================================================================================================================
    def build(self) -> None:
        """Creates the panel's fixed widgets (in the current GUI container)."""
        gui = self.gui
        self.md_header = gui.add_markdown("*no maneuver open*")
        with gui.add_folder("Library"):
            names = [e["name"] for e in self.services.store.list()] or ["stand"]
            self.dd_library = gui.add_dropdown(
                "Maneuver", names, initial_value="bow" if "bow" in names else names[0]
            )
            self.btn_open = gui.add_button("Open", icon=None)
            self.btn_new = gui.add_button("New")
        with gui.add_folder("Maneuver"):
            self.txt_name = gui.add_text("name", "")
            self.txt_title = gui.add_text("title", "")
            self.num_duration = self._number("duration (s)", 3.0, F.MANEUVER, "duration", 0.1, is_time=True)
            self.num_friction = self._number("friction", 0.6, F.MANEUVER, "friction", 0.05)
        self.html_timeline = gui.add_html(timeline_svg(3.0, [], []))
        # what the page helper sends from the timeline (drags, selections, zoom, playhead), one JSON op per value;
        # the helper hides this row
        self.txt_timeline_ops = gui.add_text("timeline edits", "")
        self.sl_scrub = gui.add_slider("scrub (s)", 0.0, 3.0, 0.01, 0.0)
        with gui.add_folder("Moves", expand_by_default=False):
            names = move_names(Path(self.services.settings.data_dir) / "moves") or ["(none)"]
            self.dd_move = gui.add_dropdown("move", names, initial_value=names[0])
            self.num_move_repeat = gui.add_number("repeat", 1, min=1, max=MAX_REPEAT, step=1)
            # the move's natural parameters (server.studio.moves): set to its own values when it is picked; only
            # those it has are enabled
            self.num_move_params = {
                "angle": gui.add_number("angle (°)", 0.0, min=-moves.MAX_ANGLE_DEG, max=moves.MAX_ANGLE_DEG,
                                        step=1.0, disabled=True, hint="how far the move turns in all"),
                "distance": gui.add_number("distance (m)", 0.0, min=0.0, max=moves.MAX_DISTANCE_M, step=0.01,
                                           disabled=True, hint="how far the move travels in all"),
                "amount": gui.add_number("amount (×)", 1.0, min=0.0, max=moves.MAX_AMOUNT, step=0.05,
                                         disabled=True, hint="how far its keyframes lean, tilt and dip (1: as written)"),
            }  # fmt: skip
            self.btn_insert_move = gui.add_button("Insert at playhead")
            self.txt_move_name = gui.add_text("new move name", "")
            self.btn_save_move = gui.add_button("Save selection as a move")
        with gui.add_folder("Music", expand_by_default=False):
            self.btn_audio = gui.add_upload_button(
                "Load music (WAV)", hint="a PCM WAV file: its tempo and beats"
            )
            self.md_music = gui.add_markdown("*no music: load a WAV file to see its beats on the timeline*")
            self.num_bpm = gui.add_number(
                "tempo (bpm)", 120.0, min=music.MIN_BPM / 2, max=music.MAX_BPM * 2, step=0.5
            )
            self.num_beat_offset = gui.add_number("first beat (s)", 0.0, min=0.0, max=10.0, step=0.005)
            self.cb_snap_beats = gui.add_checkbox("snap to beats", False)
            self.html_audio = gui.add_html("")  # the loaded music, played with the preview (page.js)
            self.html_clock = gui.add_html(music.clock_html(0.0, False, 1.0, ""))
        with gui.add_folder("Timeline tools", expand_by_default=False):
            self.dd_grid = gui.add_dropdown("snap to", tuple(GRID_CHOICES), initial_value="0.05 s")
            self.btn_undo = gui.add_button("Undo")
            self.btn_redo = gui.add_button("Redo")
            self.btn_copy = gui.add_button("Copy selection")
            self.btn_paste = gui.add_button("Paste at playhead")
            self.btn_duplicate = gui.add_button("Duplicate selection")
            self.btn_delete_sel = gui.add_button("Delete selection", color="red")
            self.btn_zoom_all = gui.add_button("Show the whole maneuver")
        self.fd_legs = gui.add_folder("Legs (steps)", expand_by_default=True)
        self.fd_body = gui.add_folder("Body keyframes", expand_by_default=False)
        self.fd_gaits = gui.add_folder("Gaits", expand_by_default=False)
        with gui.add_folder("Weights", expand_by_default=False):
            self.num_weights = {
                w: self._number(w, WEIGHT_DEFAULTS[w], F.WEIGHTS, w, 1e-4 if w == "force" else 0.01)
                for w in WEIGHT_NAMES
            }
        self.fd_objectives = gui.add_folder("Objectives", expand_by_default=False)
        with gui.add_folder("Check and preview", expand_by_default=True):
            self.md_validation = gui.add_markdown("")
            self.btn_validate = gui.add_button("Validate")
            self.cb_physics = gui.add_checkbox(
                "physics check",
                True,
                hint="Validate also runs the whole maneuver headless in MuJoCo (a few seconds) and marks each "
                "event on the timeline with the margins measured (torque, friction, stability, touchdown errors)",
            )
            self.btn_preview = gui.add_button("Preview", color="green")
            self.btn_pause = gui.add_button("Play / pause")
            self.btn_restart = gui.add_button("Restart")
            self.sl_speed = gui.add_slider("speed (× real time)", 0.1, 2.0, 0.05, 1.0)
        with gui.add_folder("Replay and compare", expand_by_default=False):
            # the last preview shown at the playhead instead of the live robot; the run before it as a ghost
            self.cb_replay = gui.add_checkbox("replay the preview at the playhead", False)
            self.btn_frame_back = gui.add_button("◀ frame")
            self.btn_frame_fwd = gui.add_button("frame ▶")
            self.cb_ghost = gui.add_checkbox("ghost: the run before", True)
            self.md_replay = gui.add_markdown("*no preview recorded yet*")
        with gui.add_folder("File", expand_by_default=False):
            self.btn_save = gui.add_button("Save")
            self.txt_save_as = gui.add_text("save as name", "")
            self.btn_save_as = gui.add_button("Save as")
            self.btn_download = gui.add_button("Download YAML")
            self.btn_export = gui.add_button("Export preview (HTML)")
        self._bind_static()

    def _bind_static(self) -> None:
        @self.btn_open.on_click
        def _(_: Any) -> None:
            self.open(str(self.dd_library.value))

        @self.btn_new.on_click
        def _(_: Any) -> None:
            self.new_document()

        def meta_setter(key: str, conv: Callable[[Any], Any]) -> Callable[[Any], None]:
            def cb(event: Any) -> None:
                if self._suspend:
                    return
                with self.lock:
                    self.meta[key] = conv(event.target.value)
                if key == "duration":
                    self.sl_scrub.max = max(0.1, float(event.target.value))
                self._changed()

            return cb

        self.txt_name.on_update(meta_setter("name", lambda v: str(v).strip()))
        self.txt_title.on_update(meta_setter("title", lambda v: str(v) or None))
        self.num_duration.on_update(meta_setter("duration", float))
        self.num_friction.on_update(meta_setter("friction", float))

        for w, h in self.num_weights.items():

            def cb(event: Any, w: str = w) -> None:
                if self._suspend:
                    return
                with self.lock:
                    if self.weights is None:
                        self.weights = {}
                    self.weights[w] = float(event.target.value)
                self._changed()

            h.on_update(cb)

        @self.txt_timeline_ops.on_update
        def _(e: Any) -> None:
            text = str(e.target.value)
            if not text:
                return
            try:
                op = json.loads(text)
            except ValueError:
                return
            if isinstance(op, dict):
                self.timeline_op(op)

        @self.btn_audio.on_upload
        def _(e: Any) -> None:
            f = e.target.value
            self.load_music(bytes(f.content), str(f.name))

        def retime(_e: Any) -> None:
            if self.beats is not None and not self._suspend:
                self.beats = music.Beats(float(self.num_bpm.value), float(self.num_beat_offset.value),
                                         self.beats.duration_s)  # fmt: skip
                self._keep_music()
                self._refresh_timeline()

        self.num_bpm.on_update(retime)
        self.num_beat_offset.on_update(retime)
        self.btn_save_move.on_click(
            lambda _e: self.save_selection_as_move(str(self.txt_move_name.value).strip())
        )
        self.btn_insert_move.on_click(
            lambda _e: self.insert_move(
                str(self.dd_move.value), self._scrub_t(), int(self.num_move_repeat.value), self.move_params()
            )
        )
        self.dd_move.on_update(lambda e: self.show_move_params(str(e.target.value)))
        self.show_move_params(str(self.dd_move.value))
        self.dd_grid.on_update(lambda e: setattr(self, "grid_s", GRID_CHOICES.get(str(e.target.value), 0.0)))
        self.btn_undo.on_click(lambda _e: self.undo())
        self.btn_redo.on_click(lambda _e: self.redo())
        self.btn_copy.on_click(lambda _e: self.copy_selection())
        self.btn_paste.on_click(lambda _e: self.paste(self._scrub_t()))
        self.btn_duplicate.on_click(lambda _e: self.duplicate_selection())
        self.btn_delete_sel.on_click(lambda _e: self.delete_selection())
        self.btn_zoom_all.on_click(lambda _e: self.timeline_op({"op": "view", "t0": None, "t1": None}))
        actions: dict[str, Callable[[], Any]] = {
            "undo": self.undo, "redo": self.redo, "copy": self.copy_selection,
            "paste": lambda: self.paste(self._scrub_t()), "delete": self.delete_selection,
        }  # fmt: skip
        for label, hotkey, mod, action in EDIT_KEYS:
            fn = actions[action]
            try:
                cmd = self.gui.add_command(label, hotkey=hotkey, modifier=mod)  # type: ignore[arg-type]
            except Exception:  # noqa: BLE001 - hotkeys are a convenience (older viser)
                break
            cmd.on_trigger(lambda _e, fn=fn: fn())

        @self.sl_scrub.on_update
        def _(_: Any) -> None:
            self._refresh_timeline()
            self._refresh_scrub()

        @self.btn_validate.on_click
        def _(_: Any) -> None:
            self.validate_now(announce=True)

        @self.btn_preview.on_click
        def _(_: Any) -> None:
            self.preview()

        @self.btn_save.on_click
        def _(_: Any) -> None:
            self.save(None)

        @self.btn_save_as.on_click
        def _(_: Any) -> None:
            self.save(str(self.txt_save_as.value).strip())

        @self.btn_download.on_click
        def _(_: Any) -> None:
            name = str(self.meta.get("name") or "maneuver")
            self.client.send_file_download(
                f"{name}.yaml", self.yaml_text().encode("utf-8"), save_immediately=True
            )

    def _number(
        self, label: str, value: float, model: Any, name: str, step: float, *, is_time: bool = False
    ) -> Any:
        """Adds a number input whose limits and hint are the format's own (`model.name`)."""
        f = F.number(model, name, step, is_time=is_time)
        return self.gui.add_number(label, float(min(max(value, f.lo), f.hi)), min=f.lo, max=f.hi, step=step,
                                   hint=f.description)  # fmt: skip

    def _write_static_fields(self, keep_scrub: bool = False) -> None:
        self._suspend = True
        try:
            m = self.meta
            self.txt_name.value = str(m.get("name") or "")
            self.txt_title.value = str(m.get("title") or "")
            d = float(m.get("duration") or 3.0)
            self.num_duration.value = d
            self.num_friction.value = float(m.get("friction") or 0.6)
            self.sl_scrub.max = max(0.1, d)
            if not keep_scrub:
                self.sl_scrub.value = 0.0
            w = self.weights or {}
            for k, h in self.num_weights.items():
                h.value = float(w.get(k, WEIGHT_DEFAULTS[k]))
            self.txt_save_as.value = ""
        finally:
            self._suspend = False
        self._refresh_header()

    def _refresh_header(self) -> None:
        name = self.meta.get("name") or "(unnamed)"
        where = {"shipped": "shipped library (read-only: save as a new name)", "user": "your library"}.get(
            self.source or "", "not saved yet"
        )
        star = " *(modified)*" if self.dirty else ""
        self.md_header.content = f"**{name}** · {where}{star}"

    # ---- items ------------------------------------------------------------------------------------------------
    def _steps_of(self, leg: str) -> list[tuple[dict[str, Any] | None, dict[str, Any] | None]]:
        """Returns the leg's events paired in time order: (liftoff, touchdown), a lone one paired with None."""
        evs = sorted((e for e in self.events if e.get("leg") == leg), key=lambda e: float(e.get("t", 0.0)))
        out: list[tuple[dict[str, Any] | None, dict[str, Any] | None]] = []
        open_lo: dict[str, Any] | None = None
        for e in evs:
            if e.get("type") == "liftoff":
                if open_lo is not None:
                    out.append((open_lo, None))
                open_lo = e
            else:
                out.append((open_lo, e))
                open_lo = None
        if open_lo is not None:
            out.append((open_lo, None))
        return out

    def _clear_items(self) -> None:
        folders = {id(ui.folder): ui.folder for ui in self.item_ui.values()}  # a step's two events share one
        with warnings.catch_warnings():  # a step folder goes with its leg folder; removing both is harmless
            warnings.simplefilter("ignore")
            for h in [*folders.values(), *self._holder_items]:
                try:
                    h.remove()
                except Exception:  # noqa: BLE001 - already gone (with the client)
                    pass
        self.item_ui.clear()
        self._holder_items.clear()

    def rebuild_items(self) -> None:
        """Recreates the item folders (after open, add or delete) and the 3D markers."""
        with self.lock:
            self._suspend = True
            try:
                self._clear_items()
                keep = self._holder_items
                with self.fd_legs:
                    for leg in LEG_ROWS:
                        with self.gui.add_folder(leg, expand_by_default=False) as fl:
                            btn = self.gui.add_button(f"Add {leg} step at scrub time")
                            btn.on_click(lambda _e, leg=leg: self.add_step(leg))
                            for lo, td in self._steps_of(leg):
                                self._step_folder(leg, lo, td)
                        keep.append(fl)
                with self.fd_body:
                    keep.append(self.gui.add_button("Add keyframe at scrub time"))
                    keep[-1].on_click(lambda _e: self.add_keyframe())
                    for kf in sorted(self.keyframes, key=lambda k: float(k.get("t", 0.0))):
                        self._keyframe_folder(kf)
                with self.fd_gaits:
                    keep.append(self.gui.add_button("Add gait segment at scrub time"))
                    keep[-1].on_click(lambda _e: self.add_gait())
                    for g in self.gaits:
                        self._gait_folder(g)
                with self.fd_objectives:
                    keep.append(self.gui.add_button("Add objective"))
                    keep[-1].on_click(lambda _e: self.add_objective())
                    for o in self.objectives:
                        self._objective_folder(o)
            finally:
                self._suspend = False
        self._refresh_timeline()
        self.refresh_markers()
        self._apply_problems()

    def _problem_md(self) -> Any:
        md = self.gui.add_markdown("")
        md.visible = False
        return md

    def _step_folder(self, leg: str, lo: dict[str, Any] | None, td: dict[str, Any] | None) -> None:
        gui = self.gui

        def relabel() -> str:
            t0 = float(lo["t"]) if lo else None
            t1 = float(td["t"]) if td else None
            return (f"step {t0:.2f} → {t1:.2f} s" if lo and td else
                    f"liftoff {t0:.2f} s (no touchdown)" if lo else f"touchdown {t1:.2f} s (no liftoff)")  # fmt: skip

        label = relabel()
        with gui.add_folder(label, expand_by_default=False) as f:
            md = self._problem_md()
            h: dict[str, Any] = {}
            if lo is not None:
                h["lo_t"] = self._number("liftoff t (s)", float(lo["t"]), F.LIFTOFF, "t", 0.01, is_time=True)
                h["lo_t"].on_update(lambda e, it=lo: self._set(it, "t", float(e.target.value)))
            if td is not None:
                h["td_t"] = self._number(
                    "touchdown t (s)", float(td["t"]), F.TOUCHDOWN, "t", 0.01, is_time=True
                )
                h["td_t"].on_update(lambda e, it=td: self._set(it, "t", float(e.target.value)))
                mode = (
                    "at"
                    if td.get("at") is not None
                    else "offset"
                    if td.get("offset") is not None
                    else "in place"
                )
                h["mode"] = gui.add_dropdown("target", TARGET_MODES, initial_value=mode)
                vec = td.get("at") or td.get("offset") or [0.0, 0.0, 0.0]
                vec = [float(v) for v in vec] + [0.0] * (3 - len(vec))
                h["vec"] = gui.add_vector3("target / offset (m)", tuple(vec[:3]), step=0.005)
                h["vec"].disabled = mode == "in place"
                adj = td.get("adjust") or {}
                h["adj_t"] = self._number(
                    "adjust ± time (s)", float(adj.get("time", 0.0)), F.ADJUST, "time", 0.01
                )
                h["adj_r"] = self._number("adjust radius (m)", float(adj.get("radius") or 0.0), F.ADJUST, "radius",
                                          0.005)  # fmt: skip
                n = td.get("normal") or [0.0, 0.0, 1.0]
                h["normal"] = gui.add_vector3("contact normal", tuple(float(v) for v in n[:3]), step=0.05)
                h["mode"].on_update(lambda e, it=td, hh=h: self._set_target_mode(it, str(e.target.value), hh))
                h["vec"].on_update(lambda e, it=td, hh=h: self._set_target_vec(it, e.target.value, hh))
                h["adj_t"].on_update(lambda e, it=td: self._set_adjust(it, "time", float(e.target.value)))
                h["adj_r"].on_update(lambda e, it=td: self._set_adjust(it, "radius", float(e.target.value)))
                h["normal"].on_update(
                    lambda e, it=td: self._set(it, "normal", [_r(v) for v in e.target.value])
                )
                gui.add_button("Move target in 3D").on_click(lambda _e, it=td: self.select(id(it)))
            gui.add_button("Delete", color="red").on_click(lambda _e, a=lo, b=td: self.delete_items(a, b))
        ui = ItemUi(f, md, label, h, relabel)
        for it in (lo, td):
            if it is not None:
                self.item_ui[id(it)] = ui

    def _keyframe_folder(self, kf: dict[str, Any]) -> None:
        gui = self.gui

        def relabel() -> str:
            return f"keyframe {float(kf.get('t', 0.0)):.2f} s"

        label = relabel()
        with gui.add_folder(label, expand_by_default=False) as f:
            md = self._problem_md()
            h = {
                "t": self._number("t (s)", float(kf.get("t", 0.0)), F.KEYFRAME, "t", 0.01, is_time=True),
                "pos": gui.add_vector3("position (m)", tuple(float(v) for v in kf.get("position", [0, 0, 0.52])),
                                       step=0.005),
                "rpy": gui.add_vector3("roll, pitch, yaw (deg)", tuple(float(v) for v in kf.get("rpy", [0, 0, 0])),
                                       step=0.5),
                "w": self._number("weight", float(kf.get("weight", 1.0)), F.KEYFRAME, "weight", 0.1),
            }  # fmt: skip
            h["t"].on_update(lambda e, it=kf: self._set(it, "t", float(e.target.value)))
            h["pos"].on_update(
                lambda e, it=kf: self._set(it, "position", [_r(v) for v in e.target.value], marker=True)
            )
            h["rpy"].on_update(
                lambda e, it=kf: self._set(it, "rpy", [_r(v, 2) for v in e.target.value], marker=True)
            )
            h["w"].on_update(lambda e, it=kf: self._set(it, "weight", float(e.target.value)))
            gui.add_button("Move in 3D").on_click(lambda _e, it=kf: self.select(id(it)))
            gui.add_button("Delete", color="red").on_click(lambda _e, it=kf: self.delete_items(it))
        self.item_ui[id(kf)] = ItemUi(f, md, label, h, relabel)

    def _gait_folder(self, g: dict[str, Any]) -> None:
        gui = self.gui

        def relabel() -> str:
            return (
                f"{g.get('gait', 'trot')} {float(g.get('from', 0.0)):.2f} → {float(g.get('to', 0.0)):.2f} s"
            )

        label = relabel()
        with gui.add_folder(label, expand_by_default=False) as f:
            md = self._problem_md()
            h = {
                "gait": gui.add_dropdown("gait", GAITS, initial_value=g.get("gait", "trot")
                                         if g.get("gait") in GAITS else "trot"),
                "from": self._number("from (s)", float(g.get("from", 0.0)), F.GAIT, "from_", 0.05, is_time=True),
                "to": self._number("to (s)", float(g.get("to", 1.0)), F.GAIT, "to", 0.05, is_time=True),
                "cycle": self._number("cycle (s)", float(g.get("cycle", 0.5)), F.GAIT, "cycle", 0.01),
                "duty": self._number("duty", float(g.get("duty", 0.6)), F.GAIT, "duty", 0.01),
                "step": gui.add_vector3("step dx, dy (m), dyaw (deg)",
                                        tuple(float(v) for v in g.get("step", [0.0, 0.0, 0.0])), step=0.01),
            }  # fmt: skip
            h["gait"].on_update(lambda e, it=g: self._set(it, "gait", str(e.target.value)))
            for key in ("from", "to", "cycle", "duty"):
                h[key].on_update(lambda e, it=g, key=key: self._set(it, key, float(e.target.value)))
            h["step"].on_update(lambda e, it=g: self._set(it, "step", [_r(v) for v in e.target.value]))
            gui.add_button("Delete", color="red").on_click(lambda _e, it=g: self.delete_items(it))
        self.item_ui[id(g)] = ItemUi(f, md, label, h, relabel)

    def _objective_folder(self, o: dict[str, Any]) -> None:
        gui = self.gui
        kind = str(o.get("type")) if o.get("type") in OBJECTIVES else OBJECTIVES[0]
        t = o.get("t", [0.0, 0.0])
        t = [float(t), float(t)] if isinstance(t, (int, float)) else [float(v) for v in (t or [0.0, 0.0])[:2]]
        with gui.add_folder(f"{kind}", expand_by_default=False) as f:
            md = self._problem_md()
            h = {
                "type": gui.add_dropdown("type", OBJECTIVES, initial_value=kind),
                "t": gui.add_vector2("t start, end (s)", (t[0], t[1]) if len(t) == 2 else (0.0, 0.0), step=0.05),
                "w": self._number("weight", float(o.get("weight", 1.0)), F.objective_models()[kind], "weight", 0.1),
                "dir": gui.add_vector2("lean direction x, y", tuple(float(v) for v in o.get("direction", [1.0, 0.0])),
                                       step=0.1),
            }  # fmt: skip
            h["dir"].visible = kind == "lean"
            h["type"].on_update(lambda e, it=o: self._set_objective_type(it, str(e.target.value)))
            h["t"].on_update(lambda e, it=o: self._set(it, "t", [_r(v, 3) for v in e.target.value]))
            h["w"].on_update(lambda e, it=o: self._set(it, "weight", float(e.target.value)))
            h["dir"].on_update(lambda e, it=o: self._set(it, "direction", [_r(v, 3) for v in e.target.value]))
            gui.add_button("Delete", color="red").on_click(lambda _e, it=o: self.delete_items(it))
        self.item_ui[id(o)] = ItemUi(f, md, str(kind), h, lambda: str(o.get("type", kind)))

    # ---- edits ------------------------------------------------------------------------------------------------
    def _set(self, item: dict[str, Any], key: str, value: Any, marker: bool = False) -> None:
        if self._suspend:
            return
        with self.lock:
            item[key] = value
        self._relabel(item)
        if key == "t":
            self._refresh_timeline()
        if marker:
            self.refresh_markers()
        self._changed()

    def _relabel(self, item: dict[str, Any]) -> None:
        """Retitles the item's folder after an edit (its times, its gait), keeping its problem mark."""
        ui = self.item_ui.get(id(item))
        if ui is None or ui.relabel is None:
            return
        ui.label = ui.relabel()
        sev = self._severity(id(item))
        try:
            ui.folder.label = ("✖ " if sev == "failure" else "⚠ " if sev else "") + ui.label
        except Exception:  # noqa: BLE001 - the client may be gone
            pass

    def _set_adjust(self, td: dict[str, Any], key: str, value: float) -> None:
        if self._suspend:
            return
        with self.lock:
            adj = dict(td.get("adjust") or {})
            if key == "radius" and value <= 0.0:
                adj.pop("radius", None)
            else:
                adj[key] = value
            if key == "radius":
                adj.pop("region", None)
            td["adjust"] = adj if adj else None
            if td["adjust"] is None:
                del td["adjust"]
        self._changed()

    def _set_target_mode(self, td: dict[str, Any], mode: str, h: dict[str, Any]) -> None:
        if self._suspend:
            return
        p_world = self._resolved_target(td)
        with self.lock:
            td.pop("at", None)
            td.pop("offset", None)
            if mode == "at":
                p = p_world if p_world is not None else np.zeros(3)
                td["at"] = [_r(v) for v in p]
            elif mode == "offset":
                td["offset"] = [0.0, 0.0, 0.0]
        vec = td.get("at") or td.get("offset") or [0.0, 0.0, 0.0]
        self._suspend = True
        try:
            h["vec"].value = tuple(float(v) for v in vec)
            h["vec"].disabled = mode == "in place"
        finally:
            self._suspend = False
        self.refresh_markers()
        self._changed()

    def _set_target_vec(self, td: dict[str, Any], value: Any, h: dict[str, Any]) -> None:
        if self._suspend:
            return
        mode = str(h["mode"].value)
        with self.lock:
            if mode == "at":
                td["at"] = [_r(v) for v in value]
            elif mode == "offset":
                td["offset"] = [_r(v) for v in value]
        self.refresh_markers()
        self._changed()

    def _set_objective_type(self, o: dict[str, Any], kind: str) -> None:
        if self._suspend:
            return
        with self.lock:
            o["type"] = kind
            if kind == "lean":
                o.setdefault("direction", [1.0, 0.0])
            else:
                o.pop("direction", None)
        ui = self.item_ui.get(id(o))
        if ui is not None:
            ui.handles["dir"].visible = kind == "lean"
        self._relabel(o)
        self._changed()

    def _scrub_t(self) -> float:
        return float(self.sl_scrub.value)

    def add_step(self, leg: str) -> None:
        t = self._scrub_t()
        d = float(self.meta.get("duration") or 3.0)
        t0 = min(t, max(0.0, d - 0.5))
        with self.lock:
            self.events.append({"t": _r(t0, 3), "leg": leg, "type": "liftoff"})
            self.events.append(
                {"t": _r(t0 + 0.35, 3), "leg": leg, "type": "touchdown", "offset": [0.1, 0.0, 0.0]}
            )
        self._changed(structural=True)

    def add_keyframe(self) -> None:
        t = self._scrub_t()
        p, rpy = self._reference_at(t)
        with self.lock:
            self.keyframes.append({"t": _r(t, 3), "position": [_r(v) for v in p], "rpy": [_r(v, 2) for v in rpy],
                                   "weight": 1.0})  # fmt: skip
        self._changed(structural=True)

    def add_gait(self) -> None:
        t = self._scrub_t()
        d = float(self.meta.get("duration") or 3.0)
        with self.lock:
            self.gaits.append({"gait": "trot", "from": _r(t, 2), "to": _r(min(d, t + 2.0), 2), "cycle": 0.5,
                               "duty": 0.6, "step": [0.1, 0.0, 0.0]})  # fmt: skip
        self._changed(structural=True)

    def add_objective(self) -> None:
        t = self._scrub_t()
        with self.lock:
            self.objectives.append(
                {"type": "maximize_height", "t": [_r(t, 2), _r(t + 0.2, 2)], "weight": 1.0}
            )
        self._changed(structural=True)

    # ---- the timeline worked with the mouse ---------------------------------------------------------------------
    def load_music(self, data: bytes, name: str = "music") -> music.Beats | None:
        """Finds the tempo and beats of a WAV file's bytes and shows them on the timeline."""
        try:
            x, rate = music.read_wav(data)
        except music.AudioError as e:
            self.notify("Music not loaded", f"{name}: {e}", "red")
            return None
        b = music.find_beats(x, rate)
        self.beats = b
        try:
            self.html_audio.content = music.audio_html(music.playable_wav(x, rate))
        except Exception:  # noqa: BLE001 - no GUI
            pass
        self._suspend = True
        try:
            self.num_bpm.value = b.bpm
            self.num_beat_offset.value = b.offset_s
        finally:
            self._suspend = False
        self.md_music.content = (
            f"**{name}**: {b.bpm:g} bpm, first beat at {b.offset_s:.3f} s, {b.duration_s:.1f} s long"
        )
        self.cb_snap_beats.value = True
        self._keep_music(name)
        self._refresh_timeline()
        return b

    def show_clock(self, state: dict[str, Any]) -> None:
        """Tells the tab where the preview is (the page plays the loaded music in step with it): called with the
        live session's state a few times a second; writes only when something changed."""
        if not self.html_audio.content:
            return
        playing = (state.get("status") == "running" and state.get("mode") == "maneuver"
                   and not state.get("done") and not state.get("fell"))  # fmt: skip
        t = float(state.get("t") or 0.0)
        html_ = music.clock_html(t if playing else round(t, 1), playing, float(state.get("speed") or 1.0),
                                 f"{state.get('generation')}:{state.get('maneuver')}")  # fmt: skip
        if html_ != self.html_clock.content:
            self.html_clock.content = html_

    def _keep_music(self, file: str | None = None) -> None:
        """Writes the music's tempo and first beat into the document (`music`: the file keeps them)."""
        if self.beats is None:
            return
        with self.lock:
            old = self.meta.get("music") if isinstance(self.meta.get("music"), dict) else {}
            kept: dict[str, Any] = {
                "bpm": _r(float(self.beats.bpm), 3),
                "offset": _r(float(self.beats.offset_s), 4),
            }
            name = file if file is not None else (old or {}).get("file")
            if name:
                kept["file"] = str(name)[:200]
            if old == kept:
                return
            self.meta["music"] = kept
        self._changed()

    def _music_from_document(self) -> None:
        """Shows the beat grid of a document's `music` (tempo and first beat; the audio is the user's to load)."""
        m = self.meta.get("music")
        if not isinstance(m, dict) or not isinstance(m.get("bpm"), (int, float)):
            return
        offset = float(m.get("offset") or 0.0)
        self.beats = music.Beats(float(m["bpm"]), offset, float(self.meta.get("duration") or 60.0))
        self._suspend = True
        try:
            self.num_bpm.value = float(m["bpm"])
            self.num_beat_offset.value = offset
            name = f"**{m['file']}**" if m.get("file") else "the maneuver's music"
            self.md_music.content = (
                f"{name}: {float(m['bpm']):g} bpm, first beat at {offset:.3f} s (kept in the file)"
            )
        except Exception:  # noqa: BLE001 - no GUI
            pass
        finally:
            self._suspend = False

    def _snap(self, t: float) -> float:
        if self.beats is not None and bool(self.cb_snap_beats.value):
            return _r(self.beats.snap(t), 4)
        g = self.grid_s
        return _r(round(t / g) * g, 4) if g > 0 else _r(t, 4)

    def _timed_items(self) -> dict[int, tuple[str, dict[str, Any]]]:
        """Returns the items with a time on the timeline (events, keyframes) by id, with their kind."""
        out: dict[int, tuple[str, dict[str, Any]]] = {id(e): ("event", e) for e in self.events}
        out.update({id(k): ("keyframe", k) for k in self.keyframes})
        return out

    def timeline_op(self, op: dict[str, Any]) -> None:
        """Applies one operation sent by the timeline (see page.js): a drag of items or of a part of one, a
        selection, the visible window, the playhead. Times are snapped to the grid."""
        n = op.get("n")
        if isinstance(n, int):
            if n == self._last_op:
                return  # the same op delivered twice
            self._last_op = n
        kind = op.get("op")
        try:
            ids = [int(i) for i in op.get("ids") or []]
            if kind == "drag":
                self.drag(ids, str(op.get("part", "move")), float(op["dt"]))
            elif kind == "select":
                self.select_items(ids, add=bool(op.get("add")))
            elif kind == "scrub":
                d = float(self.meta.get("duration") or 1.0)
                self.sl_scrub.value = float(min(max(self._snap(float(op["t"])), 0.0), d))
            elif kind == "view":
                t0, t1 = op.get("t0"), op.get("t1")
                d = float(self.meta.get("duration") or 1.0)
                if t0 is None or t1 is None:
                    self.view = None
                else:
                    lo, hi = max(0.0, float(t0)), min(d, float(t1))
                    self.view = None if hi - lo >= d - 1e-6 or hi - lo < 0.05 else (lo, hi)
                self._refresh_timeline()
        except (KeyError, TypeError, ValueError):
            log.info("timeline op ignored: %r", op)

    def select_items(self, ids: list[int], add: bool = False) -> None:
        items = self._timed_items()
        with self.lock:
            if not add:
                self.selected.clear()
            self.selected ^= {i for i in ids if i in items} if add else {i for i in ids if i in items}
        self._refresh_timeline()

    def drag(self, ids: list[int], part: str, dt: float) -> None:
        """Moves items by dt (s): `move` every item given (and the selection, when one of them is selected),
        `start`/`end` one end of a swing, `adjust` a touchdown's ± time window by dt. The first item's new time lands
        on the grid; the maneuver's bounds hold."""
        items = self._timed_items()
        group = [i for i in ids if i in items]
        if not group:
            return
        d = float(self.meta.get("duration") or 1.0)
        with self.lock:
            if part == "adjust":
                td = items[group[0]][1]
                adj = dict(td.get("adjust") or {})
                adj["time"] = max(0.0, self._snap(float(adj.get("time", 0.0)) + dt))
                td["adjust"] = adj
            else:
                if part == "move" and set(group) & self.selected:
                    group = list(dict.fromkeys([*group, *sorted(self.selected & set(items))]))
                times = [float(items[i][1].get("t", 0.0)) for i in group]
                shift = self._snap(times[0] + dt) - times[0]
                shift = min(max(shift, -min(times)), d - max(times))  # the whole group stays in [0, duration]
                for i, t in zip(group, times, strict=True):
                    items[i][1]["t"] = _r(t + shift, 4)
        self._changed(structural=True)

    def user_moves_dir(self) -> Path:
        return Path(self.services.settings.data_dir) / "moves"

    def save_selection_as_move(self, name: str) -> Path | None:
        """Writes the selected events and keyframes (from time 0, the body back at its nominal pose at the end) as a
        move in the user's moves folder; returns its path (None, after telling the user, when it cannot)."""
        if not self.authorized("save a move"):
            return None
        if not re.match(NAME_PATTERN, name or "") or len(name) > 64:
            self.notify("Move not saved", "name: lowercase letters, digits and dashes (e.g. my-step)", "red")
            return None
        items = self._timed_items()
        chosen = [items[i] for i in self.selected if i in items]
        if not chosen:
            self.notify("Move not saved", "select events or keyframes on the timeline first", "yellow")
            return None
        t0 = min(float(it["t"]) for _, it in chosen)
        p_ref, _ = self._reference_at(t0)
        dxy = np.array([p_ref[0], p_ref[1], 0.0])
        events, body = [], []
        for kind, it in sorted(chosen, key=lambda c: float(c[1]["t"])):
            c = {**copy.deepcopy(it), "t": _r(float(it["t"]) - t0)}
            if kind == "keyframe":
                c["position"] = [_r(v) for v in np.asarray(c["position"], dtype=float) - dxy]
                body.append(c)
            else:
                if c.get("at") is not None:
                    c["at"] = [_r(v) for v in np.asarray(c["at"], dtype=float) - dxy]
                events.append(c)
        end = max(float(c["t"]) for c in [*events, *body]) + 0.8
        h = float(getattr(self.services.robot, "standing_height_m", 0.52))
        body.append(
            {"t": _r(end - 0.1), "position": [0.0, 0.0, _r(h)], "rpy": [0.0, 0.0, 0.0], "weight": 5.0}
        )
        doc: dict[str, Any] = {"format": FORMAT, "name": name, "title": name.replace("-", " ").capitalize(),
                               "duration": _r(end, 2), "start": "stand", "tracks": ["legs", "body"]}  # fmt: skip
        if events:
            doc["events"] = events
        doc["body"] = body
        result = validate_maneuver(doc, self.services.robot)
        if not result.ok:
            self.notify("Move not saved", f"{result.failures[0].path}: {result.failures[0].message}", "red")
            return None
        path = self.user_moves_dir() / f"{name}.yaml"
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".yaml.tmp")
        tmp.write_text(dump_yaml(doc), encoding="utf-8")
        tmp.replace(path)
        self.dd_move.options = move_names(self.user_moves_dir())
        self.dd_move.value = name
        self.notify("Move saved", f"{name}: {len(events)} events, {len(body)} keyframes", "green")
        return path

    def _read_move(self, name: str) -> dict[str, Any] | None:
        path = self.user_moves_dir() / f"{name}.yaml"
        if not path.is_file():
            path = MOVES_DIR / f"{name}.yaml"
        try:
            data, _ = read_yaml(path.read_text(encoding="utf-8"))
        except (OSError, ManeuverError) as e:
            self.notify("Cannot insert", f"{name}: {e}", "red")
            return None
        return data if isinstance(data, dict) else None

    def show_move_params(self, name: str) -> dict[str, float]:
        """Sets the parameter inputs to a move's own values, enabling those it has; returns them."""
        data = self._read_move(name) if name and name != "(none)" else None
        nat = moves.natural_params(data) if data is not None else {}
        self._move_natural = nat
        for key, num in getattr(self, "num_move_params", {}).items():
            try:
                num.value = nat.get(key, 1.0 if key == "amount" else 0.0)
                num.disabled = key not in nat
            except Exception:  # noqa: BLE001 - the client may be gone
                pass
        return nat

    def move_params(self) -> dict[str, float]:
        """Returns the parameters set in the inputs that differ from the picked move's own values."""
        nat = getattr(self, "_move_natural", {})
        out = {}
        for key, num in getattr(self, "num_move_params", {}).items():
            if key in nat and abs(float(num.value) - nat[key]) > 1e-6:
                out[key] = float(num.value)
        return out

    def insert_move(
        self, name: str, t0: float, repeat: int = 1, params: dict[str, float] | None = None
    ) -> int:
        """Inserts a move (maneuvers/moves/NAME.yaml) `repeat` times back to back from t0 (s): its events, keyframes,
        gaits and objectives shift by t0, its positions by where the body is planned to be at t0 (x, y); the
        maneuver grows to hold it. `params` (angle, distance, amount; server.studio.moves) rescale it first.
        Returns how many items it added (0, after telling the user, when it cannot)."""
        data = self._read_move(name)
        if data is None:
            return 0
        if params:
            try:
                h = float(getattr(self.services.robot, "standing_height_m", 0.52))
                data = moves.scale_move(data, standing_height_m=h, **params)
            except (ValueError, TypeError) as e:
                self.notify("Cannot insert", f"{name}: {e}", "red")
                return 0
        repeat = int(min(max(repeat, 1), MAX_REPEAT))
        dur = float(data.get("duration") or 0.0)
        t0 = self._snap(t0)
        added: list[dict[str, Any]] = []
        with self.lock:
            for k in range(repeat):
                ts = t0 + k * dur
                p_ref, _ = self._reference_at(ts)
                dxy = np.array([p_ref[0], p_ref[1], 0.0])
                for ev in data.get("events") or []:
                    c = {**copy.deepcopy(ev), "t": _r(float(ev["t"]) + ts)}
                    if c.get("at") is not None:
                        c["at"] = [_r(v) for v in np.asarray(c["at"], dtype=float) + dxy]
                    self.events.append(c)
                    added.append(c)
                for kf in data.get("body") or []:
                    c = {**copy.deepcopy(kf), "t": _r(float(kf["t"]) + ts)}
                    c["position"] = [_r(v) for v in np.asarray(c["position"], dtype=float) + dxy]
                    self.keyframes.append(c)
                    added.append(c)
                for g in data.get("gaits") or []:
                    self.gaits.append({**copy.deepcopy(g), "from": _r(float(g["from"]) + ts),
                                       "to": _r(float(g["to"]) + ts)})  # fmt: skip
                for o in data.get("objectives") or []:
                    c = copy.deepcopy(o)
                    if isinstance(c.get("t"), list):
                        c["t"] = [_r(float(v) + ts) for v in c["t"]]
                    elif c.get("t") is not None:
                        c["t"] = _r(float(c["t"]) + ts)
                    self.objectives.append(c)
            end = t0 + repeat * dur
            if end > float(self.meta.get("duration") or 0.0):
                self.meta["duration"] = _r(end, 2)
            self.selected = {id(c) for c in added}
        self._write_static_fields(keep_scrub=True)
        self._changed(structural=True)
        said = ", ".join(f"{k} {v:g}" for k, v in (params or {}).items())
        self.notify("Inserted", f"{name}{f' ({said})' if said else ''} × {repeat} at {t0:.2f} s", "green")
        return len(added)

    def copy_selection(self) -> int:
        """Copies the selected items (times relative to the earliest); returns how many."""
        items = self._timed_items()
        with self.lock:
            chosen = [items[i] for i in self.selected if i in items]
            if not chosen:
                return 0
            t0 = min(float(it.get("t", 0.0)) for _, it in chosen)
            self.clipboard = [
                (k, {**copy.deepcopy(it), "t": float(it.get("t", 0.0)) - t0}) for k, it in chosen
            ]
        return len(chosen)

    def paste(self, t: float) -> int:
        """Inserts the clipboard's items from time t (s); the pasted items become the selection."""
        if not self.clipboard:
            return 0
        d = float(self.meta.get("duration") or 1.0)
        with self.lock:
            new = []
            for kind, it in self.clipboard:
                c = copy.deepcopy(it)
                c["t"] = _r(min(self._snap(t) + float(it["t"]), d), 4)
                (self.events if kind == "event" else self.keyframes).append(c)
                new.append(c)
            self.selected = {id(c) for c in new}
        self._changed(structural=True)
        return len(new)

    def duplicate_selection(self) -> int:
        """Copies the selection and pastes it right after its end."""
        items = self._timed_items()
        with self.lock:
            chosen = [items[i][1] for i in self.selected if i in items]
        if not chosen or not self.copy_selection():
            return 0
        t0 = min(float(it["t"]) for it in chosen)
        span = max(float(it["t"]) for it in chosen) - t0
        return self.paste(t0 + span + max(self.grid_s, 0.05))

    def delete_selection(self) -> int:
        items = self._timed_items()
        chosen = [items[i][1] for i in self.selected if i in items]
        if chosen:
            self.selected.clear()
            self.delete_items(*chosen)
        return len(chosen)

    def delete_items(self, *items: dict[str, Any] | None) -> None:
        ids = {id(i) for i in items if i is not None}
        with self.lock:
            self.events = [e for e in self.events if id(e) not in ids]
            self.keyframes = [k for k in self.keyframes if id(k) not in ids]
            self.gaits = [g for g in self.gaits if id(g) not in ids]
            self.objectives = [o for o in self.objectives if id(o) not in ids]
            if self.gizmo_item in ids:
                self._drop_gizmo()
        self._changed(structural=True)

    # ================================================================================================================
    # validation
    # ================================================================================================================
    def close(self, timeout_s: float = 20.0) -> None:
        """Stops the background validation (the tab is going): a check still running native solver code when the
        interpreter exits aborts the process, so this waits for it."""
        with self.lock:
            self._closed = True
            timer = self._validate_timer
            if timer is not None:
                timer.cancel()
        if timer is not None and timer is not threading.current_thread() and timer.is_alive():
            timer.join(timeout_s)
        with self._checks_done:  # earlier timers that had already started (cancel cannot stop those)
            self._checks_done.wait_for(lambda: self._checks_running == 0, timeout_s)

    def request_validation(self, delay_s: float = 0.4) -> None:
        """Validates after `delay_s` of quiet (edits in a burst validate once)."""
        with self.lock:
            if getattr(self, "_closed", False):
                return
            if self._validate_timer is not None:
                self._validate_timer.cancel()
            self._validate_timer = threading.Timer(delay_s, self._validate_quietly)
            self._validate_timer.daemon = True
            self._validate_timer.start()

    def _validate_quietly(self) -> None:
        with self._checks_done:
            if getattr(self, "_closed", False):
                return
            self._checks_running += 1
        try:
            self.validate_now()
        except Exception:  # noqa: BLE001 - a background check must not kill its timer thread noisily
            log.exception("studio validation")
        finally:
            with self._checks_done:
                self._checks_running -= 1
                self._checks_done.notify_all()

    def validate_now(self, announce: bool = False) -> Any:
        """Validates the document, shows the problems on their items; returns the result (None: shape errors).
        announce (the Validate button): also starts the physics check in the background when its box is ticked."""
        rev = self._rev
        doc, ev_ids, kf_ids = self.document()
        try:
            maneuver = parse_maneuver(doc)
        except ManeuverError as e:
            problems, result = list(e.problems), None
        else:
            from server.services import robot_model

            # the one validation (CLI and REST call it too), for the tab's picked robot
            result = check_maneuver(maneuver, robot_model(self.services, self.robot_load()))
            problems = [*result.failures, *result.warnings]
        physics = bool(announce and result is not None and result.ok and self._physics_wanted())
        if not self._show_result(rev, result, problems, ev_ids, kf_ids):
            return result
        if announce and not physics:
            n_f = sum(1 for p in problems if p.severity == "failure")
            n_w = len(problems) - n_f
            self.notify("Validation", "valid" if n_f == 0 else f"{n_f} failures, {n_w} warnings",
                        "green" if n_f == 0 else "red")  # fmt: skip
        if physics:
            self._start_physics(rev, maneuver, result, ev_ids, kf_ids)
        return result

    def _physics_wanted(self) -> bool:
        try:
            return bool(self.cb_physics.value)
        except Exception:  # noqa: BLE001 - no GUI (a test's editor)
            return True

    def _show_result(
        self, rev: int, result: Any, problems: list[Any], ev_ids: list[int], kf_ids: list[int]
    ) -> bool:
        """Shows a validation's problems on their items and the timeline; False when a newer document's are shown."""
        with self.lock:
            if rev < self._shown_rev:
                return False  # a newer document's problems are shown already
            self._shown_rev = rev
            self.result = result
            if getattr(result, "physics", None) is not None:
                self.physics, self._physics_rev = result.physics, rev
            self.problems_by_item = {}
            self.general_problems = []
            for p in problems:
                target = self._item_of_path(p.path, ev_ids, kf_ids)
                if target is None:
                    self.general_problems.append(p)
                else:
                    self.problems_by_item.setdefault(target, []).append(p)
        self._apply_problems()
        self._refresh_timeline()
        self.refresh_markers()
        self._refresh_scrub()
        return True

    def _start_physics(
        self, rev: int, maneuver: Any, result: Any, ev_ids: list[int], kf_ids: list[int]
    ) -> None:
        """Runs the physics check on the simulation pool in a background thread (close waits for it); its marks
        and problems are shown if the document did not change meanwhile."""
        with self._checks_done:
            if getattr(self, "_closed", False):
                return
            self._checks_running += 1
        try:
            self.md_validation.content += "\n\n⏳ physics check: simulating the maneuver headless…"
        except Exception:  # noqa: BLE001
            pass

        def work() -> None:
            from planning.maneuver.physics import skipped, with_physics
            from server.services import PhysicsUnavailable, physics_report
            from server.simulations import QueueFull

            try:
                try:
                    checked = with_physics(result, physics_report(maneuver, self.services, self.robot_load()))
                except (PhysicsUnavailable, QueueFull) as e:
                    checked = skipped(result, f"the physics check could not run: {e}")
                if rev != self._rev:
                    return  # edited meanwhile: these marks belong to an older document
                problems = [*checked.failures, *checked.warnings]
                self._show_result(rev, checked, problems, ev_ids, kf_ids)
                ph = checked.physics or {}
                if not ph.get("ran"):
                    self.notify("Physics check not run", str(ph.get("reason", "")), "yellow")
                elif checked.ok:
                    self.notify("Validation", f"valid — the physics check succeeded ({len(checked.warnings)} "
                                              "warnings)", "green")  # fmt: skip
                else:
                    first = checked.failures[0] if checked.failures else ""
                    self.notify("Validation", f"the physics check fails: {first}"[:300], "red")
            except Exception:  # noqa: BLE001 - a background check must not die noisily
                log.exception("studio physics check")
            finally:
                with self._checks_done:
                    self._checks_running -= 1
                    self._checks_done.notify_all()

        threading.Thread(target=work, name="footfall-physics-check", daemon=True).start()

    def _item_of_path(self, path: str, ev_ids: list[int], kf_ids: list[int]) -> int | None:
        m = _PATH_RE.match(path or "")
        if not m:
            return None
        kind, k = m.group(1), int(m.group(2))
        if kind == "events":
            return ev_ids[k] if k < len(ev_ids) else None
        if kind == "body":
            return kf_ids[k] if k < len(kf_ids) else None
        items = self.gaits if kind == "gaits" else self.objectives
        return id(items[k]) if k < len(items) else None

    def _severity(self, item_id: int) -> str | None:
        ps = self.problems_by_item.get(item_id, [])
        if any(p.severity == "failure" for p in ps):
            return "failure"
        return "warning" if ps else None

    def _apply_problems(self) -> None:
        seen: set[int] = set()
        with self.lock:
            groups: dict[int, tuple[ItemUi, list[Any]]] = {}
            for item_id, ui in self.item_ui.items():
                if ui.problems is None:
                    continue
                g = groups.setdefault(id(ui), (ui, []))
                g[1].extend(self.problems_by_item.get(item_id, []))
            for ui, ps in groups.values():
                if id(ui) in seen:
                    continue
                seen.add(id(ui))
                fails = [p for p in ps if p.severity == "failure"]
                icon = "✖ " if fails else "⚠ " if ps else ""
                try:
                    ui.folder.label = icon + ui.label
                    ui.problems.content = "\n".join(
                        f"- {'✖' if p.severity == 'failure' else '⚠'} `{p.path}`: {p.message}" for p in ps
                    )
                    ui.problems.visible = bool(ps)
                except Exception:  # noqa: BLE001 - the client may be gone
                    pass
            general = self.general_problems
            all_ps = [p for ps in self.problems_by_item.values() for p in ps] + general
        n_f = sum(1 for p in all_ps if p.severity == "failure")
        n_w = len(all_ps) - n_f
        lines = [f"**{'✔ valid' if n_f == 0 else '✖ invalid'}** — {n_f} failures, {n_w} warnings"]
        ph = self.physics if self._physics_rev == self._shown_rev else None
        if ph is not None and ph.get("ran"):
            verdict = "succeeded" if ph.get("success") else f"**failed**: {ph.get('failure_reason')}"
            lines.append(f"- physics check {verdict} ({ph.get('simulated_s')} s simulated in {ph.get('wall_s')} s; "
                         "dots on the timeline: margins per event, hover for the numbers)")  # fmt: skip
        elif ph is not None:
            lines.append(f"- physics check not run: {ph.get('reason')}")
        lines += [
            f"- {'✖' if p.severity == 'failure' else '⚠'} `{p.path or 'file'}`: {p.message}" for p in general
        ]
        try:
            self.md_validation.content = "\n".join(lines)
        except Exception:  # noqa: BLE001
            pass

    # ================================================================================================================
    # timeline and 3D
    # ================================================================================================================
    def _refresh_timeline(self) -> None:
        with self.lock:
            d = float(self.meta.get("duration") or 1.0)
            bars, marks = [], []
            for leg in LEG_ROWS:
                for lo, td in self._steps_of(leg):
                    sev = None
                    for it in (lo, td):
                        if it is not None:
                            s = self._severity(id(it))
                            sev = "failure" if s == "failure" or sev == "failure" else s or sev
                    if lo is not None and td is not None:
                        adj = float((td.get("adjust") or {}).get("time", 0.0) or 0.0)
                        bars.append(Bar(leg, float(lo["t"]), float(td["t"]), True, sev, id(lo), id(td), adj))
                    else:
                        it = lo or td
                        assert it is not None
                        marks.append(Mark(leg, float(it["t"]), sev or "failure", id(it)))
            sched = getattr(self.result, "schedule", None)
            if sched is not None:
                for leg_swings in sched.swings:
                    for sw in leg_swings:
                        if str(sw.liftoff_path).startswith("gaits"):
                            bars.append(Bar(LEG_ROWS[sw.leg], sw.t_liftoff, sw.t_touchdown, False))
            for kf in self.keyframes:
                marks.append(Mark("body", float(kf.get("t", 0.0)), self._severity(id(kf)), id(kf)))
            gaits = [
                (float(g.get("from", 0.0)), float(g.get("to", 0.0)), str(g.get("gait", "")))
                for g in self.gaits
            ]
        try:
            beats = self.beats.times(d) if self.beats is not None else ()
            self.html_timeline.content = timeline_svg(
                d,
                bars,
                marks,
                gaits,
                self._scrub_t(),
                view=self.view,
                selected=set(self.selected),
                beats=beats,
                physics=physics_marks(self.physics) if self._physics_rev == self._rev else (),
            )
        except Exception:  # noqa: BLE001
            pass

    def _resolved_target(self, td: dict[str, Any]) -> np.ndarray | None:
        """Returns where a touchdown lands (maneuver frame, m): its `at`, or liftoff point + offset (schedule)."""
        if td.get("at") is not None:
            return np.asarray(td["at"], dtype=float)
        sw = self._swing_of(td)
        return None if sw is None else np.asarray(sw.p_touchdown, dtype=float)

    def _swing_of(self, td: dict[str, Any]) -> Any:
        sched = getattr(self.result, "schedule", None)
        if sched is None:
            return None
        _, ev_ids, _ = self.document()
        try:
            k = ev_ids.index(id(td))
        except ValueError:
            return None
        for leg_swings in sched.swings:
            for sw in leg_swings:
                if sw.touchdown_path == f"events[{k}]":
                    return sw
        return None

    def _reference_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Returns the body reference (position m, rpy deg) at t, from the last good validation."""
        body = getattr(self.result, "body", None)
        if body is not None:
            try:
                p, _v, rpy, _w = body.sample(t)
                return np.asarray(p, dtype=float), np.degrees(np.asarray(rpy, dtype=float))
            except Exception:  # noqa: BLE001
                pass
        return np.array([0.0, 0.0, float(getattr(self.services.robot, "standing_height_m", 0.52))]), np.zeros(
            3
        )

    def refresh_markers(self) -> None:
        """Redraws the touchdown targets, keyframe ghosts and gait footholds (3D, world frame)."""
        off = self.world_offset()
        sc = self.scene
        with self.lock:
            wanted: dict[int, tuple[str, np.ndarray, np.ndarray | None, str]] = {}
            for td in (e for e in self.events if e.get("type") == "touchdown"):
                p = self._resolved_target(td)
                if p is not None:
                    wanted[id(td)] = ("td", p + off, None, str(td.get("leg", "FL")))
            for kf in self.keyframes:
                try:
                    p = np.asarray(kf.get("position", [0, 0, 0.52]), dtype=float) + off
                    q = wxyz_from_rpy_deg(kf.get("rpy", [0, 0, 0]))
                except (TypeError, ValueError):
                    continue
                wanted[id(kf)] = ("kf", p, q, "body")
            for item_id in list(self.markers):
                if item_id not in wanted:
                    self.markers.pop(item_id).remove()
            for item_id, (kind, p, q_or_none, leg) in wanted.items():
                h = self.markers.get(item_id)
                sev = self._severity(item_id)
                if kind == "td":
                    color = (255, 59, 48) if sev == "failure" else _hex_rgb(LEG_COLORS.get(leg, "#cccccc"))
                    if h is None:
                        h = sc.add_icosphere(
                            f"/edit/targets/{item_id}", radius=0.035, color=color, subdivisions=2
                        )
                        h.on_click(lambda _e, i=item_id: self.select(i))
                        self.markers[item_id] = h
                    h.color = color
                    h.position = p
                else:
                    color = (255, 59, 48) if sev == "failure" else (120, 200, 255)
                    if h is None:
                        h = sc.add_box(f"/edit/keyframes/{item_id}", dimensions=TRUNK_DIMS_M, color=color,
                                       opacity=0.35)  # fmt: skip
                        h.on_click(lambda _e, i=item_id: self.select(i))
                        self.markers[item_id] = h
                    h.color = color
                    h.position = p
                    h.wxyz = q_or_none
            # gait footholds (not editable here: edit the gait segment)
            sched = getattr(self.result, "schedule", None)
            pts = []
            if sched is not None:
                for leg_swings in sched.swings:
                    pts += [sw.p_touchdown for sw in leg_swings if str(sw.touchdown_path).startswith("gaits")]
            if pts:
                sc.add_point_cloud("/edit/gait_footholds", points=np.asarray(pts, dtype=np.float32) + off,
                                   colors=(200, 200, 200), point_size=0.03, point_shape="circle")  # fmt: skip
            else:
                sc.remove_by_name("/edit/gait_footholds")

    def _refresh_scrub(self) -> None:
        """Shows the planned body pose and feet at the scrub time (a ghost)."""
        t = self._scrub_t()
        off = self.world_offset()
        p, rpy = self._reference_at(t)
        sc = self.scene
        sched = getattr(self.result, "schedule", None)
        with self.lock:  # nodes are replaced by name: one thread at a time
            try:
                sc.add_box("/edit/scrub/body", dimensions=TRUNK_DIMS_M, color=(76, 201, 240), opacity=0.25,
                           position=p + off, wxyz=wxyz_from_rpy_deg(rpy))  # fmt: skip
                if sched is not None:
                    feet = np.array([sched.foot_target(i, t) for i in range(4)], dtype=np.float32) + off
                    sc.add_point_cloud("/edit/scrub/feet", points=feet, colors=(76, 201, 240), point_size=0.05,
                                       point_shape="circle")  # fmt: skip
            except Exception:  # noqa: BLE001 - a ghost that cannot be drawn (tab closing, odd schedule) is skipped
                pass

    def set_visible(self, on: bool) -> None:
        for name in ("/edit/targets", "/edit/keyframes", "/edit/scrub", "/edit/gait_footholds"):
            h = self.scene.get_handle_by_name(name) if hasattr(self.scene, "get_handle_by_name") else None
            if h is not None:
                h.visible = on
        for h in self.markers.values():
            h.visible = on

    # ---- 3D dragging ------------------------------------------------------------------------------------------
    def _drop_gizmo(self) -> None:
        if self.gizmo is not None:
            try:
                self.gizmo.remove()
            except Exception:  # noqa: BLE001
                pass
        self.gizmo, self.gizmo_item = None, None

    def _item_by_id(self, item_id: int) -> dict[str, Any] | None:
        for lst in (self.events, self.keyframes):
            for it in lst:
                if id(it) == item_id:
                    return it
        return None

    def select(self, item_id: int) -> None:
        """Attaches transform controls to a touchdown target (translate) or a keyframe (translate + rotate)."""
        with self.lock:
            item = self._item_by_id(item_id)
            marker = self.markers.get(item_id)
            if item is None or marker is None:
                self.notify(
                    "Cannot move", "this target has no position yet (fix the problems first)", "yellow"
                )
                return
            self._drop_gizmo()
            is_kf = item in self.keyframes
            self.gizmo = self.scene.add_transform_controls(
                "/edit/gizmo", scale=0.35, disable_rotations=not is_kf, position=marker.position,
                wxyz=marker.wxyz if is_kf else (1.0, 0.0, 0.0, 0.0), depth_test=False,
            )  # fmt: skip
            self.gizmo_item = item_id

            @self.gizmo.on_update
            def _(event: Any) -> None:
                target = event.target
                m = self.markers.get(item_id)
                if m is not None:
                    m.position = target.position
                    if is_kf:
                        m.wxyz = target.wxyz
                if getattr(event, "phase", "end") == "end":
                    self._commit_drag(item, np.asarray(target.position, dtype=float),
                                      np.asarray(target.wxyz, dtype=float), is_kf)  # fmt: skip

    def _commit_drag(self, item: dict[str, Any], p_world: np.ndarray, wxyz: np.ndarray, is_kf: bool) -> None:
        p = p_world - self.world_offset()
        with self.lock:
            if is_kf:
                item["position"] = [_r(v) for v in p]
                item["rpy"] = rpy_deg_from_wxyz(wxyz)
            elif item.get("at") is not None or (item.get("offset") is None and self._swing_of(item) is None):
                item.pop("offset", None)
                item["at"] = [_r(v) for v in p]
            else:
                sw = self._swing_of(item)
                base = np.asarray(sw.p_liftoff, dtype=float) if sw is not None else p
                item.pop("at", None)
                item["offset"] = [_r(v) for v in p - base]
        ui = self.item_ui.get(id(item))
        if ui is not None:
            self._suspend = True
            try:
                if is_kf:
                    ui.handles["pos"].value = tuple(item["position"])
                    ui.handles["rpy"].value = tuple(item["rpy"])
                else:
                    mode = "at" if item.get("at") is not None else "offset"
                    ui.handles["mode"].value = mode
                    ui.handles["vec"].value = tuple(item.get("at") or item.get("offset") or (0.0, 0.0, 0.0))
                    ui.handles["vec"].disabled = False
            finally:
                self._suspend = False
        self._changed()

    # ================================================================================================================
    # preview and file
    # ================================================================================================================
    def maneuver_or_none(self) -> Any:
        """Returns the validated Maneuver, or None after telling the user what is wrong."""
        result = self.validate_now()
        if result is None or not result.ok:
            n = len(getattr(result, "failures", []) or []) or len(self.general_problems) or 1
            self.notify("Not valid", f"fix {n} failure(s) first (marked ✖ on the items)", "red")
            return None
        return result.maneuver

    def preview(self) -> None:
        if not self.authorized("preview"):
            return
        m = self.maneuver_or_none()
        if m is not None:
            self.start_preview(m)

    def save(self, save_as: str | None) -> None:
        """Saves to the user library: under the current name (Save) or a new one (Save as)."""
        if not self.authorized("save"):
            return
        name = save_as if save_as else str(self.meta.get("name") or "")
        if save_as:
            with self.lock:
                self.meta["name"] = save_as
            self._suspend = True
            try:
                self.txt_name.value = save_as
            finally:
                self._suspend = False
        m = self.maneuver_or_none()
        if m is None:
            return
        store = self.services.store
        if_match = None
        if self.source == "user" and self.source_name == name and self.etag:
            if_match = self.etag
        elif save_as or self.source_name != name:
            if_match = None  # a new file: must not exist yet
        try:
            stored, _created = store.save(name, self.yaml_text(), if_match=if_match,
                                          if_none_match="*" if if_match is None else None)  # fmt: skip
        except Conflict as e:
            self.notify("Not saved", f"{e.message}", "red")
            return
        except StorageError as e:
            self.notify("Not saved", e.message, "red")
            return
        with self.lock:
            self.source_name, self.source, self.etag, self.dirty = stored.name, "user", stored.etag, False
        self._refresh_header()
        self._show_in_library(stored.name)
        self.notify("Saved", f"{stored.name} saved to your library", "green")
