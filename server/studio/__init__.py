"""The browser studio (viser): a live robot per tab, maneuver authoring, driving, overlays and plots."""

from __future__ import annotations

import logging
import threading
from typing import Any

from server.studio.client import StudioClient

log = logging.getLogger("footfall.studio")


class Studio:
    """The viser server and one StudioClient per connected browser tab."""

    def __init__(self, services: Any) -> None:
        self.services = services
        self.settings = services.settings
        self.server: Any = None
        self.clients: dict[int, StudioClient] = {}
        self._closing: list[StudioClient] = []  # tabs being torn down (stop waits for their validations too)
        self._lock = threading.Lock()

    @property
    def port(self) -> int:
        return int(self.server.get_port()) if self.server is not None else self.settings.viewer_port

    def start(self) -> None:
        import viser

        self.server = viser.ViserServer(host=self.settings.host, port=self.settings.viewer_port, label="footfall",
                                        verbose=False)  # fmt: skip
        self.server.scene.set_up_direction("+z")
        self.server.on_client_connect(self._connect)
        self.server.on_client_disconnect(self._disconnect)
        log.info("studio on port %d", self.port)

    def _connect(self, client: Any) -> None:
        sc = StudioClient(self, client)
        with self._lock:
            self.clients[client.client_id] = sc
        try:
            sc.start()
        except Exception:  # noqa: BLE001 - one tab failing to build must not take the studio down
            log.exception("studio client %s failed to start", client.client_id)
            sc.notify("Studio error", "this tab could not be set up; see the server log", "red")

    def _disconnect(self, client: Any) -> None:
        with self._lock:
            sc = self.clients.pop(client.client_id, None)
            if sc is not None:
                self._closing.append(sc)
        if sc is not None:
            try:
                sc.stop()
            finally:
                with self._lock:
                    self._closing.remove(sc)

    def info(self) -> dict[str, Any]:
        with self._lock:
            clients = list(self.clients.items())
        return {
            "port": self.port,
            "clients": len(clients),
            "fps": {str(cid): round(c.fps, 1) for cid, c in clients},
            # the snapshots each tab's session published a second: fps / published is the share the tab passed on
            "published_fps": {str(cid): round(c.published_fps, 1) for cid, c in clients},
            "sessions": {str(cid): (c.session.id if c.session is not None else None) for cid, c in clients},
            # what each tab shows: its camera (m, world frame) and its steering sliders (m/s, m/s, rad/s)
            "cameras": {str(cid): c.camera_info() for cid, c in clients},
            "steer": {str(cid): c.slider_info() for cid, c in clients},
        }

    def stop(self) -> None:
        with self._lock:
            clients = list(self.clients.values())
            self.clients.clear()
            closing = list(self._closing)
        for c in clients:
            c.stop()
        for c in closing:  # a validation still solving when the interpreter exits aborts the process
            editor = getattr(c, "editor", None)
            if editor is not None:
                editor.close()
        if self.server is not None:
            try:
                self.server.stop()
            except Exception:  # noqa: BLE001
                pass
            self.server = None


__all__ = ["Studio", "StudioClient"]
