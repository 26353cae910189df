"""Terrain scenes: they compile, their geoms follow the naming rules, and ground_height matches MuJoCo's surfaces."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest

from planning.terrain.scenes import TERRAIN_NAMES, build_terrain

FREE_BOX = (
    '<body name="robot" pos="0 0 0.6"><freejoint/>'
    '<geom name="robot_body" type="box" size="0.45 0.13 0.08" mass="32"/></body>'
)


def compile_scene(name: str, seed: int = 0, **params):
    scene = build_terrain(name, seed=seed, **params)
    model = mujoco.MjModel.from_xml_string(scene.mjcf(FREE_BOX))
    for hname, data in scene.hfield_data.items():
        hid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_HFIELD, hname)
        adr = model.hfield_adr[hid]
        model.hfield_data[adr : adr + data.size] = data
    return scene, model, mujoco.MjData(model)


@pytest.mark.parametrize("name", TERRAIN_NAMES)
def test_scene_compiles_and_names_follow_rules(name: str) -> None:
    scene, model, data = compile_scene(name)
    mujoco.mj_forward(model, data)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(model.ngeom)]
    terrain = [n for n in names if n != "robot_body"]
    assert terrain and all(n.startswith("terrain_") for n in terrain)
    for g, n in enumerate(names):
        if n.startswith("terrain_"):
            assert model.geom_contype[g] == 1 and model.geom_conaffinity[g] == 1
            assert model.geom_friction[g][0] == pytest.approx(0.8)
    assert set(scene.obstacle_geom_names) == {n for n in terrain if n.startswith("terrain_obstacle_")}
    assert scene.goal_xy == (6.0, 0.0)
    assert scene.ground_height(0.0, 0.0) == pytest.approx(0.0)
    assert scene.ground_height(6.0, 0.0) == pytest.approx(0.0)
    # Every geom is named in the XML (no anonymous geoms).
    assert len(re.findall(r"<geom ", scene.worldbody_xml)) == len(
        re.findall(r'<geom name="terrain_', scene.worldbody_xml)
    )


@pytest.mark.parametrize("name", TERRAIN_NAMES)
def test_ground_height_matches_ray_casts(name: str) -> None:
    scene, model, data = compile_scene(name, seed=3)
    mujoco.mj_forward(model, data)
    robot = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "robot")
    rng = np.random.default_rng(1)
    geom = np.zeros(1, np.int32)
    checked = 0
    for _ in range(400):
        x, y = rng.uniform(-0.5, 6.0), rng.uniform(-1.6, 1.6)
        dist = mujoco.mj_ray(
            model, data, np.array([x, y, 5.0]), np.array([0.0, 0.0, -1.0]), None, 1, robot, geom
        )
        hit = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(geom[0]))
        if hit.startswith("terrain_obstacle_"):
            continue  # the surface under an obstacle is the floor, which the ray cannot see
        assert 5.0 - dist == pytest.approx(scene.ground_height(x, y), abs=1e-4), (x, y, hit)
        checked += 1
    assert checked > 300


def test_ground_height_under_the_table_is_the_floor() -> None:
    scene = build_terrain("under-table")
    assert scene.ground_height(3.0, 0.0) == 0.0
    grid = scene.ground_height(np.linspace(0, 6, 50), np.zeros(50))
    assert grid.shape == (50,) and np.all(grid == 0.0)


def test_stairs_and_slope_heights() -> None:
    stairs = build_terrain("stairs")
    assert stairs.ground_height(1.15, 0.0) == pytest.approx(0.15)
    assert stairs.ground_height(1.45, 0.0) == pytest.approx(0.30)
    assert stairs.ground_height(2.8, 0.0) == pytest.approx(0.60)
    assert stairs.ground_height(2.8, 1.0) == 0.0  # beside the stairs
    slope = build_terrain("slope", angle_deg=15.0)
    assert slope.ground_height(1.75, 0.0) == pytest.approx(0.75 * np.tan(np.radians(15.0)))


def test_stones_gaps_are_within_range() -> None:
    for seed in range(5):
        scene = build_terrain("stones", seed=seed)
        xs = np.arange(1.0, 5.0, 0.005)
        low = scene.ground_height(xs, np.full_like(xs, 0.25)) < -0.2
        # Runs of pit along the line y = 0.25 are the gaps between rows.
        edges = np.flatnonzero(np.diff(low.astype(int)))
        runs = [(xs[b] - xs[a]) for a, b in zip(edges[0::2], edges[1::2], strict=False)]
        assert runs and all(0.19 <= r <= 0.31 for r in runs), runs


def test_seed_changes_the_scene_and_same_seed_repeats_it() -> None:
    a = build_terrain("clutter", seed=1)
    b = build_terrain("clutter", seed=1)
    c = build_terrain("clutter", seed=2)
    assert a.worldbody_xml == b.worldbody_xml
    assert a.worldbody_xml != c.worldbody_xml


def test_bad_names_and_params_are_named_in_the_error() -> None:
    with pytest.raises(ValueError, match="valid names: flat, stairs"):
        build_terrain("lava")
    with pytest.raises(ValueError, match="riser_cm"):
        build_terrain("stairs", riser_cm=15)


@pytest.mark.parametrize("name", TERRAIN_NAMES)
def test_ground_height_of_one_point_equals_the_array_answer(name: str) -> None:
    # the one-point path (Python floats, the loop's fall check) gives the array path's value, inside and outside
    # every piece and on its edges
    scene = build_terrain(name)
    rng = np.random.default_rng(7)
    xs = np.append(rng.uniform(-2.0, 10.0, 300), 0.0)
    ys = np.append(rng.uniform(-3.0, 3.0, 300), 0.0)
    for box in scene.obstacle_boxes[:4]:
        xs = np.append(xs, box[:2])
        ys = np.append(ys, box[2:4])
    want = scene.ground_height(xs, ys)
    for x, y, w in zip(xs.tolist(), ys.tolist(), want.tolist(), strict=True):
        got = scene.ground_height(x, y)
        assert type(got) is float and got == w
