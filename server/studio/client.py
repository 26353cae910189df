"""One studio tab: its live session, the 3D view (robot, terrain, overlays), the panels and the render loop."""

from __future__ import annotations

import html
import logging
import math
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from server.deps import check_token
from server.errors import ApiError
from server.sessions import LiveSession, SessionError
from server.studio.editor import ManeuverEditor
from server.studio.overlays import OverlayView
from server.studio.replay import GhostRobot, Take, take_of
from server.studio.robot_view import RobotView

log = logging.getLogger("footfall.studio")

PERCEPTION = {
    "scene (real time)": "truth",
    "depth sensor": "sensor",
}  # the studio's names for a session's maps
FRAME_HZ = 75.0  # at most this many robot pose updates per second to the browser (the session publishes ≤ 60)
# A pose whose bodies all moved less than STILL_M (m; quaternion components alike) since the last one sent is not
# sent: a robot standing still costs the browser no redraws (its GPU is often a software one).
STILL_M = 2e-4
FPS_WINDOW_S = 2.0  # the frame rate shown (and in GET /studio) counts the poses sent over this many seconds
# The render loop wakes at each snapshot its session publishes (a pose goes out as soon as the loop runs), and at
# least every IDLE_WAIT_S for the overlays, plots and status line (or every POLL_S without a session).
IDLE_WAIT_S = 0.02
POLL_S = 0.004
OVERLAY_HZ = 10.0
PLOT_HZ = 4.0
STATUS_HZ = 4.0
STEER_STEP = {"vx": 0.1, "vy": 0.05, "yaw_rate": 0.2}  # per key press: m/s, m/s, rad/s
# Steering keys (key, command, sign). viser's viewer flies its camera with W A S D Q E and the arrow keys whatever
# else they are bound to, so the studio's keys stay clear of those: I/K forward and back, J/L left and right, U/O
# turn, X stops.
STEER_KEYS = (("I", "vx", 1.0), ("K", "vx", -1.0), ("J", "vy", 1.0), ("L", "vy", -1.0), ("U", "yaw_rate", 1.0),
              ("O", "yaw_rate", -1.0))  # fmt: skip
STOP_KEY = "X"
CAMERA_KEYS = frozenset("WASDQE") | {"arrowup", "arrowdown", "arrowleft", "arrowright"}  # viser's, never ours
# the view a tab opens with and returns to with "Reset view": from the front left, above, at the robot (m, relative
# to the robot's body position on the ground)
VIEW_EYE_M = (1.6, -1.9, 0.85)
VIEW_TARGET_M = (0.0, 0.0, 0.0)


