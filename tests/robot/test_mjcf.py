"""Loading a quadruped from its MJCF by structure: a synthetic robot written the way third-party models are (no
names footfall knows, an unnamed free joint, feet in their own bodies, knee offsets, joints about −y, gear, meshes
in a subfolder), position servos refused or converted, every problem in one message, falls named by body."""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np
import pytest

from planning.maneuver import load_maneuver
from planning.maneuver.load import find_maneuver
from planning.maneuver.scale import reference_dimensions, robot_scale, scale_to_robot
from planning.robot import RobotDescriptionError, load_robot
from planning.robot.check import check_robot
from planning.robot.model import ASSETS
from planning.sim.world import RobotState, World
from planning.terrain.scenes import build_terrain

# a cube, for a mesh geom resolved relative to the model file
CUBE_OBJ = "\n".join(
    [f"v {x} {y} {z}" for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)]
    + ["f 1 2 4 3", "f 5 7 8 6", "f 1 5 6 2", "f 3 4 8 7", "f 1 3 7 5", "f 2 6 8 4"]
)


def _leg(name: str, sx: int, sy: int, actuated: str) -> str:
    # the flexion axis sits 1 cm below the abduction axis, the shank starts 2 cm ahead of the thigh's end (a knee
    # offset), the foot is a sphere in its own body; flexion and knee turn about -y (their angles are negated)
    return f"""
      <body name="{name}_hip" pos="{0.2 * sx} {0.05 * sy} 0">
        <joint name="{name}_abad" axis="1 0 0" range="-0.8 0.8"/>
        <geom type="capsule" fromto="0 0 0 0 {0.06 * sy} 0" size="0.03" contype="0" conaffinity="0"/>
        <body name="{name}_thigh" pos="0 {0.08 * sy} -0.01">
          <joint name="{name}_pitch" axis="0 -1 0" range="-2.5 1.5"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02"/>
          <body name="{name}_shank" pos="0.02 0 -0.2">
            <joint name="{name}_knee" axis="0 -1 0" range="0.6 2.6"/>
            <geom type="capsule" fromto="0 0 0 0 0 -0.19" size="0.012"/>
            <body name="{name}_toe" pos="0 0 -0.2">
              <geom type="sphere" size="0.02"/>
            </body>
          </body>
        </body>
      </body>"""


def robot_xml(actuator: str = "motor", keyframe: bool = True) -> str:
    legs = "".join(
        _leg(n, sx, sy, actuator)
        for n, sx, sy in (("lf", 1, 1), ("rf", 1, -1), ("lh", -1, 1), ("rh", -1, -1))
    )
    acts = []
    for n in ("lf", "rf", "lh", "rh"):
        for j, t in (("abad", 10), ("pitch", 10), ("knee", 15)):
            if actuator == "motor":
                acts.append(f'<motor joint="{n}_{j}" gear="2" ctrlrange="-{t} {t}"/>')
            else:
                acts.append(f'<position joint="{n}_{j}" kp="50" forcerange="-{2 * t} {2 * t}"/>')
    # the pose: flexion 0.8 and knee 1.6 about -y
    key = (
        '<keyframe><key name="home" qpos="0 0 0.3 1 0 0 0 ' + " ".join(["0 -0.8 1.6"] * 4) + '"/></keyframe>'
        if keyframe
        else ""
    )
    return f"""<mujoco model="critter">
  <compiler angle="radian" meshdir="parts"/>
  <asset><mesh name="shell" file="shell.obj"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="base" pos="0 0 0.4">
      <freejoint/>
      <geom type="box" size="0.25 0.08 0.05" mass="6"/>
      <geom type="mesh" mesh="shell" contype="0" conaffinity="0"/>{legs}
    </body>
  </worldbody>
  <actuator>{"".join(acts)}</actuator>
  {key}
</mujoco>"""


def write_robot(tmp: Path, **kw: object) -> Path:
    (tmp / "parts").mkdir(exist_ok=True)
    (tmp / "parts" / "shell.obj").write_text(CUBE_OBJ)
    p = tmp / "critter.xml"
    p.write_text(robot_xml(**kw))  # type: ignore[arg-type]
    return p


