"""Reads a quadruped from a standard MJCF by its structure: the free joint by type, four legs of three hinges from the
kinematic tree, the feet at the leg ends, torque motors with their gear, the standing pose from the ``home``
keyframe, meshes relative to the file. An optional description (``NAME.footfall.yaml`` beside the file, or the
shipped ``*.yaml``) overrides what the structure cannot say.

Every problem found is collected, so one error names them all (``RobotDescriptionError``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

LEGS: tuple[str, str, str, str] = ("FL", "FR", "RL", "RR")
JOINT_ROLES = ("hip abduction", "hip flexion", "knee")
AXIS_TOLERANCE = 1e-3  # a leg joint's axis may differ from body x / y by this much (1 - |cos|)
# a lower-leg contact within this many foot radii of the foot center counts as the foot's
NEAR_FOOT_FACTOR = 1.5
DESCRIPTION_KEYS = {
    "name",
    "title",
    "mjcf",
    "body",
    "legs",
    "feet",
    "ground_geoms",
    "standing_height",
    "nominal_stance",
    "keyframe",
    "actuators",
    "joint_velocity_limit",
    "self_collision",
    "joint_loss_compensation",
    "near_foot_contact",
}
FRICTION_RAMP_RAD_S = 0.05  # friction loss is compensated in proportion to the joint speed up to this speed


class RobotDescriptionError(ValueError):
    """A robot description that does not match its MJCF, or an MJCF footfall cannot drive; names every problem."""


def _round(v: Any) -> np.ndarray:
    """Geometry read from MuJoCo's kinematics, rounded to 1 nm (a sum of body offsets carries 1e-17 m of noise)."""
    return np.round(np.asarray(v, dtype=float), 9) + 0.0


@dataclass
class LegGeometry:
    """One leg as detected: MuJoCo ids and the analytic kinematic parameters (body frame, zero joint angles)."""

    label: str
    joint_ids: tuple[int, int, int]
    actuator_ids: tuple[int, int, int]
    foot_geom: int
    foot_site_name: str  # an existing site at the foot center, or the one the loader adds
    knee_body: int  # the body the knee joint moves
    lower_geoms: tuple[int, ...]  # collision geoms below the knee other than the foot
    p_hip: np.ndarray  # (3,) a point on the abduction axis, at the flexion axis' x
    y_foot: float  # lateral offset of the foot center from the abduction axis
    y_knee: float  # lateral offset of the knee anchor from the abduction axis
    z_flex: float  # the flexion axis' offset below (−) / above (+) the abduction axis
    l_upper: float
    l_lower: float
    alpha: float  # the thigh's angle from straight down at zero flexion (rad, about +y)
    beta: float  # the shank's angle from straight down at zero flexion and knee (rad, about +y)
    signs: tuple[float, float, float]  # +1 where the joint turns about +x / +y, −1 about −x / −y
    foot_radius: float


@dataclass
class Detected:
    """What the loader found, and every problem in the way."""

    model: mujoco.MjModel
    xml: str
    base_body: int
    free_joint_name: str
    legs: list[LegGeometry] = field(default_factory=list)
    ctrl_scale: np.ndarray = field(default_factory=lambda: np.ones((4, 3)))  # ctrl = tau * scale
    tau_max: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))
    q_range: np.ndarray = field(default_factory=lambda: np.zeros((4, 3, 2)))
    home_q: np.ndarray | None = None  # (4,3) leg angles of the home keyframe
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what was detected, for `footfall robot check`


def _name(m: mujoco.MjModel, kind: mujoco.mjtObj, i: int) -> str:
    return mujoco.mj_id2name(m, kind, i) or ""


def _name_everything(spec: mujoco.MjSpec) -> int:
    """Names unnamed bodies, joints, geoms and actuators (so that errors and falls read as names, and the world can
    re-resolve them after the scene is added); returns how many it named."""
    used = {
        e.name for kind in (spec.bodies, spec.joints, spec.geoms, spec.sites, spec.actuators) for e in kind
    }

    named = 0

    def fresh(base: str) -> str:
        nonlocal named
        named += 1
        n, k = base, 1
        while n in used:
            k += 1
            n = f"{base}{k}"
        used.add(n)
        return n

    for b in spec.bodies:
        if b.name == "" and b is not spec.worldbody:
            b.name = fresh("body")
    for b in spec.bodies:
        if b is spec.worldbody:
            continue
        for j in b.joints:
            if j.name == "":
                j.name = fresh("root" if j.type == mujoco.mjtJoint.mjJNT_FREE else f"{b.name}_joint")
        for k, g in enumerate(b.geoms):
            if g.name == "":
                g.name = fresh(f"{b.name}_geom{k}")
    for a in spec.actuators:
        if a.name == "":
            a.name = fresh(f"{a.target or 'actuator'}_actuator")
    return named


