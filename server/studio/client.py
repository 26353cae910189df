"""One studio tab: its live session, the 3D view (robot, terrain, overlays), the panels and the render loop."""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from typing import Any

import numpy as np

from server.deps import check_token
from server.errors import ApiError
from server.sessions import LiveSession, SessionError
from server.studio.editor import ManeuverEditor
from server.studio.overlays import OverlayView
from server.studio.robot_view import RobotView

log = logging.getLogger("footfall.studio")

PERCEPTION = {
    "scene (real time)": "truth",
    "depth sensor": "sensor",
}  # the studio's names for a session's maps
FRAME_HZ = 60.0  # robot pose updates per second sent to the browser (≥ 30 fps), at most the publish rate
OVERLAY_HZ = 10.0
PLOT_HZ = 4.0
STATUS_HZ = 4.0
STEER_STEP = {"vx": 0.1, "vy": 0.05, "yaw_rate": 0.2}  # per key press: m/s, m/s, rad/s


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
        self._frames: deque[float] = deque(maxlen=200)
        self._last_note = 0.0
        self.steer_cmd = {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0}

    # ---- lifecycle ----------------------------------------------------------------------------------------------
    def start(self) -> None:
        c = self.client
        c.scene.set_up_direction("+z")
        try:
            c.camera.position = (1.6, -1.9, 1.2)
            c.camera.look_at = (0.0, 0.0, 0.35)
        except Exception:  # noqa: BLE001 - camera setup is cosmetic
            pass
        if self.may_drive():  # a tab that may not drive takes no session slot (issue 24); the token opens one
            self._open_session()
        self.overlays = OverlayView(c.scene, "/overlays", on_new=self._overlay_added)
        self._build_gui()
        self._pick_up_preview_request()
        self._thread = threading.Thread(target=self._loop, name=f"footfall-studio-{c.client_id}", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        thread = getattr(self, "_thread", None)
        if thread is not None and thread is not threading.current_thread():
            thread.join(1.0)  # let the render loop finish its frame before the session goes away
        if self.session is not None:
            try:
                self.services.sessions.delete(self.session.id)
            except SessionError:
                pass
            self.session = None

    @property
    def fps(self) -> float:
        f = list(self._frames)
        if len(f) < 2 or f[-1] - f[0] <= 0:
            return 0.0
        return (len(f) - 1) / (f[-1] - f[0])

    def _open_session(self, terrain: str = "flat") -> None:
        try:
            self.session = self.services.sessions.create(terrain, "maneuver", origin="studio")
        except SessionError as e:
            self.session = None
            self.notify("No live robot", e.message + " — authoring still works; reload to retry.", "red")

    # ---- helpers ------------------------------------------------------------------------------------------------
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
        from server.terrains import resolve_terrain, save_file

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
            if self.session is None or not self.authorized("change the terrain"):
                return
            try:
                terrain = resolve_terrain(str(txt.value).strip(), self.services.settings)
            except ApiError as e:
                self.notify("Terrain not usable", e.detail, "red")
                return
            self.session.reset(terrain)

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

    def _build_drive(self) -> None:
        from server.engine import steering_gaits, terrain_names

        gui = self.client.gui
        names = list(terrain_names())
        self.dd_terrain = gui.add_dropdown("terrain", names, initial_value="flat")
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
        with gui.add_folder("Steer (WASD + QE, X stops)"):
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

        @self.dd_terrain.on_update
        def _(e: Any) -> None:
            if self.session is not None and str(e.target.value) != self.session.terrain:
                if self.authorized("change the terrain"):
                    self.session.reset(str(e.target.value))

        @self.dd_maps.on_update
        def _(e: Any) -> None:
            maps = PERCEPTION.get(str(e.target.value), "truth")
            if self.session is not None and maps != self.session.maps and self.authorized("change the maps"):
                self.session.reset(maps=maps)

        @btn_reset.on_click
        def _(_: Any) -> None:
            if self.session is not None and self.authorized("reset"):
                self.session.reset()

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

        def send() -> None:
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

        btn_send.on_click(lambda _e: send())

        def stop() -> None:
            self.sl_vx.value = self.sl_vy.value = self.sl_yaw.value = 0.0
            send()

        btn_stop.on_click(lambda _e: stop())

        def nudge(handle: Any, step: float) -> None:
            handle.value = float(np.clip(float(handle.value) + step, handle.min, handle.max))
            send()

        keys = [("W", self.sl_vx, STEER_STEP["vx"]), ("S", self.sl_vx, -STEER_STEP["vx"]),
                ("A", self.sl_vy, STEER_STEP["vy"]), ("D", self.sl_vy, -STEER_STEP["vy"]),
                ("Q", self.sl_yaw, STEER_STEP["yaw_rate"]), ("E", self.sl_yaw, -STEER_STEP["yaw_rate"])]  # fmt: skip
        for key, handle, step in keys:
            try:
                cmd = gui.add_command(f"steer {key}", hotkey=key, description="nudge the velocity command")
            except Exception:  # noqa: BLE001 - hotkeys are a convenience (older viser)
                break
            cmd.on_trigger(lambda _e, h=handle, s=step: nudge(h, s))
        try:
            gui.add_command("stop", hotkey="X", description="zero the velocity command").on_trigger(
                lambda _e: stop()
            )
        except Exception:  # noqa: BLE001
            pass

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

    def _build_plots(self) -> None:
        import viser.uplot as up

        gui = self.client.gui
        z = np.zeros(2)
        self.plot_solver = gui.add_uplot(
            data=(np.array([0.0, 1.0]), z),
            series=(up.Series(label="t (s)"), up.Series(label="controller ms/tick", stroke="#f3a712", width=1.5)),
            title="Solver time per tick (ms)", aspect=1.6,
        )  # fmt: skip
        self.plot_vel = gui.add_uplot(
            data=(np.array([0.0, 1.0]), z, z, z, z),
            series=(up.Series(label="t (s)"), up.Series(label="vx", stroke="#4cc9f0", width=1.5),
                    up.Series(label="vx ref", stroke="#4cc9f0", dash=(4.0, 4.0), width=1.0),
                    up.Series(label="vy", stroke="#e4572e", width=1.5),
                    up.Series(label="vy ref", stroke="#e4572e", dash=(4.0, 4.0), width=1.0)),
            title="Velocity tracking (m/s)", aspect=1.6,
        )  # fmt: skip

    # ---- the render loop ----------------------------------------------------------------------------------------
    def _loop(self) -> None:
        period = 1.0 / FRAME_HZ
        last_seq = -1
        next_overlay = next_plot = next_status = 0.0
        while not self._stop.is_set():
            t0 = time.perf_counter()
            try:
                s = self.session
                if s is not None:
                    s.touch()
                    if s.generation != self.generation or self.view is None:
                        self._rebuild_scene(s)
                    snap = s.snapshot
                    if snap.seq != last_seq:
                        last_seq = snap.seq
                        with self.client.atomic():
                            assert self.view is not None
                            self.view.set_poses(snap.xpos, snap.xquat)
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
            time.sleep(max(0.0, period - (time.perf_counter() - t0)))

    def _rebuild_scene(self, s: LiveSession) -> None:
        self.generation = s.generation
        with s.lock:
            visuals = s.sim.visuals() if hasattr(s.sim, "visuals") else None
        if visuals is None:
            return
        key = (s.terrain, len(visuals.robot_geoms))
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
        st = s.state()
        dur = st.get("maneuver_duration") or 0.0
        status = st.get("status")
        line = (f"**{st.get('maneuver')}** on *{st.get('terrain')}* · t = {st.get('t', 0.0):.2f}"
                f"{f' / {dur:.1f}' if dur else ''} s · {status} · {st.get('realtime_factor', 0):.2f}× real time · "
                f"{self.fps:.0f} fps")  # fmt: skip
        if st.get("fell"):
            line += f"\n\n⚠ **fell**: {st.get('failure_reason')}"
        if status == "crashed":
            line += f"\n\n✖ **simulation crashed**: {st.get('error')} — press Reset robot"
        self.md_status.content = line


__all__ = ["StudioClient"]