@pytest.fixture
def critter(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    p = write_robot(tmp_path)
    monkeypatch.chdir(os.path.dirname(os.path.abspath(__file__)))  # meshes must not resolve against the cwd
    return p


def test_structure_is_detected_and_the_kinematics_match_mujoco(critter: Path) -> None:
    r = load_robot(critter)
    assert r.name == "critter" and r.free_joint_name == "root"
    m = r.model
    jname = lambda j: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)  # noqa: E731
    # legs labelled by where their hips are, not by their names
    assert [jname(r.legs[i].joint_ids[0]) for i in range(4)] == ["lf_abad", "rf_abad", "lh_abad", "rh_abad"]
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, m.geom_bodyid[r.legs[0].foot_geom]) == "lf_toe"
    assert r.foot_radius_m == pytest.approx(0.02)
    np.testing.assert_allclose(r.tau_max, [[20, 20, 30]] * 4)  # gear 2 × ctrlrange
    np.testing.assert_allclose(r.ctrl_scale, 0.5)
    foot_err, knee_err = r.kinematics_error(100)
    assert foot_err < 1e-9 and knee_err < 1e-9
    # the home keyframe is the standing pose: its feet, their mean height
    np.testing.assert_allclose(r.q_nominal, [[0.0, -0.8, 1.6]] * 4, atol=1e-6)
    feet = np.array([r.fk_leg(i, r.q_nominal[i]) for i in range(4)])
    assert r.standing_height_m == pytest.approx(-feet[:, 2].mean() + 0.02)


def test_jacobian_matches_finite_differences_with_offsets_and_negative_axes(critter: Path) -> None:
    r = load_robot(critter)
    rng = np.random.default_rng(1)
    for leg in range(4):
        for _ in range(20):
            q = r.q_min[leg] + rng.random(3) * (r.q_max[leg] - r.q_min[leg])
            J = r.jacobian_leg(leg, q)
            Jn = np.column_stack(
                [(r.fk_leg(leg, q + 1e-6 * e) - r.fk_leg(leg, q - 1e-6 * e)) / 2e-6 for e in np.eye(3)]
            )
            np.testing.assert_allclose(J, Jn, atol=1e-7)
            p = r.fk_leg(leg, q)
            q2, ok = r.ik_leg_many(leg, p[None, :])
            if ok[0]:
                np.testing.assert_allclose(r.fk_leg(leg, q2[0]), p, atol=1e-9)


def test_position_servos_are_refused_naming_each_or_converted_when_asked(tmp_path: Path) -> None:
    p = write_robot(tmp_path, actuator="position")
    with pytest.raises(RobotDescriptionError) as e:
        load_robot(p)
    msg = str(e.value)
    assert "12 problem(s)" in msg and "position servo (kp=50)" in msg and "'rh_knee'" in msg
    assert "\n" not in msg
    (tmp_path / "critter.footfall.yaml").write_text("actuators: convert\nname: servo-critter\n")
    r = load_robot(p)
    assert r.name == "servo-critter"
    np.testing.assert_allclose(r.tau_max, [[20, 20, 30]] * 4)  # the servos' forcerange
    a = r.legs[0].actuator_ids[0]
    assert r.model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE


def test_robot_check_reports_detection_and_problems(critter: Path, tmp_path: Path) -> None:
    ok, text = check_robot(critter)
    assert ok, text
    assert "analytic vs MuJoCo kinematics over 200 poses" in text and "standing (keyframe)" in text
    assert "world geom 'floor' dropped" in text
    bad = tmp_path / "three.xml"
    bad.write_text(robot_xml(keyframe=False).replace("<freejoint/>", ""))
    ok, text = check_robot(bad)
    assert not ok and "needs exactly one free joint" in text