def _absolute_dirs(spec: mujoco.MjSpec, path: Path) -> None:
    """Meshes and textures resolve against the model's folder, not the current directory."""
    base = Path(spec.modelfiledir) if spec.modelfiledir else path.parent
    spec.meshdir = str((base / spec.meshdir).resolve()) if spec.meshdir else str(base.resolve())
    spec.texturedir = str((base / spec.texturedir).resolve()) if spec.texturedir else str(base.resolve())


def load_spec(path: Path) -> mujoco.MjSpec:
    """Parses an MJCF file (includes and assets relative to it); raises RobotDescriptionError with MuJoCo's reason."""
    if not path.exists():
        raise RobotDescriptionError(f"{path}: no such file")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        spec.compile()
    except Exception as e:  # MuJoCo raises ValueError with its own message
        msg = " ".join(str(e).split())
        raise RobotDescriptionError(f"{path.name}: MuJoCo cannot load it: {msg}") from None
    return spec


def _subtree(m: mujoco.MjModel, root: int) -> list[int]:
    out = [root]
    for b in range(root + 1, m.nbody):
        p = int(m.body_parentid[b])
        if p in out:
            out.append(b)
    return out


def _is_ancestor(m: mujoco.MjModel, a: int, b: int) -> bool:
    """True if body a is b or one of b's ancestors."""
    while True:
        if a == b:
            return True
        if b == 0:
            return False
        b = int(m.body_parentid[b])


