"""A preview as a self-contained HTML page: the session's recorded body poses replayed into viser's scene serializer.

The recording is made on a private viser server (loopback, an ephemeral port, no clients) so the live studio's
clients see nothing of it; the serializer's HTML embeds the viewer and the scene, and plays without any server.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

from server.errors import ApiError
from server.studio.robot_view import RobotView

_export_lock = threading.Lock()  # one export at a time: each briefly runs a private viser server


def recording_frames(session: Any) -> tuple[str, str, np.ndarray, np.ndarray, np.ndarray]:
    """Returns (maneuver, terrain, t (F,), xpos (F,nb,3), xquat (F,nb,4)) recorded since the maneuver started."""
    with session.lock:
        rec = session.recording
        t = np.array(rec.t, dtype=float)
        xpos = np.array(rec.xpos, dtype=float)
        xquat = np.array(rec.xquat, dtype=float)
    if len(t) < 2:
        raise ApiError(409, "nothing recorded yet: start a maneuver and let it run a moment",
                       [{"field": "recording", "reason": "empty"}])  # fmt: skip
    return rec.maneuver, rec.terrain, t, xpos, xquat


def recording_html(session: Any, dark_mode: bool = False) -> tuple[str, str]:
    """Returns (self-contained HTML, file stem) replaying the session's current maneuver as recorded."""
    import viser

    visuals_fn = getattr(session.sim, "visuals", None)
    if visuals_fn is None:
        raise ApiError(409, "this session's simulation has no visuals to record",
                       [{"field": "recording", "reason": "unavailable"}])  # fmt: skip
    name, terrain, t, xpos, xquat = recording_frames(session)
    visuals = visuals_fn()
    with _export_lock:
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        try:
            server.scene.set_up_direction("+z")
            view = RobotView(server.scene, visuals, root="/world")
            view.set_poses(xpos[0], xquat[0])
            ser = server.get_scene_serializer()
            for k in range(1, len(t)):
                ser.insert_sleep(float(max(0.0, t[k] - t[k - 1])))
                view.set_poses(xpos[k], xquat[k])
            html = ser.as_html(dark_mode=dark_mode)
        finally:
            server.stop()
    return html, f"{name}-{terrain}-preview"
