"""The studio without a browser: a raw viser websocket client connects, gets a live robot that passes on the poses
its session publishes, and the authoring panel's logic (open, edit, validate on items, drag, preview, save as,
export) runs on the real stack."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import viser
from fastapi.testclient import TestClient

from benchmarks.studio_stream import FakeBrowser, wait_for
from server.app import create_app
from server.settings import Settings
from server.studio.overlays import _point_size, default_on, overlay_geometry
from server.studio.robot_view import capsule_mesh, hfield_mesh
from server.studio.timeline import Bar, Mark, timeline_svg


@pytest.fixture(scope="module")
def studio_app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[TestClient, Any]]:
    data = tmp_path_factory.mktemp("studio")
    s = Settings(data_dir=data, viewer_port=0, max_sessions=3)
    app = create_app(s, with_studio=True)
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c, app.state.services


@pytest.fixture(scope="module")
def tab(studio_app: tuple[TestClient, Any]) -> Iterator[Any]:
    client, services = studio_app
    browser = FakeBrowser(services.studio.port)
    assert wait_for(lambda: client.get("/studio").json()["clients"] == 1), (
        "the studio did not register the tab"
    )
    studio_client = next(iter(services.studio.clients.values()))
    # the tab's live robot is a worker process of its own: on a loaded machine (CI beside other jobs) its start
    # takes seconds, so the wait is generous; the studio's own liveness is what the tests below check
    assert wait_for(
        lambda: studio_client.session is not None and getattr(studio_client, "ready", False), timeout_s=90.0
    ), "the tab got no live robot"
    yield studio_client
    browser.close()
    assert wait_for(lambda: client.get("/studio").json()["clients"] == 0)


def _tab_fps(client: TestClient, tab: Any) -> float:
    return float(client.get("/studio").json()["fps"].get(str(tab.client.client_id), 0.0))


def _fps_while_trotting(client: TestClient, tab: Any, at_least: float) -> bool:
    """Whether the tab gets at least `at_least` poses a second while its robot trots (a robot standing still is
    not sent: the studio only sends poses that moved); the robot is put back standing at the origin after."""
    sid = tab.session.id
    r = client.post(f"/sessions/{sid}/steer", json={"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0, "gait": "trot"})
    assert r.status_code == 200, r.text
    try:
        return wait_for(lambda: _tab_fps(client, tab) >= at_least, 20.0)
    finally:
        client.post(f"/sessions/{sid}/reset")


def test_a_tab_gets_a_live_robot(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    client, _ = studio_app
    sid = tab.session.id
    sessions = {s["id"]: s for s in client.get("/sessions").json()}
    assert sessions[sid]["origin"] == "studio"
    # poses stream to the tab (how fast depends on the machine's load: the rate is checked on its own below)
    assert _fps_while_trotting(client, tab, 5.0), client.get("/studio").json()
    # standing still, the robot costs the tab no frames
    assert wait_for(lambda: _tab_fps(client, tab) < 1.0, 20.0), client.get("/studio").json()
    assert tab.view is not None and len(tab.view.bodies) >= 13  # trunk + 4 × (hip, upper, lower)


# The share of the poses its session publishes that a tab sends on, reached at least once within 20 s of trotting.
# `python -m benchmarks.studio_stream` on 2 cores (AMD EPYC), 2 s windows, p50 (p10): at 07:45 UTC 1.00 (0.99) alone,
# 0.92 (0.89) beside 2 busy processes, 0.97 (0.92) beside 4, 0.98 (0.92) beside 6; at 09:34, the host slower, 0.92
# (0.88), 0.88 (0.77), 0.94 (0.85), 0.96 (0.81).
PASS_ON = 0.8


def _published_fps(client: TestClient, tab: Any) -> float:
    return float(client.get("/studio").json()["published_fps"].get(str(tab.client.client_id), 0.0))


@pytest.mark.load
def test_a_tab_passes_on_the_poses_its_session_publishes(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    """While its robot trots, a tab sends on at least PASS_ON of the snapshots its session publishes (up to 60 a
    second, fewer when the machine cannot keep the session at real time): the studio's render loop is not what
    limits the frame rate. The absolute rate depends on the machine and what else runs on it, so it is a measure
    (`python -m benchmarks.studio_stream`), not a test: a CI run beside other jobs once got 31/s with the session
    publishing fewer than 60."""
    client, _ = studio_app
    sid = tab.session.id
    r = client.post(f"/sessions/{sid}/steer", json={"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0, "gait": "trot"})
    assert r.status_code == 200, r.text
    ratios: list[tuple[float, float]] = []
    try:
        assert wait_for(lambda: _tab_fps(client, tab) >= 5.0, 20.0), client.get("/studio").json()
        time.sleep(2.5)  # a whole window of trotting
        end = time.monotonic() + 20.0
        while time.monotonic() < end:
            sent, published = _tab_fps(client, tab), _published_fps(client, tab)
            ratios.append((sent, published))
            if published >= 10.0 and sent >= PASS_ON * published:
                break
            time.sleep(0.5)
    finally:
        client.post(f"/sessions/{sid}/reset")
    sent, published = ratios[-1]
    assert published >= 10.0, f"the session published {published:.0f} snapshots/s: {ratios}"
    assert sent >= PASS_ON * published, f"the tab passed on {sent:.0f} of {published:.0f} a second: {ratios}"


def test_a_check_of_an_older_document_does_not_hide_newer_problems(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    """Edits validate after a quiet period on a timer thread; a check that began before the latest edit (its
    document older) and ends after the latest check must leave the newer problems shown."""
    ed = tab.editor
    assert ed.open("bow")
    ed.sl_scrub.value = 1.0
    ed.add_step("FL")
    lo, td = next(p for p in ed._steps_of("FL"))
    old_doc, old_rev = ed.document(), ed._rev
    ed._set(td, "t", 0.9)  # touchdown before its liftoff
    assert not ed.validate_now().ok
    ui = ed.item_ui[id(td)]
    assert ui.folder.label.startswith("✖")
    # the late check of the document as it was before the edit: valid, but stale
    new_rev, document = ed._rev, ed.document
    ed._rev, ed.document = old_rev, lambda: old_doc
    try:
        assert ed.validate_now().ok
    finally:
        ed._rev, ed.document = new_rev, document
    assert ui.folder.label.startswith("✖") and ui.problems.visible and not ed.result.ok
    ed.delete_items(lo, td)
    assert ed.validate_now().ok


def test_open_edit_validate_and_preview(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    client, _ = studio_app
    ed = tab.editor
    assert ed.open("bow") and ed.meta["name"] == "bow" and ed.source == "shipped"
    assert ed.validate_now().ok
    # an edit that breaks a rule shows up on the item it concerns
    ed.sl_scrub.value = 1.0
    ed.add_step("FL")
    lo, td = next(p for p in ed._steps_of("FL"))
    assert lo["t"] == pytest.approx(1.0)
    ed._set(td, "t", 0.9)  # touchdown before its liftoff
    result = ed.validate_now()
    assert result is not None and not result.ok
    ui = ed.item_ui[id(td)]
    assert ui.folder.label.startswith("✖") and ui.problems.visible and "before" in ui.problems.content
    ed.delete_items(lo, td)
    assert ed.validate_now().ok
    # dragging a keyframe in 3D writes its position and rpy back into the document
    kf = ed.keyframes[0]
    off = tab.world_offset()
    q = np.array([np.cos(np.radians(5)), 0.0, np.sin(np.radians(5)), 0.0])  # 10° pitch
    ed._commit_drag(kf, np.array([0.05, 0.0, 0.47]) + off, q, True)
    assert kf["position"] == pytest.approx([0.05, 0.0, 0.47]) and kf["rpy"][1] == pytest.approx(
        10.0, abs=0.05
    )
    # preview runs it on the live session
    before = np.array(client.get(f"/sessions/{tab.session.id}/state").json()["body"]["rpy_deg"])
    ed.sl_speed.value = 2.0
    ed.preview()
    assert client.get(f"/sessions/{tab.session.id}/state").json()["maneuver"] == "bow"
    assert wait_for(
        lambda: (
            abs(client.get(f"/sessions/{tab.session.id}/state").json()["body"]["rpy_deg"][1] - before[1])
            > 5.0
        ),
        8.0,
    ), "the robot did not pitch during the bow preview"


def test_save_as_then_save_with_etag(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    client, services = studio_app
    ed = tab.editor
    ed.open("stand")
    ed.save("my-stand")
    assert ed.source == "user" and ed.etag and client.get("/maneuvers/my-stand").status_code == 200
    path = Path(services.settings.user_dir) / "my-stand.yaml"
    ed.meta["title"] = "Mine"
    ed.save(None)
    assert "Mine" in path.read_text()
    # someone else edits the file: the studio's next save is refused, the other edit survives
    etag = client.get("/maneuvers/my-stand").headers["etag"]
    doc = client.get("/maneuvers/my-stand").json()
    doc["title"] = "Theirs"
    assert client.put("/maneuvers/my-stand", json=doc, headers={"If-Match": etag}).status_code == 200
    ed.meta["title"] = "Mine again"
    ed.save(None)
    assert "Theirs" in path.read_text()


def test_export_recording_is_self_contained(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    client, _ = studio_app
    time.sleep(0.5)
    r = client.get(f"/sessions/{tab.session.id}/recording")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    assert "__VISER_EMBED_DATA__" in r.text and "attachment" in r.headers["content-disposition"]
    assert "ws://" not in r.text.split("__VISER_EMBED_DATA__")[0][-2000:]  # plays from the embedded data


def test_landing_preview_request_is_picked_up(studio_app: tuple[TestClient, Any]) -> None:
    client, services = studio_app
    assert client.post("/studio/preview", json={"maneuver": "nope"}).status_code == 404
    assert client.post("/studio/preview", json={"maneuver": "../x"}).status_code == 422
    assert client.post("/studio/preview", json={"maneuver": "crouch"}).status_code == 202
    browser = FakeBrowser(services.studio.port)
    try:

        def crouching() -> bool:
            return any(
                s["maneuver"] == "crouch" and s["origin"] == "studio" for s in client.get("/sessions").json()
            )

        assert wait_for(crouching), client.get("/sessions").json()
    finally:
        browser.close()


# ---- pure pieces ------------------------------------------------------------------------------------------------------
def test_overlay_geometry_is_generic() -> None:
    kind, arr = overlay_geometry({"kind": "polyline", "points": [[0, 0, 0], [1, 0, 0], [1, 1, 0]]}) or (
        "",
        None,
    )
    assert kind == "segments" and arr.shape == (2, 2, 3)
    kind, arr = overlay_geometry({"kind": "segments", "points": [[0, 0, 0], [0, 0, 1], [1, 0, 0]]}) or (
        "",
        None,
    )
    assert arr.shape == (1, 2, 3)
    assert overlay_geometry({"kind": "points", "points": [[0, 0, float("nan")]]}) is None
    assert overlay_geometry({"kind": "nonsense", "points": [[0, 0, 0]]}) is None
    assert overlay_geometry({"kind": "points", "points": "junk"}) is None


def test_overlay_points_take_their_own_size_within_bounds_and_busy_ones_start_hidden() -> None:
    assert _point_size({"kind": "points"}) == 0.04
    assert _point_size({"point_size": 0.02}) == 0.02
    assert _point_size({"point_size": "big"}) == 0.04 and _point_size({"point_size": 50}) == 0.04
    assert default_on("terrain_no_step") and default_on("body_path_plan") and default_on("step_qp_footholds")
    assert not default_on("depth_cloud") and not default_on("step_qp_reference")


def test_meshes_and_timeline() -> None:
    v, f = capsule_mesh(0.02, 0.15)
    assert v[:, 2].max() == pytest.approx(0.17, abs=1e-6) and v[:, 2].min() == pytest.approx(-0.17, abs=1e-6)
    assert f.max() < len(v)
    v, f = hfield_mesh(np.zeros((3, 4)), 1.0, 0.5)
    assert v.shape == (12, 3) and f.shape == (12, 3) and v[:, 0].max() == 1.0 and v[:, 1].min() == -0.5
    svg = timeline_svg(
        4.0, [Bar("RL", 0.8, 1.4, True, "failure")], [Mark("body", 2.0)], [(1.0, 3.0, "trot")], 1.2
    )
    assert svg.startswith("<svg") and "#ff3b30" in svg and "trot" in svg and svg.count("<rect") >= 2


# ---- the defects of issue 28 ------------------------------------------------------------------------------------------
def _viser_camera_keys() -> set[str]:
    """Returns the keys viser's viewer flies its camera with, read from the client source viser ships."""
    import re

    src = (Path(viser.__file__).parent / "client" / "src" / "CameraControls.tsx").read_text()
    block = src[src.index("CAMERA_MOVEMENT_KEYS = new Set([") :]
    block = block[: block.index("])")]
    codes = re.findall(r'"(\w+)"', block)
    assert "KeyW" in codes and "ArrowUp" in codes, codes  # the parse found the set
    return {c[3:].upper() if c.startswith("Key") else c.lower() for c in codes}