class StudioClient:
    """Everything of one browser tab; built on connect, torn down on disconnect."""

    def __init__(self, studio: Any, client: Any) -> None:
        self.studio = studio
        self.services = studio.services
        self.client = client
        self.session: LiveSession | None = None
        self.view: RobotView | None = None
        self.generation = -1
        self.token = ""
        self._stop = threading.Event()
        # show_replay runs on the GUI's callbacks and on the tab's loop: one at a time, each reading the playhead
        # inside, so the last to run shows the playhead's latest value (not one read before a scrub moved it)
        self._replay_lock = threading.RLock()
        self._frames: deque[float] = deque(maxlen=200)
        self._seen: deque[tuple[float, int]] = deque(maxlen=1000)  # (time, session's pose count) the loop saw
        self._sent_pose: tuple[np.ndarray, np.ndarray] | None = None  # the robot's pose the browser last got
        self._last_note = 0.0
        self.steer_cmd = {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0}
        self.take: Take | None = None  # the preview being replayed (refreshed while it records)
        self.prev_take: Take | None = None  # the run before the latest preview (the ghost)
        self.ghost: GhostRobot | None = None

    # ---- lifecycle ----------------------------------------------------------------------------------------------
    def start(self) -> None:
        c = self.client
        c.scene.set_up_direction("+z")
        if self.may_drive():  # a tab that may not drive takes no session slot (issue 24); the token opens one
            self._open_session()
        self.reset_view()
        self.overlays = OverlayView(c.scene, "/overlays", on_new=self._overlay_added)
        self._build_gui()
        self._pick_up_preview_request()
        self._thread = threading.Thread(target=self._loop, name=f"footfall-studio-{c.client_id}", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if getattr(self, "robustness", None) is not None:
            self.robustness.stop()
        thread = getattr(self, "_thread", None)
        if thread is not None and thread is not threading.current_thread():
            thread.join(1.0)  # let the render loop finish its frame before the session goes away
        editor = getattr(self, "editor", None)
        if editor is not None:
            editor.close()
        if self.session is not None:
            try:
                self.services.sessions.delete(self.session.id)
            except SessionError:
                pass
            self.session = None

    @property
    def fps(self) -> float:
        """Robot poses sent per second over the last FPS_WINDOW_S (0 while the robot stands still)."""
        now = time.perf_counter()
        f = [t for t in list(self._frames) if now - t <= FPS_WINDOW_S]
        return len(f) / FPS_WINDOW_S

    @property
    def published_fps(self) -> float:
        """Poses the tab's session published per second over the last FPS_WINDOW_S (from its count of them, so
        the ones the render loop skipped count too): what `fps` could be on this machine now."""
        now = time.perf_counter()
        seen = [(t, q) for t, q in list(self._seen) if now - t <= FPS_WINDOW_S]
        if len(seen) < 2 or seen[-1][0] <= seen[0][0]:
            return 0.0
        return (seen[-1][1] - seen[0][1]) / (seen[-1][0] - seen[0][0])

    def _open_session(self, terrain: str = "flat") -> None:
        try:
            self.session = self.services.sessions.create(terrain, "maneuver", origin="studio")
        except SessionError as e:
            self.session = None
            self.notify("No live robot", e.message + " — authoring still works; reload to retry.", "red")

    def camera_info(self) -> dict[str, list[float]] | None:
        try:
            cam = self.client.camera
            return {"position": [round(float(v), 4) for v in cam.position],
                    "look_at": [round(float(v), 4) for v in cam.look_at]}  # fmt: skip
        except Exception:  # noqa: BLE001 - no camera reported yet
            return None

    def slider_info(self) -> dict[str, float] | None:
        sliders = getattr(self, "steer_sliders", None)
        return None if sliders is None else {k: round(float(h.value), 4) for k, h in sliders.items()}

    # ---- helpers ------------------------------------------------------------------------------------------------
    def reset_view(self) -> None:
        """Puts the camera back where a tab starts: looking at the robot from the front left, z up."""
        p = np.zeros(3)
        s = self.session
        if s is not None and len(s.snapshot.xpos):
            p = np.array([s.snapshot.xpos[0][0], s.snapshot.xpos[0][1], s.snapshot.xpos[0][2]], dtype=float)
        try:
            cam = self.client.camera
            cam.up_direction = (0.0, 0.0, 1.0)
            cam.position = tuple(p + np.asarray(VIEW_EYE_M))
            cam.look_at = tuple(p + np.asarray(VIEW_TARGET_M))
        except Exception:  # noqa: BLE001 - a tab without a camera yet (it reports one right after connecting)
            pass

    def notify(self, title: str, body: str, color: str = "blue") -> None:
        try:
            self.client.add_notification(title, body, auto_close_seconds=6.0, color=color)
        except Exception:  # noqa: BLE001 - the tab may be gone
            pass

    def may_drive(self) -> bool:
        """True when this tab may write or drive now (no notification)."""
        try:
            check_token(self.services.settings, self.token or None)
        except ApiError:
            return False
        return True

    def authorized(self, what: str) -> bool:
        """True when this tab may write or drive (the API token rule applies to the studio too)."""
        try:
            check_token(self.services.settings, self.token or None)
        except ApiError:
            self.notify("Token needed", f"to {what}, enter the API token under Access (see the server's log)",
                        "yellow")  # fmt: skip
            return False
        return True

    def world_offset(self) -> np.ndarray:
        s = self.session
        off = getattr(getattr(s, "sim", None), "offset", None) if s is not None else None
        return np.zeros(3) if off is None else np.asarray(off, dtype=float)

    def start_preview(self, maneuver: Any) -> None:
        if self.session is None:
            self.notify("No live robot", "the server has no free session; reload later", "red")
            return
        before = take_of(self.session)
        if before is not None and before.maneuver != "stand":
            self.prev_take = before  # the ghost: the run before this one
        try:
            self.session.set_speed(float(self.editor.sl_speed.value))
            self.session.start_maneuver(maneuver)
        except SessionError as e:
            self.notify("Preview failed", e.message, "red")
            return
        self.notify("Preview", f"{maneuver.name} on {self.session.terrain}", "green")

    def _pick_up_preview_request(self) -> None:
        reqs = self.services.preview_requests
        now = time.time()
        fresh = [r for r in reqs if now - r[0] < 60.0]
        if not fresh:
            return
        req = fresh[-1]
        try:
            reqs.remove(req)
        except ValueError:
            return
        _, name, terrain = req
        if self.editor.open(name):
            if self.session is not None and terrain != self.session.terrain:
                self.session.reset(terrain)
                if (
                    terrain in self.dd_terrain.options
                ):  # a custom terrain (with parameters, a file) is not listed
                    self.dd_terrain.value = terrain
            m = self.editor.maneuver_or_none()
            if m is not None:
                self.start_preview(m)

    # ---- GUI ----------------------------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.client.gui
        try:
            gui.configure_theme(control_width="large", dark_mode=True, show_share_button=False)
        except Exception:  # noqa: BLE001
            pass
        self.md_status = gui.add_markdown("starting…")
        gui.add_html(page_script_html())
        if self.services.settings.token_required:
            with gui.add_folder("Access", expand_by_default=True):
                gui.add_markdown("This server is reachable from the network: saving and driving need the API "
                                 "token (printed in the server's log).")  # fmt: skip
                txt = gui.add_text("API token", "")

                @txt.on_update
                def _(e: Any) -> None:
                    self.token = str(e.target.value).strip()
                    if self.session is None and self.may_drive():
                        self._open_session()

        tabs = gui.add_tab_group()
        with tabs.add_tab("Author"):
            self.editor = ManeuverEditor(
                self.client, self.services, notify=self.notify, authorized=self.authorized,
                start_preview=self.start_preview, world_offset=self.world_offset,
            )  # fmt: skip
            self.editor.build()
        with tabs.add_tab("Drive"):
            self._build_drive()
        with tabs.add_tab("View"):
            self._build_view()
        with tabs.add_tab("Plots"):
            self._build_plots()
        with tabs.add_tab("Robustness"):
            from server.studio.robustness import RobustnessPanel

            self.robustness = RobustnessPanel(self.client, self.services, self.notify, self.authorized,
                                              self.editor.maneuver_or_none, lambda: self.session)  # fmt: skip
            self.robustness.build()
        self._bind_playback()
        if not self.editor.open("bow"):
            self.editor.new_document()
        self.ready = True  # every panel is built (tests and the studio's status wait for this)

    def _bind_playback(self) -> None:
        ed = self.editor

        @ed.btn_pause.on_click
        def _(_: Any) -> None:
            s = self.session
            if s is None or not self.authorized("pause or play"):
                return
            s.resume() if s.status == "paused" else s.pause()

        @ed.btn_restart.on_click
        def _(_: Any) -> None:
            s = self.session
            if s is not None and self.authorized("restart"):
                s.restart()

        @ed.sl_speed.on_update
        def _(e: Any) -> None:
            if self.session is not None:
                self.session.set_speed(float(e.target.value))

        ed.btn_frame_back.on_click(lambda _e: self.step_frames(-1))
        ed.btn_frame_fwd.on_click(lambda _e: self.step_frames(1))
        ed.cb_ghost.on_update(lambda _e: self.show_replay())
        ed.cb_replay.on_update(lambda _e: self.show_replay())
        ed.sl_scrub.on_update(lambda _e: self.show_replay())

        @ed.btn_export.on_click
        def _(_: Any) -> None:
            from server.studio.recording import recording_html

            if self.session is None:
                return
            try:
                html, stem = recording_html(self.session)
            except ApiError as e:
                self.notify("Nothing to export", e.detail, "yellow")
                return
            self.client.send_file_download(f"{stem}.html", html.encode("utf-8"), save_immediately=True)

    def _build_custom_terrain(self) -> None:
        """A terrain with parameters or from a file, as on the command line (uploaded files by their name)."""
        from server.terrains import save_file

        gui = self.client.gui
        with gui.add_folder("Custom terrain", expand_by_default=False):
            txt = gui.add_text("terrain", "stairs:riser_m=0.18,tread_m=0.28",
                               hint="NAME:KEY=VALUE,... (footfall terrains --params), or an uploaded file: "
                                    "room.xml, hills.npy:cell_m=0.05")  # fmt: skip
            btn = gui.add_button("Use this terrain")
            upload = gui.add_upload_button(
                "Upload a terrain file", hint="an MJCF scene (.xml), a heightmap (.npy, .png) or its .yaml"
            )

        @btn.on_click
        def _(_: Any) -> None:
            if self.authorized("change the terrain"):
                self.use_terrain(str(txt.value).strip())

        @upload.on_upload
        def _(e: Any) -> None:
            if not self.authorized("upload a terrain"):
                return
            f = e.target.value
            try:
                save_file(self.services.settings, str(f.name), bytes(f.content))
            except ApiError as err:
                self.notify("Upload refused", err.detail, "red")
                return
            if not str(f.name).endswith(".yaml"):
                txt.value = str(f.name) + ("" if str(f.name).endswith(".xml") else ":cell_m=0.05")
            self.notify("Uploaded", f"{f.name}: check the terrain field, then Use this terrain", "green")

    def use_terrain(self, text: str) -> bool:
        """Puts this tab's robot on the terrain `text` names (the REST rules: uploaded files by name); False, with a
        notification saying why, when it cannot be used."""
        from server.terrains import resolve_terrain

        if self.session is None:
            return False
        try:
            terrain = resolve_terrain(text, self.services.settings)
        except ApiError as e:
            self.notify("Terrain not usable", e.detail, "red")
            return False
        self.session.reset(terrain)
        self.zero_sliders()  # a new terrain starts standing: the old command must not walk it off
        return True

    def _build_drive(self) -> None:
        from server.engine import steering_gaits, terrain_names

        gui = self.client.gui
        names = list(terrain_names())
        self.dd_terrain = gui.add_dropdown("terrain", names, initial_value="flat")
        from server.studio.robot_picker import add_robot_picker

        self.dd_robot = add_robot_picker(self)
        self._build_custom_terrain()
        # what a walk on a terrain plans on: the scene's own maps keep real time, the depth sensor's are what a robot
        # would see (slower than real time; the "depth cloud" overlay shows its scans)
        self.dd_maps = gui.add_dropdown("walk on maps", tuple(PERCEPTION), initial_value="scene (real time)")
        btn_reset = gui.add_button("Reset robot")
        with gui.add_folder("Push"):
            sl_dir = gui.add_slider("direction (deg, 0 = +x)", -180.0, 180.0, 5.0, 90.0)
            sl_imp = gui.add_slider("impulse (N·s)", 2.0, 60.0, 1.0, 15.0)
            sl_dur = gui.add_slider("duration (s)", 0.05, 0.5, 0.05, 0.1)
            btn_push = gui.add_button("Push")
        keys = " ".join(k for k, _, _ in STEER_KEYS)
        with gui.add_folder(f"Steer (keys {keys}; {STOP_KEY} stops)"):
            self.sl_vx = gui.add_slider("vx (m/s)", -1.0, 1.0, 0.05, 0.0)
            self.sl_vy = gui.add_slider("vy (m/s)", -0.5, 0.5, 0.05, 0.0)
            self.sl_yaw = gui.add_slider("yaw rate (rad/s)", -1.5, 1.5, 0.05, 0.0)
            gaits = steering_gaits() or ("trot",)
            self.dd_gait = gui.add_dropdown(
                "gait", gaits, initial_value="trot" if "trot" in gaits else gaits[0]
            )
            self.dd_weights = gui.add_dropdown(
                "step weights", ("default", "precise_footing", "stable_body"), initial_value="default"
            )
            btn_send = gui.add_button("Send command")
            btn_stop = gui.add_button("Stop")
        self.steer_sliders = {"vx": self.sl_vx, "vy": self.sl_vy, "yaw_rate": self.sl_yaw}
        # set while the sliders are written from the session (their callbacks must not steer)
        self._syncing = False

        @self.dd_terrain.on_update
        def _(e: Any) -> None:
            if self.session is not None and str(e.target.value) != self.session.terrain:
                if self.authorized("change the terrain"):
                    self.session.reset(str(e.target.value))
                    self.zero_sliders()  # a new terrain starts standing: the old command must not walk it off

        @self.dd_maps.on_update
        def _(e: Any) -> None:
            maps = PERCEPTION.get(str(e.target.value), "truth")
            if self.session is not None and maps != self.session.maps and self.authorized("change the maps"):
                self.session.reset(maps=maps)
                self.zero_sliders()

        @btn_reset.on_click
        def _(_: Any) -> None:
            if self.session is not None and self.authorized("reset"):
                self.session.reset()
                self.zero_sliders()

        @btn_push.on_click
        def _(_: Any) -> None:
            if self.session is None or not self.authorized("push"):
                return
            a = math.radians(float(sl_dir.value))
            dur = float(sl_dur.value)
            f = float(sl_imp.value) / dur
            try:
                self.session.push((f * math.cos(a), f * math.sin(a), 0.0), dur)
            except SessionError as e:
                self.notify("Push failed", e.message, "red")

        btn_send.on_click(lambda _e: self.send_steer())
        btn_stop.on_click(lambda _e: self.stop_steer())
        for h in self.steer_sliders.values():
            h.on_update(lambda _e: None if self._syncing else self.send_steer())

        def nudge(handle: Any, step: float) -> None:
            # the slider's on_update steers
            handle.value = float(np.clip(float(handle.value) + step, handle.min, handle.max))

        for key, name, sign in STEER_KEYS:
            try:
                cmd = gui.add_command(f"steer {name} {'+' if sign > 0 else '−'}", hotkey=key,  # type: ignore[arg-type]
                                      description="nudge the velocity command")  # fmt: skip
            except Exception:  # noqa: BLE001 - hotkeys are a convenience (older viser)
                break
            cmd.on_trigger(lambda _e, h=self.steer_sliders[name], st=sign * STEER_STEP[name]: nudge(h, st))
        try:
            gui.add_command("stop", hotkey=STOP_KEY, description="zero the velocity command").on_trigger(
                lambda _e: self.stop_steer()
            )
        except Exception:  # noqa: BLE001
            pass

    # ---- replay and compare ----------------------------------------------------------------------------------------
    def step_frames(self, frames: int) -> None:
        """Moves the playhead by whole recorded frames (replay on)."""
        ed = self.editor
        if self.session is not None:
            self.take = take_of(self.session)
        if self.take is None:
            return
        ed.cb_replay.value = True
        ed.sl_scrub.value = float(min(self.take.step(float(ed.sl_scrub.value), frames), ed.sl_scrub.max))

    def show_replay(self, t_live: float | None = None) -> None:
        """Poses the robot from the recorded preview at the playhead (replay on), and the ghost from the run before
        at the same time (or at the live time `t_live`)."""
        with self._replay_lock:
            self._show_replay(t_live)

    def _show_replay(self, t_live: float | None) -> None:
        ed = self.editor
        replay = bool(ed.cb_replay.value)
        t = float(ed.sl_scrub.value) if replay or t_live is None else t_live
        if replay and self.session is not None:
            if self.take is None or self.session.status == "running":
                self.take = take_of(self.session)
            if self.take is not None and self.view is not None:
                with self.client.atomic():
                    self.view.set_poses(*self.take.pose_at(t))
                k = self.take.index_at(t)
                ed.md_replay.content = (f"replaying **{self.take.maneuver}**: frame {k + 1} of {len(self.take.t)}, "
                                        f"t = {self.take.t[k]:.2f} s")  # fmt: skip
        want_ghost = bool(ed.cb_ghost.value) and self.prev_take is not None
        if want_ghost and self.ghost is None and self.session is not None:
            with self.session.lock:
                visuals = self.session.sim.visuals() if hasattr(self.session.sim, "visuals") else None
            if visuals is not None:
                self.ghost = GhostRobot(self.client.scene, visuals)
        if self.ghost is not None:
            self.ghost.set_visible(want_ghost)
            if want_ghost and self.prev_take is not None:
                self.ghost.set_poses(*self.prev_take.pose_at(t))

    def send_steer(self) -> None:
        """Sends the sliders' velocity command (and the gait and step weights) to the tab's session."""
        if self.session is None or not self.authorized("steer"):
            return
        try:
            self.session.steer(float(self.sl_vx.value), float(self.sl_vy.value), float(self.sl_yaw.value),
                               str(self.dd_gait.value), str(self.dd_weights.value))  # fmt: skip
        except SessionError as e:
            now = time.time()
            if now - self._last_note > 2.0:  # key repeats must not flood the tab with notes
                self._last_note = now
                self.notify("Steering", e.message, "yellow")

    def stop_steer(self) -> None:
        self.zero_sliders()
        self.send_steer()

    def zero_sliders(self) -> None:
        """Sets the velocity sliders to 0 without steering."""
        self._write_sliders({"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0})

    def _write_sliders(self, cmd: dict[str, Any]) -> None:
        self._syncing = True
        try:
            for k, h in self.steer_sliders.items():
                v = float(cmd.get(k) or 0.0)
                if abs(float(h.value) - v) > 1e-9:
                    h.value = v
        finally:
            self._syncing = False

    def _sync_sliders(self) -> None:
        """Shows the session's velocity command on the sliders when it was set elsewhere (REST /steer)."""
        s = self.session
        if s is None or not hasattr(self, "steer_sliders"):
            return
        cmd = s.command or {}
        if s.command is not None and s.command.get("gait") in self.dd_gait.options:
            if self.dd_gait.value != s.command["gait"]:
                self.dd_gait.value = s.command["gait"]
        self._write_sliders(cmd)

    def _overlay_added(self, name: str) -> None:
        # a new overlay name (e.g. from a planning module that just landed) gets its own toggle
        if name in self.overlay_boxes:
            return
        with self.fd_overlays:
            cb = self.client.gui.add_checkbox(name.replace("_", " "), self.overlays.enabled.get(name, False))
        cb.on_update(lambda e, n=name: self.overlays.set_enabled(n, bool(e.target.value)))
        self.overlay_boxes[name] = cb

    def _build_view(self) -> None:
        gui = self.client.gui
        self.overlay_boxes: dict[str, Any] = {}
        self.fd_overlays = gui.add_folder("Overlays")
        for name in ("contact_forces", "body_path", "step_plan", "capture_point", "body_target"):
            self.overlays.enabled.setdefault(name, True)
            self._overlay_added(name)
        cb_edit = gui.add_checkbox("authoring markers", True)
        cb_edit.on_update(lambda e: self.editor.set_visible(bool(e.target.value)))
        self.cb_follow = gui.add_checkbox("camera follows the robot", False)
        # Shadows cost a software-rendering browser (no GPU) most of a core for every frame drawn
        self.cb_shadows = gui.add_checkbox("shadows", self.services.settings.studio_shadows)
        self.cb_shadows.on_update(
            lambda e: self.client.scene.configure_default_lights(cast_shadow=bool(e.target.value))
        )
        self.client.scene.configure_default_lights(cast_shadow=self.services.settings.studio_shadows)
        self.btn_reset_view = gui.add_button("Reset view")
        self.btn_reset_view.on_click(lambda _e: self.reset_view())

    def _build_plots(self) -> None:
        import viser.uplot as up

        gui = self.client.gui
        z = np.zeros(2)
        # simulated seconds on x (uPlot reads an x scale as dates unless told otherwise)
        scales = {"x": up.Scale(time=False, auto=True)}
        x_axis = up.Axis(label="t (s)")
        self.plot_solver = gui.add_uplot(
            data=(np.array([0.0, 1.0]), z),
            series=(up.Series(label="t (s)"), up.Series(label="controller ms/tick", stroke="#f3a712", width=1.5)),
            title="Solver time per tick (ms)", aspect=1.6, scales=scales, axes=(x_axis, up.Axis()),
        )  # fmt: skip
        self.plot_vel = gui.add_uplot(
            data=(np.array([0.0, 1.0]), z, z, z, z),
            series=(up.Series(label="t (s)"), up.Series(label="vx", stroke="#4cc9f0", width=1.5),
                    up.Series(label="vx ref", stroke="#4cc9f0", dash=(4.0, 4.0), width=1.0),
                    up.Series(label="vy", stroke="#e4572e", width=1.5),
                    up.Series(label="vy ref", stroke="#e4572e", dash=(4.0, 4.0), width=1.0)),
            title="Velocity tracking (m/s)", aspect=1.6, scales=scales, axes=(x_axis, up.Axis()),
        )  # fmt: skip

    # ---- the render loop ----------------------------------------------------------------------------------------
    def _loop(self) -> None:
        min_gap = 1.0 / FRAME_HZ
        last_seq = -1
        last_sent = 0.0
        next_overlay = next_plot = next_status = 0.0
        while not self._stop.is_set():
            t0 = time.perf_counter()
            s = None
            seen_seq = -1
            deferred = False  # a new pose held back only because the last one went out less than min_gap ago
            try:
                s = self.session
                if s is not None:
                    s.touch()
                    if s.generation != self.generation or self.view is None:
                        self._rebuild_scene(s)
                    snap = s.snapshot
                    seen_seq = snap.seq
                    poses = s.poses
                    if self._seen and poses < self._seen[-1][1]:  # another session
                        self._seen.clear()
                    if not self._seen or self._seen[-1][1] != poses:
                        self._seen.append((t0, poses))
                    replaying = bool(self.editor.cb_replay.value)
                    view = self.view  # read once: a closing tab or a rebuild may clear it meanwhile
                    deferred = snap.seq != last_seq and t0 - last_sent < min_gap and not replaying
                    if (
                        view is not None
                        and snap.seq != last_seq
                        and t0 - last_sent >= min_gap
                        and not replaying
                        and self._moved(snap.xpos, snap.xquat)
                    ):
                        last_seq, last_sent = snap.seq, t0
                        with self.client.atomic():
                            view.set_poses(snap.xpos, snap.xquat)
                        if self.ghost is not None or self.prev_take is not None:
                            self.show_replay(t_live=float(snap.state.get("t", 0.0)))
                        self._frames.append(time.perf_counter())
                        if self.cb_follow.value and len(snap.xpos):
                            self._follow(snap.xpos[0])
                    if t0 >= next_overlay and s.status != "crashed":
                        next_overlay = t0 + 1.0 / OVERLAY_HZ
                        self.overlays.update(s.plan())
                    if t0 >= next_plot:
                        next_plot = t0 + 1.0 / PLOT_HZ
                        self._update_plots(s)
                if t0 >= next_status:
                    next_status = t0 + 1.0 / STATUS_HZ
                    self._update_status()
            except SessionError:
                pass
            except Exception:  # noqa: BLE001 - a drawing hiccup must not end the tab's loop
                if self._stop.is_set():
                    return
                log.exception("studio render loop")
                time.sleep(0.5)
            if s is None:
                time.sleep(POLL_S)
                continue
            now = time.perf_counter()
            wait = min(IDLE_WAIT_S, next_overlay - now, next_plot - now, next_status - now)
            if deferred:
                wait = min(wait, last_sent + min_gap - now)
            if wait > 0.0:
                s.wait_snapshot(seen_seq, wait)

    def _moved(self, xpos: np.ndarray, xquat: np.ndarray) -> bool:
        """Whether any body moved by at least STILL_M since the pose last sent (and remembers this one if so)."""
        sent = self._sent_pose
        if sent is not None and sent[0].shape == xpos.shape and sent[1].shape == xquat.shape:
            if (
                np.abs(xpos - sent[0]).max(initial=0.0) < STILL_M
                and np.abs(xquat - sent[1]).max(initial=0.0) < STILL_M
            ):
                return False
        self._sent_pose = (xpos.copy(), xquat.copy())
        return True

    def _rebuild_scene(self, s: LiveSession) -> None:
        self.generation = s.generation
        self._sent_pose = None  # a new scene gets the pose at once
        with s.lock:
            visuals = s.sim.visuals() if hasattr(s.sim, "visuals") else None
        if visuals is None:
            return
        key = (s.terrain, s.robot, len(visuals.robot_geoms))
        if self.view is not None and getattr(self.view, "_key", None) == key:
            return
        if self.view is not None:
            self.view.remove()
        self.view = RobotView(self.client.scene, visuals, root="/world")
        self.view._key = key  # type: ignore[attr-defined]
        self.editor.refresh_markers()

    def _follow(self, p: np.ndarray) -> None:
        cam = self.client.camera
        look = np.asarray(cam.look_at, dtype=float)
        delta = np.array([p[0], p[1], look[2]]) - look
        if np.linalg.norm(delta) > 0.05:
            cam.look_at = look + delta
            cam.position = np.asarray(cam.position, dtype=float) + delta

    def _update_plots(self, s: LiveSession) -> None:
        samples = list(s.plot)
        if len(samples) < 2:
            return
        t = np.array([p.t for p in samples])
        self.plot_solver.data = (t, np.array([p.tick_ms for p in samples]))
        v = np.array([p.v_body for p in samples])
        r = np.array([p.v_ref for p in samples])
        self.plot_vel.data = (t, v[:, 0], r[:, 0], v[:, 1], r[:, 1])

    def _update_status(self) -> None:
        s = self.session
        if s is None:
            self.md_status.content = "**no live robot** (server at its session cap) — authoring only"
            return
        self._sync_sliders()
        st = s.state()
        self.md_status.content = status_line(st, self.fps)
        self.editor.show_clock(st)  # the loaded music follows the preview


def page_script_html() -> str:
    """Returns an invisible HTML element that runs the studio's page helper (page.js) once in the tab: viser renders
    GUI HTML as markup, where a script element would not run, but an image's error handler does."""
    js = (Path(__file__).with_name("page.js")).read_text(encoding="utf-8")
    return f'<img alt="" src="data:," style="display:none" onerror="{html.escape(js, quote=True)}">'


def status_line(st: dict[str, Any], fps: float) -> str:
    """Returns the studio's status line (markdown) for a session state: what runs where, its time (never past the
    maneuver's end), whether it is running, done, fell (the robot then goes limp) or crashed."""
    dur = float(st.get("maneuver_duration") or 0.0)
    t = float(st.get("t") or 0.0)
    status = str(st.get("status"))
    if st.get("fell") and status == "running":
        status = "fell"
    elif st.get("done") and status == "running":
        status = "done"
    shown_t = min(t, dur) if dur else t
    line = (f"**{st.get('maneuver')}** on *{st.get('terrain')}* · t = {shown_t:.2f}"
            f"{f' / {dur:.1f}' if dur else ''} s · {status} · {float(st.get('realtime_factor') or 0.0):.2f}× real "
            f"time · {fps:.0f} fps")  # fmt: skip
    if st.get("fell"):
        reason = str(st.get("failure_reason") or "")
        reason = reason[len("fell: ") :] if reason.startswith("fell: ") else reason
        line += f"\n\n⚠ **fell**: {reason} — the robot is limp; press Reset robot or preview again"
    if status == "crashed":
        line += f"\n\n✖ **simulation crashed**: {st.get('error')} — press Reset robot"
    return line


__all__ = ["StudioClient", "status_line"]
