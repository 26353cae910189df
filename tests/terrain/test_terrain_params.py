"""Terrain family parameters: the measured ranges build and compile, bad values are named with their range."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from planning.terrain.crossing import terrain_span_x
from planning.terrain.scenes import (
    TERRAIN_NAMES,
    StairsParams,
    TerrainParamError,
    build_terrain,
    param_info,
    terrain_params,
)

# The corners of the ranges the sweeps measure (issue 26), one scene each.
CORNERS = [
    ("stairs", {"riser_m": 0.10, "tread_m": 0.25, "n_steps": 3, "railings": False}),
    ("stairs", {"riser_m": 0.20, "tread_m": 0.40, "n_steps": 8, "railings": True}),
    ("stairs", {"riser_m": 0.18, "tread_m": 0.28}),
    ("stones", {"gap_m": (0.15, 0.15), "stone_depth_m": (0.25, 0.30), "jitter_z_m": 0.05}),
    ("stones", {"gap_m": (0.30, 0.30), "stone_width_m": (0.30, 0.35)}),
    ("clutter", {"n_low": 12, "n_tall": 1}),
    ("clutter", {"n_low": 0, "n_tall": 0, "platform": False}),
    ("slope", {"angle_deg": 5.0}),
    ("slope", {"angle_deg": 25.0}),
    ("rough", {"amplitude_m": 0.12}),
    ("under-table", {"clearance_m": 0.55}),
    ("under-table", {"clearance_m": 0.65}),
    ("mixed", {"n_steps": 3, "riser_m": 0.18, "gap_m": (0.25, 0.30)}),
]


def _compile(scene):
    model = mujoco.MjModel.from_xml_string(scene.mjcf())
    for name, data in scene.hfield_data.items():
        hid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_HFIELD, name)
        model.hfield_data[model.hfield_adr[hid] : model.hfield_adr[hid] + data.size] = data
    return model, mujoco.MjData(model)


@pytest.mark.parametrize(("name", "params"), CORNERS, ids=[f"{n}-{i}" for i, (n, _) in enumerate(CORNERS)])
def test_measured_ranges_build_and_match_mujoco(name: str, params: dict) -> None:
    scene = build_terrain(name, seed=2, **params)
    model, data = _compile(scene)
    mujoco.mj_forward(model, data)
    x0, x1 = terrain_span_x(scene)
    assert x0 >= 0.6 and x1 > x0
    assert scene.goal_xy[0] >= x1 + 1.0 - 1e-9 or scene.goal_xy[0] == 6.0
    assert scene.goal_xy[0] > x1  # the auto goal lies past the terrain
    # The support height agrees with a downward ray wherever the ray meets a support surface.
    rng = np.random.default_rng(0)
    geom = np.zeros(1, np.int32)
    checked = 0
    for _ in range(150):
        x, y = rng.uniform(x0 - 0.3, x1 + 0.3), rng.uniform(-1.0, 1.0)
        dist = mujoco.mj_ray(
            model, data, np.array([x, y, 5.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geom
        )
        if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(geom[0])).startswith("terrain_obstacle_"):
            continue
        assert 5.0 - dist == pytest.approx(scene.ground_height(x, y), abs=1e-4), (x, y)
        checked += 1
    assert checked > 80


def test_stairs_dimensions_and_railings_follow_the_parameters() -> None:
    s = build_terrain("stairs", riser_m=0.18, tread_m=0.28, n_steps=5, railings=False)
    assert s.ground_height(1.0 + 0.14, 0.0) == pytest.approx(0.18)
    assert s.ground_height(1.0 + 4 * 0.28 + 0.14, 0.0) == pytest.approx(0.90)
    assert s.obstacle_boxes == ()
    railed = build_terrain("stairs", riser_m=0.18, tread_m=0.28, n_steps=5)
    assert railed.obstacle_boxes and all(abs(b[2]) > 0.6 for b in railed.obstacle_boxes)
    assert terrain_span_x(s) == pytest.approx((1.0, 1.0 + 10 * 0.28 + 1.2))
    long = build_terrain("stairs", n_steps=8, tread_m=0.40)
    assert long.goal_xy[0] == pytest.approx(1.0 + 16 * 0.40 + 1.2 + 1.0)  # past the end, not on the stairs
    assert build_terrain("stairs", goal_x_m=12.0).goal_xy == (12.0, 0.0)


def test_mixed_is_stairs_then_stones() -> None:
    s = build_terrain(
        "mixed", n_steps=2, riser_m=0.15, tread_m=0.30, landing_m=0.6, floor_m=0.4, stones_m=1.6
    )
    assert s.ground_height(1.15, 0.0) == pytest.approx(0.15)
    assert s.ground_height(2.0, 0.0) == pytest.approx(0.30)  # landing
    assert s.ground_height(3.0, 0.0) == pytest.approx(0.0)  # floor before the pit
    xs = np.linspace(3.2, 4.8, 400)
    assert np.min(s.ground_height(xs, np.full_like(xs, 0.25))) == pytest.approx(-0.3)  # gaps into the pit
    assert terrain_span_x(s) == pytest.approx((1.0, 4.8))


def test_clutter_options_keep_the_seed_s_other_boxes() -> None:
    base = build_terrain("clutter", seed=4)
    fewer = build_terrain("clutter", seed=4, n_tall=1, platform=False)
    lines, fewer_lines = base.worldbody_xml.splitlines(), fewer.worldbody_xml.splitlines()
    assert any("box_tall_1" in line for line in lines) and any("box_platform" in line for line in lines)
    assert not any("box_tall_1" in line or "box_platform" in line for line in fewer_lines)
    # the tall box kept is where it was (low boxes may now fit where the platform stood)
    assert [x for x in fewer_lines if "box_tall_0" in x] == [x for x in lines if "box_tall_0" in x]
    many = build_terrain("clutter", seed=4, n_low=12)
    assert many.worldbody_xml.count("box_low_") > base.worldbody_xml.count("box_low_")


@pytest.mark.parametrize(
    ("name", "params", "match"),
    [
        ("stairs", {"riser_m": 0.5}, r"stairs\.riser_m=0\.5: outside the allowed range 0\.02–0\.3 m"),
        ("stairs", {"n_steps": 2.5}, r"stairs\.n_steps=2\.5: must be an integer"),
        ("stairs", {"n_steps": 40}, r"stairs\.n_steps=40: outside the allowed range 1–12 steps"),
        ("stairs", {"railings": "yes"}, r"stairs\.railings='yes': must be true or false"),
        ("stairs", {"tread_m": float("nan")}, r"stairs\.tread_m=nan: must be finite"),
        ("stairs", {"mid_rail_m": 1.0}, r"stairs\.mid_rail_m=1: must be below rail_height_m=0\.9"),
        ("stones", {"gap_m": (0.3, 0.2)}, r"stones\.gap_m=0\.3\.\.0\.2: min is above max"),
        ("stones", {"gap_m": (0.1, 0.9)}, r"stones\.gap_m=0\.1\.\.0\.9: outside the allowed range 0–0\.6 m"),
        ("stones", {"gap_m": 0.2}, r"stones\.gap_m=0\.2: must be a \(min, max\) pair"),
        ("stones", {"x_end_m": 1.2}, r"stones\.x_end_m=1\.2: must be at least 0\.5 m past x_start_m=1"),
        ("slope", {"angle_deg": 45}, r"slope\.angle_deg=45: outside the allowed range 1–35 deg"),
        ("rough", {"cell_m": 0.01, "x_range_m": (1, 15)}, r"rough\.cell_m=0\.01: .* more than 250000"),
        ("under-table", {"clearance_m": "high"}, r"under-table\.clearance_m='high': must be a number"),
        ("mixed", {"pit_half_width_m": 0.5}, r"mixed\.pit_half_width_m=0\.5: must hold the stones"),
        ("stairs", {"riser_cm": 15}, r"unknown parameter\(s\) riser_cm; valid: x_start_m, n_steps, riser_m"),
    ],
)
def test_bad_parameters_are_named_with_their_allowed_range(name: str, params: dict, match: str) -> None:
    with pytest.raises(TerrainParamError, match=match):
        build_terrain(name, **params)


def test_every_family_lists_its_parameters_with_ranges() -> None:
    for name in TERRAIN_NAMES:
        infos = param_info(name)
        assert infos[-1].name == "goal_x_m"
        defaults = terrain_params(name)
        for info in infos:
            assert getattr(defaults, info.name) == info.default
            assert info.kind in ("float", "int", "bool", "range", "float | None")
            assert (info.range is None) == (info.kind == "bool")
    assert [i.describe() for i in param_info("stairs")][2] == "riser_m (0.02–0.3 m, default 0.15)"
    with pytest.raises(TerrainParamError, match="valid names: flat, stairs"):
        param_info("lava")
    # Params are frozen: a sweep varies them with dataclasses.replace, which validates again.
    import dataclasses

    with pytest.raises(TerrainParamError, match="riser_m"):
        dataclasses.replace(StairsParams(), riser_m=0.01)