def test_steering_keys_are_not_camera_keys() -> None:
    """viser flies its camera on W A S D Q E and the arrows whatever else they do: the studio's keys avoid them."""
    from server.studio.client import CAMERA_KEYS, STEER_KEYS, STOP_KEY

    camera = _viser_camera_keys()
    assert camera == {k.upper() if len(k) == 1 else k for k in CAMERA_KEYS}
    from server.studio.editor import EDIT_KEYS

    ours = {k for k, _, _ in STEER_KEYS} | {STOP_KEY}
    assert len(ours) == 7 and not ours & camera, ours & camera
    edit = {k for _, k, _, _ in EDIT_KEYS}  # with or without a modifier: viser's camera reads the key alone
    assert {"Z", "C", "V", "delete"} <= edit and not edit & camera, edit & camera


def test_reset_view_brings_the_camera_back(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    cam = tab.client.camera
    cam.position = (0.3, 0.2, -2.0)  # under the floor, as three presses of W used to leave it
    cam.look_at = (0.3, 0.2, -3.0)
    tab.reset_view()
    body = np.asarray(tab.session.snapshot.xpos[0])
    assert cam.position[2] > body[2] + 0.5 and np.linalg.norm(np.asarray(cam.look_at) - body) < 1e-6


def test_folder_titles_follow_edits(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    ed = tab.editor
    assert ed.open("jump")
    lo, td = next(p for p in ed._steps_of("FL"))
    ui = ed.item_ui[id(td)]
    assert "1.20 → 1.42" in ui.folder.label
    ui.handles["td_t"].value = 1.55  # as the user types it
    assert (
        td["t"] == pytest.approx(1.55) and "1.20 → 1.55" in ui.folder.label and "1.42" not in ui.folder.label
    )
    ed.validate_now()
    assert "1.20 → 1.55" in ui.folder.label  # the problem mark keeps the new title
    kf = ed.keyframes[1]
    ed.item_ui[id(kf)].handles["t"].value = 1.33
    assert ed.item_ui[id(kf)].folder.label.endswith("keyframe 1.33 s")


def test_library_dropdown_shows_the_open_maneuver(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    ed = tab.editor
    for name in ("crouch", "bow"):
        assert ed.open(name)
        assert ed.dd_library.value == name


def test_editor_limits_are_the_formats(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    """The editor's inputs take their limits from the pydantic models (the spec says a gait cycle is ≥ 0.1 s)."""
    from planning.maneuver.spec import MAX_DURATION_S, Weights

    ed = tab.editor
    assert ed.open("walk-forward") and ed.gaits
    h = ed.item_ui[id(ed.gaits[0])].handles
    assert h["cycle"].min == pytest.approx(0.1) and h["cycle"].max == pytest.approx(10.0)
    assert 0.0 < h["duty"].min and h["duty"].max < 1.0
    assert h["from"].max == pytest.approx(MAX_DURATION_S) and h["cycle"].hint
    assert set(ed.num_weights) == set(Weights.model_fields)
    assert ed.num_duration.max == pytest.approx(MAX_DURATION_S) and ed.num_friction.max == pytest.approx(3.0)


def test_rest_steering_shows_on_the_sliders(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    client, _ = studio_app
    sid = tab.session.id
    r = client.post(f"/sessions/{sid}/steer", json={"vx": 0.3, "vy": -0.1, "yaw_rate": 0.4})
    assert r.status_code == 200, r.text
    want = {"vx": 0.3, "vy": -0.1, "yaw_rate": 0.4}
    assert wait_for(lambda: client.get("/studio").json()["steer"][str(tab.client.client_id)] == want, 5.0)
    # a new terrain starts standing: the sliders go back to 0 (and the robot does not walk off again)
    tab.dd_terrain.value = "slope"
    assert tab.slider_info() == {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0} and tab.session.command is None
    time.sleep(0.6)  # a few status updates: the sliders stay at 0
    assert tab.slider_info() == {"vx": 0.0, "vy": 0.0, "yaw_rate": 0.0}
    tab.dd_terrain.value = "flat"


def test_the_robot_picker_redraws_the_tab_on_another_robot(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    client, _ = studio_app
    names = [e["name"] for e in client.get("/robots").json()]
    assert set(tab.dd_robot.options) == set(names) and tab.dd_robot.value == "spot"
    sid, view = tab.session.id, tab.view
    tab.dd_robot.value = "go1"  # resets the tab's session on go1: a new simulation, the scene redrawn
    try:
        assert client.get(f"/sessions/{sid}/state").json()["robot"] == "go1"
        assert wait_for(lambda: tab.view is not None and tab.view is not view, 10.0)
        body_z = float(tab.session.snapshot.xpos[0][2])
        assert 0.2 < body_z < 0.4, body_z  # go1 stands ~0.30 m high (spot 0.52 m)
        # the Author tab validates for the picked robot: bow comes back scaled to the go1's height
        assert tab.editor.robot_load() == "go1"
        assert tab.editor.open("bow")  # (the tab is shared: another test may have left any document open)
        checked = tab.editor.validate_now()
        assert checked is not None and max(k.position[2] for k in checked.maneuver.body) < 0.4
    finally:  # the next tests on this tab expect the server's robot
        tab.dd_robot.value = "spot"
    assert wait_for(
        lambda: tab.session.robot == "spot" and float(tab.session.snapshot.xpos[0][2]) > 0.45, 10.0
    )


def test_plots_count_seconds_not_dates(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    for plot in (tab.plot_solver, tab.plot_vel):
        assert plot.scales["x"]["time"] is False and plot.axes[0]["label"] == "t (s)"


def test_status_line() -> None:
    from server.studio.client import status_line

    st = {"maneuver": "jump", "terrain": "flat", "t": 78.48, "maneuver_duration": 10.0, "status": "running",
          "realtime_factor": 1.0, "done": True, "fell": False}  # fmt: skip
    line = status_line(st, 55.0)
    assert "t = 10.00 / 10.0 s" in line and "done" in line and "78" not in line
    st |= {
        "t": 2.75,
        "done": False,
        "fell": True,
        "failure_reason": "fell: body dropped to 0.12 m at t=2.75 s",
    }
    line = status_line(st, 55.0)
    assert (
        line.count("fell") == 2 and "fell: fell" not in line and "· fell ·" in line and "running" not in line
    )
    assert "body dropped to 0.12 m" in line


def test_a_fallen_robot_goes_limp() -> None:
    """After a fall the controller stops: zero joint torques, no stage runs, the state still follows physics."""
    from server.engine import LiveSim, default_maneuver

    sim = LiveSim(default_maneuver("stand"), "flat")
    for _ in range(20):
        sim.step()
    assert np.abs(sim.data.ctrl).max() > 1.0  # standing takes torque
    loop = sim.session.loop
    loop.fell, loop.failure_reason = True, "fell: pushed over (test)"
    runs = [len(st.times_ms) for st in loop.stages]
    z0 = float(sim.state.p_world_body[2])
    for _ in range(250):
        sim.step()
    assert np.abs(sim.data.ctrl).max() == 0.0 and [len(st.times_ms) for st in loop.stages] == runs
    assert float(sim.state.p_world_body[2]) < z0 - 0.05  # limp: it sags under its own weight
    assert sim.state_dict()["fell"] and sim.t == pytest.approx(0.54, abs=0.01)


# ---- the timeline worked with the mouse (the ops page.js sends) -------------------------------------------------------
def test_timeline_drags_snap_and_undo(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    ed = tab.editor
    assert ed.open("jump")
    ed.cb_snap_beats.value, ed.grid_s = False, 0.05
    lo, td = next(p for p in ed._steps_of("FL"))
    # a swing bar dragged by 0.13 s: both events move, the liftoff lands on the 0.05 s grid
    ed.timeline_op({"op": "drag", "ids": [id(lo), id(td)], "part": "move", "dt": 0.13, "n": 1})
    assert lo["t"] == pytest.approx(1.35) and td["t"] == pytest.approx(1.57)
    ed.timeline_op(
        {"op": "drag", "ids": [id(lo), id(td)], "part": "move", "dt": 0.13, "n": 1}
    )  # delivered twice
    assert lo["t"] == pytest.approx(1.35)
    # its touchdown end stretched, its adjust window widened
    ed.timeline_op({"op": "drag", "ids": [id(td)], "part": "end", "dt": 0.11, "n": 2})
    assert td["t"] == pytest.approx(1.70) and lo["t"] == pytest.approx(1.35)
    ed.timeline_op({"op": "drag", "ids": [id(td)], "part": "adjust", "dt": 0.04, "n": 3})
    assert td["adjust"]["time"] == pytest.approx(0.1)
    # a keyframe never leaves the maneuver
    kf = ed.keyframes[-1]
    ed.drag([id(kf)], "move", 10.0)
    assert kf["t"] == pytest.approx(float(ed.meta["duration"]))
    # undo walks back edit by edit (items are rebuilt: find them by leg and order), redo forward
    for _ in range(4):
        assert ed.undo()
    lo, td = next(p for p in ed._steps_of("FL"))
    assert (lo["t"], td["t"]) == (pytest.approx(1.2), pytest.approx(1.42)) and not ed.undo()
    assert ed.redo()
    lo, td = next(p for p in ed._steps_of("FL"))
    assert lo["t"] == pytest.approx(1.35)
    # a broken edit (touchdown dragged before its liftoff) shows on its bar in the timeline
    ed.drag([id(td)], "end", -0.5)
    ed.validate_now()
    lo, td = next(p for p in ed._steps_of("FL"))
    assert ed._severity(id(td)) == "failure" or ed._severity(id(lo)) == "failure"
    assert "#ff3b30" in ed.html_timeline.content


def test_timeline_select_copy_paste_duplicate_delete_and_zoom(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    ed = tab.editor
    assert ed.open("jump")
    ed.cb_snap_beats.value, ed.grid_s = False, 0.01
    n_ev, n_kf = len(ed.events), len(ed.keyframes)
    lo, td = next(p for p in ed._steps_of("RL"))
    kf = ed.keyframes[0]
    ed.timeline_op({"op": "select", "ids": [id(lo), id(td)], "n": 10})
    ed.timeline_op({"op": "select", "ids": [id(kf)], "add": True, "n": 11})
    assert ed.selected == {id(lo), id(td), id(kf)} and 'stroke="#ffffff"' in ed.html_timeline.content
    # dragging one selected item moves the whole selection
    ed.drag([id(kf)], "move", 0.1)
    assert kf["t"] == pytest.approx(1.0) and lo["t"] == pytest.approx(1.3) and td["t"] == pytest.approx(1.52)
    assert ed.copy_selection() == 3
    assert ed.paste(2.0) == 3 and len(ed.events) == n_ev + 2 and len(ed.keyframes) == n_kf + 1
    pasted = sorted(float(it["t"]) for it in ed.events + ed.keyframes if id(it) in ed.selected)
    assert pasted == pytest.approx([2.0, 2.3, 2.52])
    assert ed.duplicate_selection() == 3 and len(ed.keyframes) == n_kf + 2
    assert ed.delete_selection() == 3 and len(ed.keyframes) == n_kf + 1 and len(ed.events) == n_ev + 2
    # zoom: the SVG shows the window asked for; the whole maneuver again on request
    ed.timeline_op({"op": "view", "t0": 1.0, "t1": 2.0, "n": 12})
    assert ed.view == (1.0, 2.0) and 'data-v0="1.0000" data-v1="2.0000"' in ed.html_timeline.content
    ed.timeline_op({"op": "view", "t0": None, "t1": None, "n": 13})
    assert ed.view is None
    ed.timeline_op({"op": "scrub", "t": 1.234, "n": 14})
    assert ed.sl_scrub.value == pytest.approx(1.23)
    ed.timeline_op({"op": "drag", "ids": ["junk"], "n": 15})  # malformed: ignored


def test_moves_library_validates_and_inserts_at_the_playhead(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    """At least 20 moves, each a valid maneuver file; inserting one shifts it to the playhead (twice: back to
    back), grows the maneuver to hold it, selects what it added, and undoes in one step."""
    from planning.maneuver import validate_maneuver
    from server.studio.editor import MOVES_DIR, move_names

    names = move_names()
    assert len(names) >= 20
    for name in names:
        r = validate_maneuver(MOVES_DIR / f"{name}.yaml", tab.services.robot)
        assert r.ok, (name, [p.message for p in r.failures])
    ed = tab.editor
    ed.cb_snap_beats.value, ed.grid_s = False, 0.05
    assert ed.open("bow")
    n_kf = len(ed.keyframes)
    ed.sl_scrub.value = 5.0
    added = ed.insert_move("step-fl", ed._scrub_t(), repeat=2)
    assert (
        added == 2 * (2 + 3) and len(ed.keyframes) == n_kf + 6 and ed.meta["duration"] == pytest.approx(9.4)
    )
    lifts = sorted(e["t"] for e in ed.events if e["leg"] == "FL" and e["type"] == "liftoff")
    assert lifts == [pytest.approx(5.7), pytest.approx(7.9)] and len(ed.selected) == added
    assert ed.num_duration.value == pytest.approx(9.4) and ed.validate_now().ok
    assert (
        ed.undo()
        and len(ed.keyframes) == n_kf
        and not ed.events
        and ed.meta["duration"] == pytest.approx(6.0)
    )
    # a move's natural parameters: picking it shows its own values, inserting with another rescales it
    ed.dd_move.value = "turn-left-45"
    assert wait_for(lambda: ed.num_move_params["angle"].value == pytest.approx(45.0))
    assert ed.num_move_params["distance"].disabled and not ed.num_move_params["angle"].disabled
    ed.num_move_params["angle"].value = 90.0
    assert ed.move_params() == {"angle": 90.0}
    n_gaits = len(ed.gaits)
    assert (
        ed.insert_move("turn-left-45", 6.0, 1, ed.move_params()) == 0
    )  # a gait segment: no timed item added
    g = ed.gaits[n_gaits]
    cycles = round((g["to"] - g["from"]) / g["cycle"])
    assert cycles * g["step"][2] == pytest.approx(90.0) and g["from"] == pytest.approx(6.3)
    assert ed.insert_move("bow", 1.0, 1, {"angle": 10.0}) == 0  # told: bow does not turn
    ed.undo()


def test_replay_a_preview_frame_by_frame_with_the_run_before_as_a_ghost(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    ed = tab.editor
    assert ed.open("bow")
    ed.sl_speed.value = 2.0
    ed.preview()
    assert wait_for(lambda: tab.session.snapshot.state.get("t", 0.0) > 1.5, 15.0)
    ed.preview()  # the same maneuver again: the first run becomes the ghost
    assert tab.prev_take is not None and tab.prev_take.maneuver == "bow" and tab.prev_take.t[-1] > 1.4
    assert wait_for(lambda: tab.session.snapshot.state.get("t", 0.0) > 1.0, 15.0)
    ed.cb_replay.value = True
    ed.sl_scrub.value = 0.8
    take = tab.take
    assert take is not None and take.maneuver == "bow"
    k = take.index_at(0.8)
    assert take.t[k] <= 0.8 + 1e-9 and np.allclose(tab.view.bodies[0].position, take.xpos[k][0])
    tab.step_frames(3)
    assert (
        ed.sl_scrub.value == pytest.approx(take.t[k + 3], abs=0.006)
        and f"frame {k + 4} of" in ed.md_replay.content
    )
    # the ghost shows the run before at the playhead
    assert tab.ghost is not None and tab.ghost.bodies[0].visible
    kk = tab.prev_take.index_at(float(ed.sl_scrub.value))
    assert np.allclose(tab.ghost.bodies[0].position, tab.prev_take.xpos[kk][0])
    ed.cb_ghost.value = False
    assert not tab.ghost.bodies[0].visible
    ed.cb_replay.value = False
    ed.cb_ghost.value = True


def _click_track(bpm: float, offset_s: float, duration_s: float = 10.0, rate: int = 22050) -> bytes:
    """A stereo 16-bit WAV: decaying 880 Hz clicks on every beat over a little noise."""
    import io
    import wave

    x = np.random.default_rng(0).normal(0.0, 0.01, int(rate * duration_s))
    n = int(0.03 * rate)
    click = 0.8 * np.sin(2 * np.pi * 880 * np.arange(n) / rate) * np.exp(-np.arange(n) / (0.01 * rate))
    tb = offset_s
    while tb < duration_s - 0.05:
        i = int(tb * rate)
        x[i : i + n] += click[: len(x[i : i + n])]
        tb += 60.0 / bpm
    s = (np.clip(x, -1, 1) * 32767).astype(np.int16)
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(2)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(np.stack([s, s], 1).tobytes())
    return buf.getvalue()


@pytest.mark.parametrize("bpm, offset_s", [(123.0, 0.31), (96.0, 0.05), (150.0, 0.42)])
def test_music_tempo_and_beats(bpm: float, offset_s: float) -> None:
    from server.studio.music import find_beats, read_wav

    b = find_beats(*read_wav(_click_track(bpm, offset_s)))
    assert b.bpm == pytest.approx(bpm, abs=1.0) and b.offset_s == pytest.approx(offset_s, abs=0.02)
    assert b.snap(offset_s + 2 * 60.0 / bpm + 0.1) == pytest.approx(offset_s + 2 * 60.0 / bpm, abs=0.03)


def test_music_on_the_timeline_and_snapping_to_beats(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    from server.studio.music import AudioError, read_wav

    with pytest.raises(AudioError, match="WAV"):
        read_wav(b"RIFF....not audio")
    ed = tab.editor
    assert ed.open("jump")
    assert ed.load_music(b"junk", "junk.mp3") is None  # told, not raised
    b = ed.load_music(_click_track(120.0, 0.25), "click.wav")
    assert b is not None and ed.num_bpm.value == pytest.approx(120.0, abs=1.0)
    assert ed.html_timeline.content.count('stroke-dasharray="1 2"') == len(b.times(3.5)) == 7
    kf = ed.keyframes[
        -1
    ]  # 2.80 s: dragged 0.1 s later it lands on the beat at 2.75 + 0.5 = 3.25 s? no: nearest
    ed.drag([id(kf)], "move", 0.1)
    assert kf["t"] == pytest.approx(b.snap(2.9), abs=1e-3) and kf["t"] == pytest.approx(2.75, abs=0.03)
    # the tab gets a small copy of the music to play, and a clock that follows the preview
    assert ed.html_audio.content.startswith("<audio data-footfall-audio")
    assert len(ed.html_audio.content) < 2_000_000
    state = {
        "status": "running",
        "mode": "maneuver",
        "t": 1.25,
        "speed": 0.5,
        "generation": 3,
        "maneuver": "jump",
    }
    ed.show_clock(state)
    assert 'data-t="1.250" data-playing="1" data-rate="0.500" data-run="3:jump"' in ed.html_clock.content
    ed.show_clock({**state, "status": "paused"})
    assert 'data-playing="0"' in ed.html_clock.content
    ed.show_clock({**state, "fell": True})
    assert 'data-playing="0"' in ed.html_clock.content
    # the maneuver keeps its tempo and first beat: saved, reopened without the audio, the grid comes back
    kept = ed.document()[0]["music"]
    assert kept == {"bpm": pytest.approx(b.bpm), "offset": pytest.approx(b.offset_s), "file": "click.wav"}
    ed.save("jump-on-beat")
    stored = ed.services.store.get("jump-on-beat")
    assert "music:" in stored.text and "click.wav" in stored.text
    ed.beats = None
    assert ed.open("jump-on-beat") and ed.beats is not None
    assert ed.beats.bpm == pytest.approx(b.bpm) and ed.num_beat_offset.value == pytest.approx(b.offset_s)
    ed.num_bpm.value = 100.0  # retimed by hand: the document follows
    assert wait_for(lambda: ed.document()[0]["music"]["bpm"] == pytest.approx(100.0))
    ed.cb_snap_beats.value = False  # the tab is shared with the other tests
    ed.beats = None


def test_save_a_selection_as_a_move_and_insert_it(studio_app: tuple[TestClient, Any], tab: Any) -> None:
    ed = tab.editor
    ed.cb_snap_beats.value, ed.grid_s = False, 0.05
    assert ed.open("step-in-place")
    lo, td = next(p for p in ed._steps_of("FL"))
    kfs = [k for k in ed.keyframes if 2.0 <= float(k["t"]) <= 2.8]
    assert ed.save_selection_as_move("my-step") is None  # nothing selected: told, not saved
    ed.select_items([id(lo), id(td), *(id(k) for k in kfs)])
    assert ed.save_selection_as_move("Bad Name") is None
    path = ed.save_selection_as_move("my-step")
    assert path is not None and path.parent == ed.user_moves_dir() and "my-step" in ed.dd_move.options
    from planning.maneuver import validate_maneuver

    assert validate_maneuver(path, tab.services.robot).ok
    assert ed.open("stand")
    assert ed.insert_move("my-step", 1.0) == 2 + len(kfs) + 1
    lifts = [e["t"] for e in ed.events if e["type"] == "liftoff"]
    assert lifts == [pytest.approx(1.0 + float(lo["t"]) - min(float(lo["t"]), *(float(k["t"]) for k in kfs)))]


@pytest.mark.sim
def test_validate_runs_the_physics_check_and_marks_the_timeline(
    studio_app: tuple[TestClient, Any], tab: Any
) -> None:
    """The issue's edit: `jump` with FL's touchdown 1.42 → 1.55 s passes the rules and the dry solve, but Validate
    (physics check on by default) runs it headless on the simulation pool: a failure on that touchdown's item, a red
    dot under it on the timeline with the numbers in its tooltip, the other events' dots colored by margin."""
    ed = tab.editor
    assert ed.open("jump") and ed.cb_physics.value is True
    lo, td = next(p for p in ed._steps_of("FL"))
    ed._set(td, "t", 1.55)
    assert ed.validate_now().ok  # rules and dry solve: valid
    ed.validate_now(announce=True)  # the Validate button: the physics check follows in the background
    assert wait_for(lambda: ed._physics_rev == ed._rev and ed.physics is not None, 120.0), ed.physics
    assert ed.physics["ran"] and not ed.physics["success"], ed.physics
    assert ed.physics["responsible"]["leg"] == "FL" and ed.physics["responsible"]["t"] == pytest.approx(1.55)
    # the result is stored, then the items and the timeline are redrawn from it (the checking thread, just after)
    assert wait_for(lambda: 'data-physics="failure"' in ed.html_timeline.content, 30.0)
    assert ed._severity(id(td)) == "failure" and not ed.result.ok
    svg = ed.html_timeline.content
    assert svg.count('data-physics="failure"') == 1 and svg.count("<circle data-physics") == 8
    assert "FL touchdown at 1.55 s — failure" in svg and "peak torque" in svg
    assert "physics check **failed**" in ed.md_validation.content
    # an edit makes the marks stale: they go
    ed._set(td, "t", 1.42)
    ed.validate_now()
    assert "data-physics" not in ed.html_timeline.content
