"""Terrain from the user: every form of --terrain parses, heightmaps and MJCF scenes load with a ground truth that
matches MuJoCo, bad input is named, and the robot walks a few seconds on a user heightmap and a user MJCF scene."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.terrain.spec import (
    TerrainSpec,
    TerrainSpecError,
    load_terrain,
    parse_terrain,
    spec_from_mapping,
)

SCENE_XML = """\
<mujoco model="user">
  <compiler angle="degree"/>
  <asset>
    <mesh name="wedge" vertex="0 0 0  0.6 0 0  0 0.8 0  0.6 0.8 0  0 0 0.15  0 0.8 0.15"/>
    <hfield name="bumps" nrow="3" ncol="4" size="0.5 0.4 0.1 0.05" elevation="0 1 0 1  1 0 1 0  0 1 1 0"/>
    <material name="red" rgba="0.8 0.2 0.2 1"/>
  </asset>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1"/>
    <body name="stack" pos="1.5 0 0" euler="0 0 30">
      <geom name="step" type="box" size="0.3 0.4 0.1" pos="0 0 0.1" material="red"/>
      <geom type="cylinder" size="0.2 0.05" pos="0.6 0 0.05"/>
    </body>
    <geom name="ramp" type="mesh" mesh="wedge" pos="2.5 -0.4 0"/>
    <geom name="rough" type="hfield" hfield="bumps" pos="3.8 0 0"/>
    <geom name="obstacle_table" type="box" size="0.3 0.3 0.02" pos="4.8 0 0.6"/>
    <geom name="ghost" type="sphere" size="0.2" pos="1 1 0.1" contype="0" conaffinity="0"/>
  </worldbody>