def test_without_a_keyframe_the_stance_is_guessed_under_the_hips(tmp_path: Path) -> None:
    r = load_robot(write_robot(tmp_path, keyframe=False))
    assert r.standing_source == "guessed"
    np.testing.assert_allclose(r.nominal_foot_body[:, 0], r.p_body_hip[:, 0], atol=1e-9)
    assert 0.5 * (r.l_upper + r.l_lower) < r.standing_height_m < r.l_upper + r.l_lower


def test_a_fall_names_the_body_that_touched(critter: Path) -> None:
    r = load_robot(critter)
    w = World(r, build_terrain("flat"))
    w.reset(height=0.04)  # the base box (5 cm half-height) pressed into the ground, the shanks too
    s = w.read_state(RobotState())
    assert s.bad_contact in {"base", "lf_shank", "rf_shank", "lh_shank", "rh_shank"}
    assert s.knee_contact.any()


def test_maneuvers_scale_to_the_robot() -> None:
    spot, go1 = load_robot("spot"), load_robot("go1")
    stand = load_maneuver(find_maneuver("stand"))
    assert scale_to_robot(stand, spot) is stand
    s = robot_scale(go1)
    sx0, sy0, h0 = reference_dimensions()
    assert s.z == pytest.approx(go1.standing_height_m / h0)
    scaled = scale_to_robot(stand, go1)
    assert scaled.body[0].position[2] == pytest.approx(go1.standing_height_m)
    walk = load_maneuver(find_maneuver("walk-forward"))
    g0, g1 = walk.gaits[0], scale_to_robot(walk, go1).gaits[0]
    assert g1.step[0] == pytest.approx(g0.step[0] * go1.nominal_stance_xy[0] / sx0)
    assert g1.cycle == g0.cycle


def test_the_studio_draws_mesh_geoms(critter: Path) -> None:
    from server.engine import visuals_of
    from server.studio.robot_view import add_geom

    r = load_robot(critter)
    w = World(r, build_terrain("flat"))
    v = visuals_of(w.model, w.data, w.body_id)
    meshes = [g for g in v.robot_geoms if g.kind == "mesh"]
    assert len(meshes) == 1 and meshes[0].mesh is not None
    verts, faces = meshes[0].mesh
    assert verts.shape == (8, 3) and faces.shape == (12, 3)  # the cube, triangulated
    np.testing.assert_allclose(np.abs(verts), 0.05, atol=1e-6)

    class Scene:
        def add_mesh_simple(self, name: str, vertices: np.ndarray, faces: np.ndarray, **kw: object) -> str:
            return f"mesh {name} {len(vertices)} {len(faces)}"

    assert add_geom(Scene(), "shell", meshes[0]) == "mesh shell 8 12"


def test_the_validator_says_when_a_pose_asks_more_torque_than_the_motors_give() -> None:
    import copy

    from planning.maneuver import validate_maneuver

    go1 = load_robot("go1")
    crouch = load_maneuver(find_maneuver("crouch"))
    assert not [p for p in validate_maneuver(crouch, go1).warnings if "N·m" in p.message]
    weak = copy.copy(go1)
    weak.tau_max = go1.tau_max * 0.05  # a crouched knee holds ~3 N·m of a 12.6 kg body
    found = [p for p in validate_maneuver(crouch, weak).warnings if "N·m" in p.message]
    assert found and "limit" in found[0].message and found[0].path.startswith("body[")