def detect(spec: mujoco.MjSpec, path: Path, desc: dict[str, Any]) -> Detected:
    """Finds the base, legs, feet and actuators of a quadruped MJCF; edits the spec (foot sites, converted servos,
    absolute asset folders, no keyframes, no world geoms) and returns the compiled result with every problem."""
    problems: list[str] = []
    notes: list[str] = []
    edited = _name_everything(spec) > 0
    # a scene file (floor, sky) may be given: the world's terrain replaces its ground
    for g in list(spec.worldbody.geoms):
        notes.append(f"world geom {g.name!r} dropped (the terrain is footfall's)")
        spec.delete(g)
        edited = True
    m = spec.compile()
    d = mujoco.MjData(m)

    # ---- the base: the one free joint ----------------------------------------------------------------------------
    frees = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    if len(frees) != 1:
        raise RobotDescriptionError(
            f"{path.name}: needs exactly one free joint (the floating base), found {len(frees)}"
        )
    base = int(m.jnt_bodyid[frees[0]])
    if "body" in desc and _name(m, mujoco.mjtObj.mjOBJ_BODY, base) != str(desc["body"]):
        problems.append(
            f"body: {desc['body']!r} is not the body with the free joint "
            f"({_name(m, mujoco.mjtObj.mjOBJ_BODY, base)!r})"
        )
    free_name = _name(m, mujoco.mjtObj.mjOBJ_JOINT, frees[0])
    notes.append(f"base: body {_name(m, mujoco.mjtObj.mjOBJ_BODY, base)!r} (free joint {free_name!r})")

    # zero pose: base at the origin, every joint at 0
    d.qpos[:] = 0.0
    qa = int(m.jnt_qposadr[frees[0]])
    d.qpos[qa + 3] = 1.0
    mujoco.mj_kinematics(m, d)
    p0 = d.xpos[base].copy()

    # ---- legs: three hinges in a chain under each child of the base, or the joints the description names ---------
    chains: list[list[int]] = []
    legs_desc = desc.get("legs")
    if legs_desc is not None:
        if not isinstance(legs_desc, dict) or set(legs_desc) != set(LEGS):
            raise RobotDescriptionError(f"legs: must name exactly {', '.join(LEGS)}")
        for leg in LEGS:
            joints = (legs_desc[leg] or {}).get("joints", []) if isinstance(legs_desc[leg], dict) else []
            if len(joints) != 3:
                problems.append(f"legs.{leg}.joints: needs 3 joints (hip abduction, hip flexion, knee)")
                continue
            ids = []
            for jn in joints:
                j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, str(jn))
                if j < 0:
                    problems.append(f"legs.{leg}.joints: joint {str(jn)!r} is not in {path.name}")
                else:
                    ids.append(int(j))
            if len(ids) == 3:
                chains.append(ids)
    else:
        groups: dict[int, list[int]] = {}
        for j in range(m.njnt):
            if j == frees[0]:
                continue
            b = int(m.jnt_bodyid[j])
            if not _is_ancestor(m, base, b):
                problems.append(f"joint {_name(m, mujoco.mjtObj.mjOBJ_JOINT, j)!r} is not on the robot")
                continue
            top = b
            while int(m.body_parentid[top]) != base:
                top = int(m.body_parentid[top])
            groups.setdefault(top, []).append(j)
        for top, js in groups.items():
            depth = {j: 0 for j in js}
            for j in js:
                b = int(m.jnt_bodyid[j])
                while b != base:
                    depth[j] += 1
                    b = int(m.body_parentid[b])
            js.sort(key=lambda j: (depth[j], j))
            names = [_name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in js]
            bad_type = [
                n for j, n in zip(js, names, strict=True) if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE
            ]
            chain = all(
                _is_ancestor(m, int(m.jnt_bodyid[a]), int(m.jnt_bodyid[b]))
                for a, b in zip(js, js[1:], strict=False)
            )
            where = f"the limb under body {_name(m, mujoco.mjtObj.mjOBJ_BODY, top)!r}"
            if bad_type:
                problems.append(f"{where}: joints {bad_type} are not hinges (a leg is three hinge joints)")
            elif len(js) != 3 or not chain:
                problems.append(
                    f"{where}: {len(js)} joints {names}"
                    + ("" if chain else " not in one chain")
                    + "; a leg is three hinges in a chain (hip abduction, hip flexion, knee)"
                )
            else:
                chains.append(js)
        if len(chains) != 4 and not problems:
            problems.append(f"found {len(chains)} legs of three hinges under the base, a quadruped has 4")
    if problems and len(chains) != 4:
        raise RobotDescriptionError(f"{path.name}: " + "; ".join(problems))

    # label legs by where their first joint sits: x > 0 front, y > 0 left
    labelled: dict[str, list[int]] = {}
    if legs_desc is not None:
        labelled = dict(zip(LEGS, chains, strict=True))
    else:
        for js in chains:
            a = d.xanchor[js[0]] - p0
            lab = ("F" if a[0] > 0 else "R") + ("L" if a[1] > 0 else "R")
            if lab in labelled:
                problems.append(
                    f"two legs sit at the {lab} corner (hips at x={a[0]:+.3f}, y={a[1]:+.3f} m); "
                    f"name them in the description's legs:"
                )
            labelled[lab] = js
        if problems:
            raise RobotDescriptionError(f"{path.name}: " + "; ".join(problems))

    # ---- per leg: axes, geometry, foot, actuators -------------------------------------------------------------------
    feet_desc = dict(desc.get("feet") or {})
    if isinstance(legs_desc, dict):
        for leg in LEGS:
            if isinstance(legs_desc.get(leg), dict) and "foot" in legs_desc[leg]:
                feet_desc.setdefault(leg, legs_desc[leg]["foot"])
    legs: list[LegGeometry] = []
    ctrl_scale = np.ones((4, 3))
    tau_max = np.zeros((4, 3))
    q_range = np.zeros((4, 3, 2))
    convert = str(desc.get("actuators", "")).strip() == "convert"
    expected_axes = (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 1.0, 0]))
    site_adds: list[tuple[str, str, np.ndarray]] = []  # (body name, site name, pos in body)
    for li, leg in enumerate(LEGS):
        js = labelled[leg]
        jn = [_name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in js]
        signs = []
        for r, (j, ax) in enumerate(zip(js, expected_axes, strict=True)):
            a = d.xaxis[j]
            c = float(a @ ax)
            if 1.0 - abs(c) > AXIS_TOLERANCE:
                problems.append(
                    f"leg {leg}: {JOINT_ROLES[r]} joint {jn[r]!r} turns about {np.round(a, 3).tolist()} in the base "
                    f"frame; footfall's legs turn about {'x' if r == 0 else 'y'} (abduction about x, flexion and "
                    f"knee about y)"
                )
            signs.append(1.0 if c >= 0 else -1.0)
        A0, A1, A2 = (d.xanchor[j] - p0 for j in js)
        knee_body = int(m.jnt_bodyid[js[2]])
        sub = _subtree(m, knee_body)
        coll = [
            g
            for g in range(m.ngeom)
            if int(m.geom_bodyid[g]) in sub and (m.geom_contype[g] or m.geom_conaffinity[g])
        ]
        foot = -1
        if leg in feet_desc:
            foot = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, str(feet_desc[leg]))
            if foot < 0:
                problems.append(f"feet.{leg}: geom {str(feet_desc[leg])!r} is not in {path.name}")
        else:
            spheres = [g for g in coll if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE]
            if spheres:
                foot = max(spheres, key=lambda g: float(np.linalg.norm(d.geom_xpos[g] - p0 - A2)))
            else:
                problems.append(
                    f"leg {leg}: no sphere geom that collides below the knee {jn[2]!r} to stand on "
                    f"(name the foot geom in the description's feet: {leg}: GEOM)"
                )
        if foot >= 0 and m.geom_type[foot] != mujoco.mjtGeom.mjGEOM_SPHERE:
            problems.append(
                f"leg {leg}: foot geom {_name(m, mujoco.mjtObj.mjOBJ_GEOM, foot)!r} is not a sphere"
            )
        F = d.geom_xpos[foot] - p0 if foot >= 0 else A2 + [0, 0, -0.2]
        radius = float(m.geom_size[foot][0]) if foot >= 0 else 0.02
        # the foot site: one already at the foot center in its body, or a new one
        site_name = f"{leg}_foot_site"
        if foot >= 0:
            fb = int(m.geom_bodyid[foot])
            existing = [
                s
                for s in range(m.nsite)
                if int(m.site_bodyid[s]) == fb and np.allclose(m.site_pos[s], m.geom_pos[foot], atol=1e-9)
            ]
            if existing:
                site_name = _name(m, mujoco.mjtObj.mjOBJ_SITE, existing[0])
            else:
                while mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site_name) >= 0:
                    site_name = "footfall_" + site_name
                site_adds.append(
                    (
                        _name(m, mujoco.mjtObj.mjOBJ_BODY, fb),
                        site_name,
                        np.array(m.geom_pos[foot], dtype=float),
                    )
                )
        p_hip = _round([A1[0], A0[1], A0[2]])
        thigh = _round(A2 - A1)
        shank = _round(F - A2)
        lu = float(np.hypot(thigh[0], thigh[2]))
        ll = float(np.hypot(shank[0], shank[2]))
        legs.append(
            LegGeometry(
                label=leg,
                joint_ids=(js[0], js[1], js[2]),
                actuator_ids=(-1, -1, -1),
                foot_geom=foot,
                foot_site_name=site_name,
                knee_body=knee_body,
                lower_geoms=tuple(g for g in coll if g != foot),
                p_hip=p_hip,
                y_foot=float(_round(F[1] - A0[1])),
                y_knee=float(_round(A2[1] - A0[1])),
                z_flex=float(_round(A1[2] - A0[2])),
                l_upper=lu,
                l_lower=ll,
                alpha=float(np.arctan2(-thigh[0], -thigh[2])),
                beta=float(np.arctan2(-shank[0], -shank[2])),
                signs=(signs[0], signs[1], signs[2]),
                foot_radius=radius,
            )
        )
        # joint ranges
        for r, j in enumerate(js):
            if m.jnt_limited[j]:
                q_range[li, r] = m.jnt_range[j]
            else:
                q_range[li, r] = (-np.pi, np.pi)
                notes.append(f"leg {leg}: {jn[r]!r} has no range; footfall assumes ±π")
        # actuators: torque motors, gear honoured
        acts = []
        for r, j in enumerate(js):
            cands = [
                a
                for a in range(m.nu)
                if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and int(m.actuator_trnid[a, 0]) == j
            ]
            if not cands:
                problems.append(f"leg {leg}: joint {jn[r]!r} has no actuator")
                acts.append(-1)
                continue
            a = cands[0]
            an = _name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
            acts.append(a)
            servo = m.actuator_biastype[a] != mujoco.mjtBias.mjBIAS_NONE
            if servo or m.actuator_gaintype[a] != mujoco.mjtGain.mjGAIN_FIXED or m.actuator_dyntype[a] != 0:
                kind = (
                    f"a position servo (kp={m.actuator_gainprm[a][0]:.4g})"
                    if servo and m.actuator_biasprm[a][1] != 0
                    else "not a torque motor"
                )
                if not convert:
                    problems.append(
                        f"leg {leg}: actuator {an!r} on {jn[r]!r} is {kind}; footfall commands joint torques "
                        f"(use <motor>, or set 'actuators: convert' in the description to drive it as a torque motor "
                        f"limited by its forcerange)"
                    )
                    continue
                if not m.actuator_forcelimited[a]:
                    problems.append(
                        f"leg {leg}: actuator {an!r} is {kind} without a forcerange: cannot convert it to a torque "
                        f"motor (no torque limit)"
                    )
                    continue
                notes.append(f"leg {leg}: actuator {an!r} ({kind}) converted to a torque motor")
                continue
            gear = float(m.actuator_gear[a, 0]) * float(m.actuator_gainprm[a][0])
            if gear == 0.0:
                problems.append(f"leg {leg}: actuator {an!r} has zero gain or gear")
                continue
            ctrl_scale[li, r] = 1.0 / gear
            limits = []
            if m.actuator_ctrllimited[a]:
                lo, hi = m.actuator_ctrlrange[a]
                limits.append(abs(gear) * min(abs(lo), abs(hi)))
            if m.actuator_forcelimited[a]:
                lo, hi = m.actuator_forcerange[a]
                limits.append(abs(float(m.actuator_gear[a, 0])) * min(abs(lo), abs(hi)))
            if m.jnt_actfrclimited[j]:
                lo, hi = m.jnt_actfrcrange[j]
                limits.append(min(abs(lo), abs(hi)))
            if not limits:
                problems.append(
                    f"leg {leg}: actuator {an!r} has no torque limit (set its ctrlrange or forcerange)"
                )
                continue
            tau_max[li, r] = min(limits)
        legs[-1].actuator_ids = (acts[0], acts[1], acts[2])

    # ---- edits: converted servos, foot sites, absolute asset folders, no keyframes ----------------------------------
    if convert:
        for li, lg in enumerate(legs):
            for r, a in enumerate(lg.actuator_ids):
                if (
                    a < 0
                    or m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE
                    or not m.actuator_forcelimited[a]
                ):
                    continue
                an = _name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
                sa = spec.actuator(an)
                lo, hi = m.actuator_forcerange[a]
                sa.set_to_motor()
                sa.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                sa.ctrlrange = [float(lo), float(hi)]
                g = float(m.actuator_gear[a, 0])
                ctrl_scale[li, r] = 1.0 / g
                tau_max[li, r] = abs(g) * min(abs(lo), abs(hi))
                # a converted actuator's torque limits: also the joint's own, if any
                j = lg.joint_ids[r]
                if m.jnt_actfrclimited[j]:
                    tau_max[li, r] = min(tau_max[li, r], float(min(abs(v) for v in m.jnt_actfrcrange[j])))
    # the robot touches the world, not itself (footfall's legs swing close past each other; a self-collision is
    # no planned contact): robot geoms collide as contype 2 / conaffinity 1 against the world's 1 / 1
    if not desc.get("self_collision", False):
        robot_bodies = set(_subtree(m, base))
        for g in range(m.ngeom):
            if int(m.geom_bodyid[g]) in robot_bodies and (m.geom_contype[g] or m.geom_conaffinity[g]):
                if m.geom_contype[g] != 2 or m.geom_conaffinity[g] != 1:
                    sg = spec.geom(_name(m, mujoco.mjtObj.mjOBJ_GEOM, g))
                    sg.contype, sg.conaffinity = 2, 1
                    edited = True
    for body, site, pos in site_adds:
        spec.body(body).add_site(name=site, pos=pos.tolist(), size=[0.005, 0.005, 0.005], group=5)
    key_name = str(desc.get("keyframe", "home"))
    home_q = None
    k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, key_name)
    if k >= 0:
        home_q = np.array([[m.key_qpos[k, m.jnt_qposadr[j]] for j in lg.joint_ids] for lg in legs])
        notes.append(f"standing pose: keyframe {key_name!r}")
    elif "keyframe" in desc:
        problems.append(f"keyframe: {key_name!r} is not in {path.name}")
    for key in list(spec.keys):
        spec.delete(key)
        edited = True
    edited = edited or convert or bool(site_adds) or m.nmesh > 0 or m.ntex > 0 or m.nhfield > 0
    _absolute_dirs(spec, path)
    try:
        model = spec.compile()
    except Exception as e:
        raise RobotDescriptionError(
            f"{path.name}: MuJoCo cannot compile it: {' '.join(str(e).split())}"
        ) from None
    return Detected(
        model=model,
        # an MJCF that needed no edit is used as written (to_xml rounds some values to 6 digits)
        xml=spec.to_xml() if edited or "<include" in path.read_text() else path.read_text(),
        base_body=base,
        free_joint_name=free_name,
        legs=legs,
        ctrl_scale=ctrl_scale,
        tau_max=tau_max,
        q_range=q_range,
        home_q=home_q,
        problems=problems,
        notes=notes,
    )