</mujoco>
"""


# ---- the string and structured forms ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("stairs", TerrainSpec(name="stairs")),
        (
            "stairs:riser_m=0.18,tread_m=0.28",
            TerrainSpec("stairs", None, (("riser_m", 0.18), ("tread_m", 0.28))),
        ),
        (
            "stones:gap_m=0.15..0.25,jitter_z_m=0",
            TerrainSpec("stones", None, (("gap_m", (0.15, 0.25)), ("jitter_z_m", 0.0))),
        ),
        ("stones:gap_m=0.2", TerrainSpec("stones", None, (("gap_m", (0.2, 0.2)),))),
        ("clutter:platform=false,n_low=3", TerrainSpec("clutter", None, (("platform", False), ("n_low", 3)))),
        ("stairs:goal_x_m=auto", TerrainSpec("stairs", None, (("goal_x_m", None),))),
        ("maps/hm.npy:cell_m=0.05", TerrainSpec(None, "maps/hm.npy", (("cell_m", 0.05),))),
        (
            "hm.png:cell_m=0.02,height_m=0.3",
            TerrainSpec(None, "hm.png", (("cell_m", 0.02), ("height_m", 0.3))),
        ),
        ("scenes/a:b/room.xml", TerrainSpec(None, "scenes/a:b/room.xml")),
        ("room.xml:goal_x_m=8", TerrainSpec(None, "room.xml", (("goal_x_m", 8.0),))),
    ],
)
def test_string_forms_parse_and_print_back(text: str, expected: TerrainSpec) -> None:
    spec = parse_terrain(text)
    assert spec == expected
    assert parse_terrain(spec.text()) == spec


def test_structured_form_is_the_string_form() -> None:
    s = spec_from_mapping({"name": "stones", "params": {"gap_m": [0.15, 0.25], "jitter_z_m": 0}})
    assert s == parse_terrain("stones:gap_m=0.15..0.25,jitter_z_m=0")
    assert spec_from_mapping({"file": "hm.npy", "params": {"cell_m": 0.05}}) == parse_terrain(
        "hm.npy:cell_m=0.05"
    )
    assert spec_from_mapping({"name": "flat"}).text() == "flat"


@pytest.mark.parametrize(
    ("terrain", "match"),
    [
        ("moon", r"unknown terrain 'moon'; valid: flat, stairs, .*mixed, a name with parameters"),
        (
            "stairs:riser=0.18",
            r"stairs: unknown parameter 'riser'; valid: x_start_m .*riser_m \(0\.02–0\.3 m",
        ),
        ("stairs:riser_m", r"stairs: 'riser_m' is not KEY=VALUE .* valid keys: x_start_m"),
        ("stairs:riser_m=tall", r"stairs: riser_m='tall': expected a number"),
        ("stairs:riser_m=0.5", r"stairs\.riser_m=0\.5: outside the allowed range 0\.02–0\.3 m"),
        ("stairs:n_steps=3.5", r"stairs: n_steps='3\.5': expected a whole number"),
        ("stairs:railings=maybe", r"stairs: railings='maybe': expected true or false"),
        ("stairs:riser_m=0.1,riser_m=0.2", r"'riser_m' is given twice"),
        ("stones:gap_m=0.3..0.1", r"stones\.gap_m=0\.3\.\.0\.1: min is above max"),
        ("stones:gap_m=1..2..3", r"expected MIN\.\.MAX"),
        ("scene.obj", r"terrain file 'scene\.obj': unknown kind '\.obj'"),
        ("missing/hm.npy:cell_m=0.05", r"missing/hm\.npy: no such file"),
        ("hm.npy:cell=0.05", r"heightmap: unknown parameter 'cell'; valid: cell_m"),
        ({"name": "stairs", "file": "x.xml"}, r"exactly one of name .* or file"),
        ({"name": "lava"}, r"terrain\.name 'lava': unknown terrain"),
        (
            {"name": "stairs", "params": {"riser_m": "0.18"}},
            r"stairs: riser_m='0\.18': expected a number, not text",
        ),
        ({"name": "stairs", "params": {"riser_m": True}}, r"riser_m=True: expected a number"),
        ({"name": "stairs", "color": "red"}, r"unknown field\(s\) color"),
        ("", r"terrain: empty"),
    ],
)
def test_bad_terrains_name_the_key_or_value(terrain, match: str) -> None:
    with pytest.raises(TerrainSpecError, match=match):
        load_terrain(terrain)


# ---- heightmaps -----------------------------------------------------------------------------------------------------
def _bumps() -> np.ndarray:
    rows, cols = np.mgrid[0:30, 0:50]
    return 0.05 + 0.04 * np.sin(cols * 0.3) * np.cos(rows * 0.4)


def _compile(scene) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(scene.mjcf())
    for name, data in scene.hfield_data.items():
        hid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_HFIELD, name)
        model.hfield_data[model.hfield_adr[hid] : model.hfield_adr[hid] + data.size] = data
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _ray_height(model, data, x: float, y: float) -> tuple[float, str]:
    gid = np.zeros(1, np.int32)
    d = mujoco.mj_ray(model, data, np.array([x, y, 5.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
    return 5.0 - d, mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(gid[0])) or ""


def test_npy_heightmap_is_placed_like_an_image_seen_from_above(tmp_path: Path) -> None:
    h = _bumps()
    h[0, :] = 0.2  # the first row is the +y edge
    np.save(tmp_path / "hm.npy", h)
    scene = load_terrain(f"{tmp_path}/hm.npy:cell_m=0.04,x_start_m=1.5")
    x0, y_top = 1.5, (h.shape[0] - 1) * 0.04 / 2
    # samples sit on the grid: column j at x0 + 0.04 j, row i at y_top - 0.04 i
    for i, j in [(0, 0), (0, 10), (5, 7), (29, 49), (17, 33)]:
        assert scene.ground_height(x0 + 0.04 * j, y_top - 0.04 * i) == pytest.approx(h[i, j], abs=1e-9)
    assert scene.ground_height(0.0, 0.0) == 0.0 and scene.ground_height(8.0, 0.0) == 0.0
    assert scene.span_x == pytest.approx((1.5, 1.5 + 49 * 0.04))
    model, data = _compile(scene)
    rng = np.random.default_rng(0)
    for x, y in rng.uniform([1.0, -0.8], [3.6, 0.8], size=(200, 2)):
        assert _ray_height(model, data, x, y)[0] == pytest.approx(scene.ground_height(x, y), abs=1e-4)


def test_heightmap_with_pits_has_a_floor_around_it_and_yaml_beside_it(tmp_path: Path) -> None:
    h = _bumps()
    h[:, 20:25] = -0.25
    np.save(tmp_path / "pit.npy", h)
    (tmp_path / "pit.yaml").write_text("cell_m: 0.05\nx_start_m: 2.0\n")
    scene = load_terrain(str(tmp_path / "pit.npy"))
    assert scene.ground_height(2.0 + 22 * 0.05, 0.0) == pytest.approx(-0.25)
    assert (
        scene.ground_height(1.0, 0.0) == 0.0 and scene.ground_height(2.5, 1.5) == 0.0
    )  # the floor around it
    # the string's keys win over the YAML's
    assert load_terrain(f"{tmp_path}/pit.npy:x_start_m=3").span_x[0] == 3.0
    model, data = _compile(scene)
    rng = np.random.default_rng(1)
    for x, y in rng.uniform([0.5, -1.5], [5.0, 1.5], size=(200, 2)):
        assert _ray_height(model, data, x, y)[0] == pytest.approx(scene.ground_height(x, y), abs=1e-4)


def test_png_heightmaps_8_and_16_bit(tmp_path: Path) -> None:
    from PIL import Image

    g = np.zeros((20, 30))
    g[:, 10:20] = 1.0
    g[0, 0] = 0.5
    Image.fromarray((g * 255).astype(np.uint8)).save(tmp_path / "a.png")
    Image.fromarray((g * 65535).astype(np.uint16)).save(tmp_path / "b.png")
    for name in ("a.png", "b.png"):
        s = load_terrain(f"{tmp_path}/{name}:cell_m=0.05,height_m=0.2")
        assert s.ground_height(1.0 + 15 * 0.05, 0.0) == pytest.approx(0.2, abs=1e-3)
        assert s.ground_height(1.0 + 5 * 0.05, 0.0) == pytest.approx(0.0, abs=1e-3)
        assert s.ground_height(1.0, 19 * 0.05 / 2) == pytest.approx(0.1, abs=2e-3)  # first row: the +y edge
    with pytest.raises(TerrainSpecError, match=r"a\.png: a PNG heightmap needs height_m"):
        load_terrain(f"{tmp_path}/a.png:cell_m=0.05")


@pytest.mark.parametrize(
    ("array", "spec", "match"),
    [
        (np.zeros(10), "cell_m=0.05", r"a 2-D grid of at least 2×2, got shape \(10,\)"),
        (np.full((4, 4), np.nan), "cell_m=0.05", r"heights must be finite"),
        (np.array([["a", "b"], ["c", "d"]]), "cell_m=0.05", r"heights must be numbers"),
        (np.zeros((600, 600)), "cell_m=0.05", r"600×600 samples, more than 250000"),
        (
            np.zeros((4, 4)),
            "",
            r"a heightmap needs cell_m, .*hm\.npy:cell_m=0\.05, or cell_m: 0\.05 in hm\.yaml",
        ),
        (np.zeros((4, 4)), "cell_m=0", r"heightmap\.cell_m=0: outside the allowed range 0\.005–1 m"),
    ],
)
def test_bad_heightmaps_are_named(tmp_path: Path, array, spec: str, match: str) -> None:
    np.save(tmp_path / "hm.npy", array)
    with pytest.raises(TerrainSpecError, match=match):
        load_terrain(f"{tmp_path}/hm.npy" + (f":{spec}" if spec else ""))


def test_a_file_that_is_not_a_heightmap(tmp_path: Path) -> None:
    (tmp_path / "hm.npy").write_text("not numpy")
    with pytest.raises(TerrainSpecError, match="not a NumPy array file"):
        load_terrain(f"{tmp_path}/hm.npy:cell_m=0.05")
    (tmp_path / "hm.png").write_bytes(b"\x89PNG nope")
    with pytest.raises(TerrainSpecError, match="not a readable PNG image"):
        load_terrain(f"{tmp_path}/hm.png:cell_m=0.05,height_m=1")


# ---- MJCF scenes ------------------------------------------------------------------------------------------------
def test_mjcf_scene_ground_truth_is_its_support_surface(tmp_path: Path) -> None:
    (tmp_path / "room.xml").write_text(SCENE_XML)
    scene = load_terrain(str(tmp_path / "room.xml"))
    names = [n for n in scene.worldbody_xml.split('name="')[1:]]
    assert all(n.startswith("terrain_") for n in names)
    assert scene.obstacle_geom_names == ("terrain_obstacle_table",)
    (box,) = scene.obstacle_boxes
    assert box == pytest.approx((4.5, 5.1, -0.3, 0.3, 0.58, 0.62))
    assert scene.span_x[1] == pytest.approx(5.1) and scene.goal_xy == pytest.approx((6.1, 0.0))
    assert scene.ground_height(4.8, 0.0) == 0.0  # the floor under the table, not its top
    assert scene.ground_height(1.5, 0.0) == pytest.approx(0.2)  # the rotated step's top
    # The composed scene (degrees turned into quaternions, meshes and height fields copied) is the user's file:
    # rays onto both agree with the ground truth wherever they meet a support geom.
    original = mujoco.MjModel.from_xml_path(str(tmp_path / "room.xml"))
    odata = mujoco.MjData(original)
    mujoco.mj_forward(original, odata)
    model, data = _compile(scene)
    rng = np.random.default_rng(2)
    checked = 0
    for x, y in rng.uniform([-0.5, -1.2], [5.5, 1.2], size=(600, 2)):
        z0, hit = _ray_height(original, odata, x, y)
        if hit in ("obstacle_table", "ghost"):
            continue
        z1, _ = _ray_height(model, data, x, y)
        h = scene.ground_height(x, y)
        assert z0 == pytest.approx(h, abs=1e-4) and z1 == pytest.approx(h, abs=1e-4), (x, y, hit)
        checked += 1
    assert checked > 500
    grid = scene.ground_height(np.linspace(1, 4, 7)[:, None], np.zeros((1, 3)))
    assert grid.shape == (7, 3)
    # a scene can go to a worker process
    import pickle

    again = pickle.loads(pickle.dumps(scene))
    assert again.ground_height(1.5, 0.0) == pytest.approx(0.2) and again.worldbody_xml == scene.worldbody_xml


def test_mjcf_includes_work_within_the_scene_directory(tmp_path: Path) -> None:
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "box.xml").write_text(
        '<mujoco><worldbody><geom name="block" type="box" size="0.2 0.2 0.1" pos="2 0 0.1"/></worldbody></mujoco>'
    )
    (tmp_path / "main.xml").write_text(
        '<mujoco><include file="parts/box.xml"/><worldbody><geom name="floor" type="plane" size="5 5 0.1"/>'
        "</worldbody></mujoco>"
    )
    scene = load_terrain(str(tmp_path / "main.xml"))
    assert scene.ground_height(2.0, 0.0) == pytest.approx(0.2)


def test_a_nested_include_may_not_climb_out(tmp_path: Path) -> None:
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "more.xml").write_text('<mujoco><include file="../../outside.xml"/></mujoco>')
    (tmp_path / "main.xml").write_text('<mujoco><include file="parts/more.xml"/></mujoco>')
    with pytest.raises(
        TerrainSpecError, match=r"more\.xml: <include file='\.\./\.\./outside\.xml'> names a file"
    ):
        load_terrain(str(tmp_path / "main.xml"))
    # climbing back into the scene's directory is refused too: MuJoCo may resolve it from another directory
    (tmp_path / "parts" / "more.xml").write_text('<mujoco><include file="../main2.xml"/></mujoco>')
    with pytest.raises(TerrainSpecError, match=r"without '\.\.'"):
        load_terrain(str(tmp_path / "main.xml"))


@pytest.mark.parametrize(
    ("xml", "match"),
    [
        (
            "<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>",
            r"has a joint",
        ),
        ("<mujoco><worldbody><geom type='plane' size='1 1 1'", r"not well-formed XML"),
        ("<mujoco><worldbody><geom type='box'/></worldbody></mujoco>", r"MuJoCo cannot load it"),
        ('<mujoco><include file="/etc/hostname"/></mujoco>', r"names a file outside the scene's directory"),
        (
            '<mujoco><asset><mesh name="m" file="../../m.stl"/></asset></mujoco>',
            r"<mesh file='\.\./\.\./m\.stl'> names a file outside",
        ),
        (
            "<mujoco><worldbody><geom type='box' size='1 1 0.1' pos='3 0 0'/></worldbody></mujoco>",
            r"no support geom under the robot's start",
        ),
        (
            "<mujoco><worldbody><geom name='obstacle_wall' type='plane' size='1 1 1'/></worldbody></mujoco>",
            r"no support geom \(every geom is an obstacle",
        ),
    ],
)
def test_bad_mjcf_scenes_are_named(tmp_path: Path, xml: str, match: str) -> None:
    (tmp_path / "s.xml").write_text(xml)
    with pytest.raises(TerrainSpecError, match=match):
        load_terrain(str(tmp_path / "s.xml"))


# ---- a few seconds of closed loop on each kind of file ---------------------------------------------------------
@pytest.mark.parametrize("kind", ["heightmap", "mjcf"])
def test_the_robot_walks_onto_a_user_terrain(tmp_path: Path, kind: str) -> None:
    from planning.sim.run import RunOptions, WalkCommand, WalkSession

    if kind == "heightmap":
        np.save(tmp_path / "hm.npy", _bumps())
        terrain = f"{tmp_path}/hm.npy:cell_m=0.04,x_start_m=0.8"
    else:
        (tmp_path / "room.xml").write_text(SCENE_XML)
        terrain = str(tmp_path / "room.xml")
    session = WalkSession(
        WalkCommand(goal=(6.0, 0.0), terrain_sensor=False), RunOptions(terrain=terrain, duration_s=3.0)
    )
    assert session.pipeline is not None  # a user terrain is walked terrain-aware
    report = session.run()
    assert report["terrain"] == terrain and report["seed"] == 0
    assert not report["fell"], report["failure_reason"]
    assert report["body_collisions"] == 0
    # onto the terrain: the front feet are past where it starts (the bumps at 0.8 m, the rotated step at ~1.0 m)
    s = session.loop.state
    assert s.p_world_body[0] > 0.5 and float(np.max(s.p_world_foot[:2, 0])) > 1.0, s.p_world_foot
