"""The studio's live stream: the robot poses a tab gets per second while its robot trots, beside what its session
published.

    python -m benchmarks.studio_stream                  # 20 s of trotting, one tab
    python -m benchmarks.studio_stream --duration 60 --json out.json

It builds the service in this process with the studio on, connects a minimal viser client (`FakeBrowser`: it sends
a camera, as a browser tab does, then drains what it is sent), steers the tab's robot to a trot at 0.3 m/s and
samples GET /studio twice a second: the tab's frame rate (poses sent over the last 2 s), its session's published
snapshots a second over the same window, and their ratio. The absolute rate depends on the machine and on what else
runs on it; the ratio is the studio's own share.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import viser
from websockets.sync.client import connect


class FakeBrowser:
    """Speaks just enough of viser's protocol to count as a connected tab (a camera message), then drains."""

    def __init__(self, port: int) -> None:
        self.ws = connect(
            f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], max_size=None
        )
        cam = {"type": "ViewerCameraMessage", "wxyz": [1, 0, 0, 0], "position": [2, -2, 1.2], "fov": 1.0,
               "near": 0.01, "far": 100.0, "image_height": 600, "image_width": 800, "look_at": [0, 0, 0.3],
               "up_direction": [0, 0, 1]}  # fmt: skip
        self.ws.send(msgspec.msgpack.encode(cam))
        self.bytes = 0
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._drain, daemon=True)
        self._t.start()

    def _drain(self) -> None:
        while not self._stop.is_set():
            try:
                self.bytes += len(self.ws.recv(timeout=0.5))
            except TimeoutError:
                continue
            except Exception:  # noqa: BLE001 - closed
                return

    def close(self) -> None:
        self._stop.set()
        self.ws.close()
        self._t.join(2.0)


def wait_for(pred: Callable[[], bool], timeout_s: float = 10.0) -> bool:
    """Whether pred() came true within timeout_s (checked every 50 ms)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.05)
    return False


def measure(duration_s: float = 20.0, settle_s: float = 4.0) -> dict[str, Any]:
    """Returns {"fps": {p50, p10, min}, "published_fps": {p50, p10}, "pass_on": {p50, p10}, "samples"}."""
    from fastapi.testclient import TestClient

    from server.app import create_app
    from server.settings import Settings

    with tempfile.TemporaryDirectory() as data:
        app = create_app(Settings(data_dir=Path(data), viewer_port=0, max_sessions=2), with_studio=True)
        with TestClient(app, raise_server_exceptions=False) as client:
            studio = app.state.services.studio
            browser = FakeBrowser(studio.port)
            try:
                if not wait_for(lambda: len(studio.clients) == 1, 30.0):
                    raise RuntimeError("the studio did not register the tab")
                tab = next(iter(studio.clients.values()))
                if not wait_for(lambda: tab.session is not None and getattr(tab, "ready", False), 120.0):
                    raise RuntimeError("the tab got no live robot")
                cid = str(tab.client.client_id)
                body = {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0, "gait": "trot"}
                client.post(f"/sessions/{tab.session.id}/steer", json=body).raise_for_status()
                time.sleep(settle_s)
                sent, pub = [], []
                end = time.monotonic() + duration_s
                while time.monotonic() < end:
                    info = client.get("/studio").json()
                    sent.append(float(info["fps"].get(cid, 0.0)))
                    pub.append(float(info["published_fps"].get(cid, 0.0)))
                    time.sleep(0.5)
            finally:
                browser.close()
    s, p = np.array(sent), np.array(pub)
    ratio = s / np.maximum(p, 1e-9)

    def pct(a: np.ndarray) -> dict[str, float]:
        return {"p50": round(float(np.percentile(a, 50)), 2), "p10": round(float(np.percentile(a, 10)), 2),
                "min": round(float(a.min()), 2)}  # fmt: skip

    return {"fps": pct(s), "published_fps": pct(p), "pass_on": pct(ratio), "samples": len(s)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=20.0, help="seconds of trotting sampled (default 20)")
    ap.add_argument("--json", metavar="FILE", help="write the result here")
    a = ap.parse_args()
    r = measure(a.duration)
    if a.json:
        Path(a.json).write_text(json.dumps(r, indent=2) + "\n")
    print(
        f"tab fps p50 {r['fps']['p50']:.1f} (p10 {r['fps']['p10']:.1f}); session published p50 "
        f"{r['published_fps']['p50']:.1f}/s; passed on p50 {r['pass_on']['p50']:.2f} (p10 {r['pass_on']['p10']:.2f})"
    )


if __name__ == "__main__":
    main()