def test_cli_robot_check_exit_codes(
    critter: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from server.cli import main

    assert main(["robot", "check", str(critter)]) == 0
    assert "ok: footfall can drive this robot" in capsys.readouterr().out
    servo = tmp_path / "servo"
    servo.mkdir()
    assert main(["robot", "check", str(write_robot(servo, actuator="position"))]) == 2
    out = capsys.readouterr().out
    assert "12 problem(s)" in out and "Traceback" not in out


def test_scaling_moves_every_length_and_keeps_times() -> None:
    from planning.maneuver.spec import Maneuver

    go1 = load_robot("go1")
    s = robot_scale(go1)
    m = Maneuver.model_validate(
        {
            "format": "footfall/maneuver@1",
            "name": "probe",
            "duration": 4.0,
            "events": [
                {"t": 1.0, "leg": "FL", "type": "liftoff"},
                {
                    "t": 2.0,
                    "leg": "FL",
                    "type": "touchdown",
                    "at": [0.4, 0.2, 0.0],
                    "adjust": {"time": 0.1, "region": [[0.3, 0.1], [0.5, 0.1], [0.5, 0.3]]},
                    "waypoints": [[1.5, 0.35, 0.2, 0.15]],
                },
                {"t": 2.5, "leg": "RR", "type": "liftoff"},
                {
                    "t": 3.0,
                    "leg": "RR",
                    "type": "touchdown",
                    "offset": [0.1, -0.05],
                    "adjust": {"radius": 0.04},
                },
            ],
            "gaits": [
                {
                    "gait": "trot",
                    "from": 3.2,
                    "to": 4.0,
                    "cycle": 0.4,
                    "duty": 0.6,
                    "step": [0.2, 0.1, 10],
                    "height": 0.1,
                }
            ],
            "body": [{"t": 1.0, "position": [0.1, -0.1, 0.5], "rpy": [5, 0, 0]}],
        }
    )
    out = scale_to_robot(m, go1)
    td, td2 = out.events[1], out.events[3]
    assert td.at == pytest.approx((0.4 * s.x, 0.2 * s.y, 0.0))
    assert td.adjust.region[1] == pytest.approx((0.5 * s.x, 0.1 * s.y))
    assert td.waypoints[0] == pytest.approx((1.5, 0.35 * s.x, 0.2 * s.y, 0.15 * s.z))  # the time stays
    assert td2.offset[:2] == pytest.approx((0.1 * s.x, -0.05 * s.y))
    assert td2.adjust.radius == pytest.approx(0.04 * min(s.x, s.y))
    g = out.gaits[0]
    assert g.step == pytest.approx((0.2 * s.x, 0.1 * s.y, 10.0)) and g.height == pytest.approx(0.1 * s.z)
    assert (g.from_, g.to, g.cycle) == (3.2, 4.0, 0.4)
    assert out.body[0].position == pytest.approx((0.1 * s.x, -0.1 * s.y, 0.5 * s.z))
    assert out.body[0].rpy == (5, 0, 0) and out.events[0].t == 1.0


def test_swing_gains_follow_heavier_leg_joints(tmp_path: Path) -> None:
    """The swing gains (tuned on the shipped spot) scale with a joint's inertia (leg + armature, from MuJoCo) where
    it exceeds the spot's, keeping the swing's bandwidth and damping ratio; lighter legs (go1) keep them."""
    from planning.handler import Handler, HandlerParams

    p = HandlerParams()
    for name in ("spot", "go1"):
        h = Handler(load_robot(name))
        assert np.array_equal(h.kp, np.tile(p.kp_swing, (4, 1))) and np.array_equal(
            h.kd, np.tile(p.kd_swing, (4, 1))
        )
    spot = load_robot("spot")
    xml = (ASSETS / "spot.xml").read_text().replace('armature="0.04"', 'armature="0.20"')
    (tmp_path / "heavy.xml").write_text(xml)
    desc = (ASSETS / "spot.yaml").read_text().replace("mjcf: spot.xml", "mjcf: heavy.xml")
    (tmp_path / "heavy.yaml").write_text(desc.replace("name: spot", "name: heavy"))
    heavy = load_robot(tmp_path / "heavy.yaml")
    ratio = heavy.leg_joint_inertia[:, 2] / spot.leg_joint_inertia[:, 2]
    assert np.all(ratio > 3.0)  # the knee: 0.16 kg·m² more armature on ~0.05
    h = Handler(heavy)
    assert np.allclose(h.kp[:, 2], p.kp_swing[2] * ratio) and np.allclose(h.kd[:, 2], p.kd_swing[2] * ratio)
    assert np.allclose(h.kp[:, :2], p.kp_swing[0])  # the hips' inertia is unchanged


def test_a_robot_path_may_start_with_the_home_directory(
    critter: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HOME", str(critter.parent))
    assert load_robot("~/critter.xml").mass_kg == load_robot(critter).mass_kg
