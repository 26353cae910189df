"""RobotModel: a quadruped loaded from its MJCF (plus an optional small description), with analytic leg kinematics.

Frames: ``body`` is the base frame (x forward, y left, z up, origin at the base body's frame); ``world`` is MuJoCo's.
Every leg is hip abduction (about body ±x) → hip flexion (about ±y) → knee (about ±y). The kinematic parameters are
read from MuJoCo's own kinematics at zero joint angles (``planning.robot.mjcf``), so knee offsets, feet in their own
bodies and joints turning about −y are all exact; `footfall robot check` compares the analytic model against MuJoCo.
Joint angles everywhere are MuJoCo's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import yaml

from planning.robot.mjcf import (
    DESCRIPTION_KEYS,
    LEGS,
    NEAR_FOOT_FACTOR,
    Detected,
    RobotDescriptionError,
    detect,
    load_spec,
)

ASSETS = Path(__file__).parent / "assets"
DEFAULT_JOINT_VELOCITY_LIMIT = 20.0  # rad/s, when the description does not give one
GUESSED_LEG_EXTENSION = (
    0.75  # with no keyframe: stand with the hip-foot distance at this share of the full reach
)

__all__ = [
    "ASSETS",
    "LEGS",
    "ReachError",
    "RobotDescriptionError",
    "RobotModel",
    "available_robots",
    "load_robot",
]


class ReachError(ValueError):
    """A foot position the leg cannot reach (too far, too close, or outside a joint's range)."""


@dataclass(frozen=True)
class LegIds:
    """MuJoCo ids of one leg, resolved once at load."""

    joint_ids: tuple[int, int, int]
    qpos_adr: tuple[int, int, int]
    dof_adr: tuple[int, int, int]
    actuator_ids: tuple[int, int, int]
    foot_geom: int
    foot_site: int
    hip_body: int
    knee_body: int


def _builtin(name: str) -> Path:
    return ASSETS / f"{name}.yaml"


def available_robots() -> list[str]:
    """Names of the shipped robot descriptions."""
    return sorted(p.stem for p in ASSETS.glob("*.yaml"))


def _read_yaml(path: Path) -> dict[str, Any]:
    try:
        desc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise RobotDescriptionError(f"{path}: not valid YAML: {' '.join(str(e).split())}") from None
    if desc is None:
        return {}
    if not isinstance(desc, dict):
        raise RobotDescriptionError(f"{path}: a robot description must be a mapping")
    unknown = sorted(set(map(str, desc)) - DESCRIPTION_KEYS)
    if unknown:
        raise RobotDescriptionError(
            f"{path.name}: unknown field(s) {', '.join(unknown)} (known: {', '.join(sorted(DESCRIPTION_KEYS))})"
        )
    return desc


def description_beside(xml: Path) -> Path:
    """The optional description of an MJCF file: ``NAME.footfall.yaml`` in the same folder."""
    return xml.with_name(xml.stem + ".footfall.yaml")


@lru_cache(maxsize=1)
def reference_leg_joint_inertia() -> np.ndarray:
    """Gives (4, 3) the leg joints' inertia of the reference robot (the shipped spot, which the controllers' joint
    gains were tuned on), kg·m²."""
    return load_robot("spot").leg_joint_inertia


def load_robot(name_or_path: str | Path = "spot", strict: bool = True) -> RobotModel:
    """Returns the RobotModel of a shipped robot name ("spot", "go1"), an MJCF path (``.xml``; an optional
    ``NAME.footfall.yaml`` beside it overrides detection) or a description path (``.yaml`` naming its ``mjcf``).

    Raises RobotDescriptionError naming every problem; with strict=False a robot that could be built is returned
    with its problems in ``.problems`` (what `footfall robot check` prints)."""
    p = Path(name_or_path)
    if p.suffix.lower() in (".xml", ".yaml", ".yml"):
        p = p.expanduser()  # a path may start with ~ (sweep specs name robots in the user's cache)
    if p.suffix.lower() == ".xml":
        side = description_beside(p)
        desc = _read_yaml(side) if side.exists() else {}
        return RobotModel.from_mjcf(p, desc, strict)
    path = p if p.suffix in (".yaml", ".yml") else _builtin(str(name_or_path))
    if not path.exists():
        raise RobotDescriptionError(
            f"robot {str(name_or_path)!r}: no such robot description (shipped: {', '.join(available_robots())}; "
            f"or an MJCF file, PATH.xml)"
        )
    desc = _read_yaml(path)
    if "mjcf" not in desc:
        raise RobotDescriptionError(
            f"{path.name}: missing field 'mjcf' (the MJCF file, relative to the description)"
        )
    return RobotModel.from_mjcf(path.parent / str(desc["mjcf"]), desc, strict)


class RobotModel:
    """A quadruped: MuJoCo model, names resolved to ids, analytic kinematics per leg."""

    @classmethod
    def from_mjcf(cls, xml_path: Path, desc: dict[str, Any], strict: bool = True) -> RobotModel:
        """Loads and checks an MJCF; raises RobotDescriptionError naming every problem at once."""
        xml_path = Path(xml_path)
        if not xml_path.exists():
            where = f"robot {desc['name']}: mjcf: " if "name" in desc else ""
            raise RobotDescriptionError(f"{where}file {xml_path.resolve()} does not exist")
        spec = load_spec(xml_path)
        det = detect(spec, xml_path, desc)
        robot = cls(det, desc, xml_path)
        if robot.problems and strict:
            raise RobotDescriptionError(
                f"{xml_path.name}: {len(robot.problems)} problem(s): " + "; ".join(robot.problems)
            )
        return robot

    def __init__(self, det: Detected, desc: dict[str, Any], xml_path: Path) -> None:
        self.problems: list[str] = list(det.problems)
        self.notes: list[str] = list(det.notes)
        self.mjcf_path: Path = Path(xml_path).resolve()
        self.mjcf_xml: str = det.xml
        self.model = det.model
        m = self.model
        self.name: str = str(desc.get("name", self.mjcf_path.stem))
        self.title: str = str(desc.get("title", f"{self.name} ({self.mjcf_path.name})"))
        self.body_id = det.base_body
        self.free_joint_name = det.free_joint_name
        geo = det.legs

        def site(name: str) -> int:
            return int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name))

        ids = [
            LegIds(
                joint_ids=g.joint_ids,
                qpos_adr=tuple(int(m.jnt_qposadr[j]) for j in g.joint_ids),  # type: ignore[arg-type]
                dof_adr=tuple(int(m.jnt_dofadr[j]) for j in g.joint_ids),  # type: ignore[arg-type]
                actuator_ids=g.actuator_ids,
                foot_geom=g.foot_geom,
                foot_site=site(g.foot_site_name),
                hip_body=int(m.jnt_bodyid[g.joint_ids[0]]),
                knee_body=g.knee_body,
            )
            for g in geo
        ]
        self.legs: tuple[LegIds, ...] = tuple(ids)
        self.leg_geometry = tuple(geo)
        self.qpos_idx = np.array([leg.qpos_adr for leg in ids], dtype=np.int64)  # (4,3)
        self.dof_idx = np.array([leg.dof_adr for leg in ids], dtype=np.int64)  # (4,3)
        self.act_idx = np.array([leg.actuator_ids for leg in ids], dtype=np.int64)  # (4,3)
        self.ctrl_scale = det.ctrl_scale  # (4,3) actuator ctrl per N·m of joint torque (1 / (gear · gain))
        self.foot_geom_ids = np.array([leg.foot_geom for leg in ids], dtype=np.int64)
        self.foot_site_ids = np.array([leg.foot_site for leg in ids], dtype=np.int64)
        self.foot_site_names = tuple(g.foot_site_name for g in geo)
        # collision geoms below each knee other than the foot: a contact near the foot center is the foot's
        self.lower_leg_geoms = tuple(g.lower_geoms for g in geo)
        self.ground_geom_names = tuple(str(n) for n in (desc.get("ground_geoms") or []))
        for n in self.ground_geom_names:
            if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) < 0:
                self.problems.append(f"ground_geoms: geom {n!r} is not in {self.mjcf_path.name}")

        # analytic kinematics, per leg (see planning.robot.mjcf.LegGeometry)
        self.p_body_hip = np.array([g.p_hip for g in geo])  # (4,3) on the abduction axis
        self.abd_offset = np.array([g.y_foot for g in geo])  # (4,) lateral offset of the foot plane
        self._y_knee = np.array([g.y_knee for g in geo])
        self._z_flex = np.array([g.z_flex for g in geo])
        self._lu = np.array([g.l_upper for g in geo])
        self._ll = np.array([g.l_lower for g in geo])
        self._alpha = np.array([g.alpha for g in geo])
        self._beta = np.array([g.beta for g in geo])
        self._sign = np.array([g.signs for g in geo])  # (4,3)
        self.l_upper = float(self._lu[0])
        self.l_lower = float(self._ll[0])
        if np.ptp(self._lu) > 1e-3 or np.ptp(self._ll) > 1e-3:
            self.notes.append(
                f"legs differ in length (upper {np.round(self._lu, 3).tolist()}, lower {np.round(self._ll, 3).tolist()} m)"
            )
        self.foot_radius_m = float(geo[0].foot_radius)
        # the lower legs' collision radius (m): the largest capsule, cylinder or sphere radius below the knees
        # other than the feet (0 when they are meshes or boxes: the shin rules then test the shin's axis)
        self.shin_radius_m = max(
            (
                float(m.geom_size[gid, 0])
                for g in geo
                for gid in g.lower_geoms
                if int(m.geom_type[gid])
                in (
                    mujoco.mjtGeom.mjGEOM_CAPSULE,
                    mujoco.mjtGeom.mjGEOM_CYLINDER,
                    mujoco.mjtGeom.mjGEOM_SPHERE,
                )
            ),
            default=0.0,
        )
        self.q_min = det.q_range[:, :, 0].copy()
        self.q_max = det.q_range[:, :, 1].copy()
        self.tau_max = det.tau_max
        self.qd_max = float(desc.get("joint_velocity_limit", DEFAULT_JOINT_VELOCITY_LIMIT))
        # the joints' own damping (N·m·s/rad) and friction loss (N·m) from the MJCF, which the motors make up for
        # (planning.sim.world.World.set_torques) unless the description says joint_loss_compensation: false
        self.compensate_joint_losses = bool(desc.get("joint_loss_compensation", True))
        # whether a lower-leg geom's contact right at the foot counts as the foot's (shank meshes that reach the
        # foot); a robot whose feet are their own geoms clear of the shank says near_foot_contact: false, and every
        # lower-leg contact stays a knee contact (a fall)
        self.near_foot_contact = bool(desc.get("near_foot_contact", True))
        self.joint_damping = np.array([[m.dof_damping[m.jnt_dofadr[j]] for j in g.joint_ids] for g in geo])
        self.joint_frictionloss = np.array(
            [[m.dof_frictionloss[m.jnt_dofadr[j]] for j in g.joint_ids] for g in geo]
        )
        self.mass_kg = float(np.sum(m.body_mass))
        # the knee bends to one side: the relative shank angle's sign over the knee's range
        psi_lo = self._sign[:, 2] * self.q_min[:, 2] + self._beta - self._alpha
        psi_hi = self._sign[:, 2] * self.q_max[:, 2] + self._beta - self._alpha
        lo, hi = np.minimum(psi_lo, psi_hi), np.maximum(psi_lo, psi_hi)
        self._knee_branch = np.where(lo + hi <= 0.0, -1.0, 1.0)
        a_lo = np.where(self._knee_branch < 0, np.clip(-hi, 0, np.pi), np.clip(lo, 0, np.pi))
        a_hi = np.where(self._knee_branch < 0, np.clip(-lo, 0, np.pi), np.clip(hi, 0, np.pi))
        lu, ll = self._lu, self._ll
        self._d_max = np.sqrt(lu**2 + ll**2 + 2 * lu * ll * np.cos(a_lo))
        self._d_min = np.sqrt(lu**2 + ll**2 + 2 * lu * ll * np.cos(a_hi))
        self.max_leg_length_m = float(np.min(self._d_max))
        self.min_leg_length_m = float(np.max(self._d_min))
        # per leg, the constants of the analytic kinematics as Python floats (jacobian_leg, ik_leg): signs (3),
        # upper and lower lengths, alpha, beta, z_flex, lateral foot offset, hip (3), reach min and max, knee branch
        self._leg_floats = [
            (
                *(float(v) for v in self._sign[i]),
                float(self._lu[i]),
                float(self._ll[i]),
                float(self._alpha[i]),
                float(self._beta[i]),
                float(self._z_flex[i]),
                float(self.abd_offset[i]),
                *(float(v) for v in self.p_body_hip[i]),
                float(self._d_min[i]),
                float(self._d_max[i]),
                float(self._knee_branch[i]),
            )
            for i in range(4)
        ]
        self._y_knee_f = [float(v) for v in self._y_knee]
        # joint ranges widened by ik_leg's 1e-9 tolerance, as floats (knee_of_foot)
        self._q_lo_f = [[float(v) - 1e-9 for v in self.q_min[i]] for i in range(4)]
        self._q_hi_f = [[float(v) + 1e-9 for v in self.q_max[i]] for i in range(4)]
        self._standing_pose(det, desc)
        try:
            self.q_nominal = np.array(
                [self.ik_leg(i, self.nominal_foot_body[i] + [0, 0, self.foot_radius_m]) for i in range(4)]
            )
        except ReachError as e:
            self.problems.append(f"the standing pose is out of reach: {e}")
            self.q_nominal = np.zeros((4, 3))
        self.inertia_body = self._composite_inertia()
        self.leg_joint_inertia = self._leg_joint_inertia()

    def _leg_joint_inertia(self) -> np.ndarray:
        """Gives (4, 3) each leg joint's inertia in the standing pose (kg·m²): the joint-space mass matrix's diagonal
        from MuJoCo, the leg below the joint and the joint's armature."""
        m = self.model
        d = mujoco.MjData(m)
        d.qpos[:] = self.home_qpos()
        mujoco.mj_forward(m, d)
        e, col = np.zeros(m.nv), np.zeros(m.nv)

        def diag(dof: int) -> float:  # M[dof, dof] (mj_mulM: the same call in every MuJoCo version)
            e[:] = 0.0
            e[dof] = 1.0
            mujoco.mj_mulM(m, d, col, e)
            return float(col[dof])

        return np.array([[diag(int(m.jnt_dofadr[j])) for j in lg.joint_ids] for lg in self.legs])

    def _standing_pose(self, det: Detected, desc: dict[str, Any]) -> None:
        """Standing height and nominal footholds: the description's, else the home keyframe's, else guessed."""
        r = self.foot_radius_m
        if "standing_height" in desc and "nominal_stance" in desc:
            try:
                self.standing_height_m = float(desc["standing_height"])
                st = desc["nominal_stance"]
                sx, sy = float(st["x"]), float(st["y"])
            except (TypeError, ValueError, KeyError):
                raise RobotDescriptionError(
                    "standing_height: a number (m) and nominal_stance: {x: M, y: M} are needed together"
                ) from None
            sign = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]], dtype=float)
            self.nominal_foot_body = np.column_stack(
                [sign[:, 0] * sx, sign[:, 1] * sy, np.full(4, -self.standing_height_m)]
            )  # (4,3) contact points
            self.standing_source = "description"
            return
        if det.home_q is not None:
            feet = np.array([self.fk_leg(i, det.home_q[i]) for i in range(4)])
            self.standing_source = "keyframe"
        else:
            feet = np.empty((4, 3))
            for i in range(4):
                d = GUESSED_LEG_EXTENSION * self._d_max[i] + (1 - GUESSED_LEG_EXTENSION) * self._d_min[i]
                feet[i] = self.p_body_hip[i] + [0.0, self.abd_offset[i], self._z_flex[i] - d]
            self.standing_source = "guessed"
            self.notes.append(
                f"no keyframe {desc.get('keyframe', 'home')!r}: standing pose guessed (feet under the hips, legs at "
                f"{GUESSED_LEG_EXTENSION:.0%} of their reach)"
            )
        h = float(-np.mean(feet[:, 2]) + r)
        if "standing_height" in desc:
            h = float(desc["standing_height"])
        self.standing_height_m = h
        self.nominal_foot_body = np.column_stack([feet[:, :2], np.full(4, -h)])
        if h <= r:
            self.problems.append(f"the standing pose puts the feet at or above the base (height {h:.3f} m)")

    # ----------------------------------------------------------------------------------------------------------
    @property
    def nominal_stance_xy(self) -> tuple[float, float]:
        """Mean |x| and |y| of the nominal footholds in the body frame (m): the robot's stance size."""
        return float(np.mean(np.abs(self.nominal_foot_body[:, 0]))), float(
            np.mean(np.abs(self.nominal_foot_body[:, 1]))
        )

    def home_qpos(self, height: float | None = None) -> np.ndarray:
        """Returns the full qpos (free joint + legs) of the nominal stance with the body at ``height`` m."""
        q = self.model.qpos0.copy()
        fa = int(
            self.model.jnt_qposadr[
                mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, self.free_joint_name)
            ]
        )
        q[fa : fa + 7] = (0.0, 0.0, self.standing_height_m if height is None else height, 1.0, 0.0, 0.0, 0.0)
        for i in range(4):
            q[self.qpos_idx[i]] = self.q_nominal[i]
        return q

    def _composite_inertia(self) -> np.ndarray:
        m = self.model
        d = mujoco.MjData(m)
        d.qpos[:] = self.home_qpos()
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        com = d.subtree_com[self.body_id].copy()
        inertia = np.zeros((3, 3))
        for b in range(1, m.nbody):
            R = d.ximat[b].reshape(3, 3)
            Ib = R @ np.diag(m.body_inertia[b]) @ R.T
            r = d.xipos[b] - com
            inertia += Ib + m.body_mass[b] * (r @ r * np.eye(3) - np.outer(r, r))
        return inertia

    # ---- kinematics (body frame, analytic) -------------------------------------------------------------------
    def _side(self, leg: int) -> float:
        return float(self.abd_offset[leg])

    def fk_leg(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Returns the foot-center position (3,) in the body frame for leg joint angles q (3,) rad."""
        s0, s1, s2 = self._sign[leg]
        q0, q1, q2 = s0 * q[0], s1 * q[1], s2 * q[2]
        lu, ll = self._lu[leg], self._ll[leg]
        p1 = q1 + self._alpha[leg]
        p12 = q1 + q2 + self._beta[leg]
        x = -lu * np.sin(p1) - ll * np.sin(p12)
        z = -lu * np.cos(p1) - ll * np.cos(p12) + self._z_flex[leg]
        y = self._side(leg)
        c, s = np.cos(q0), np.sin(q0)
        return self.p_body_hip[leg] + np.array([x, c * y - s * z, s * y + c * z])

    def knee_body(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Returns the knee position (3,) in the body frame."""
        s0, s1, _, lu, _, alpha, _, z_flex, _, hx, hy, hz = self._leg_floats[leg][:12]
        qa, qb = float(q[0]), float(q[1])
        q0, p1 = s0 * qa, s1 * qb + alpha
        x = -lu * math.sin(p1)
        z = -lu * math.cos(p1) + z_flex
        y = self._y_knee_f[leg]
        c, s = math.cos(q0), math.sin(q0)
        return np.array([hx + x, hy + (c * y - s * z), hz + (s * y + c * z)])

    def jacobian_leg(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Returns d p_body_foot / d q (3,3) for leg joint angles q (3,)."""
        # Python floats (the leg's constants resolved once, _leg_floats): the same IEEE arithmetic as on NumPy
        # scalars, without their per-operation overhead (this runs for every swing leg at every physics step)
        s0, s1, s2, lu, ll, alpha, beta, z_flex, y = self._leg_floats[leg][:9]
        qa, qb, qc = q.tolist() if isinstance(q, np.ndarray) else (float(q[0]), float(q[1]), float(q[2]))
        q0, q1, q2 = s0 * qa, s1 * qb, s2 * qc
        p1 = q1 + alpha
        p12 = q1 + q2 + beta
        s1_, c1_, s12, c12 = math.sin(p1), math.cos(p1), math.sin(p12), math.cos(p12)
        z = -lu * c1_ - ll * c12 + z_flex
        dx1, dz1 = -lu * c1_ - ll * c12, lu * s1_ + ll * s12
        dx2, dz2 = -ll * c12, ll * s12
        c, s = math.cos(q0), math.sin(q0)
        return np.array(
            [
                [0.0 * s0, dx1 * s1, dx2 * s2],
                [(-s * y - c * z) * s0, -s * dz1 * s1, -s * dz2 * s2],
                [(c * y - s * z) * s0, c * dz1 * s1, c * dz2 * s2],
            ]
        )

    def _wrap_into_range(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Moves an angle by 2π where that brings it into its joint's range (only then: the arithmetic of in-range
        angles is untouched)."""
        lo, hi = self.q_min[leg], self.q_max[leg]
        for k in (1, 2):
            if q[k] < lo[k] - 1e-9 and lo[k] - 1e-9 <= q[k] + 2 * np.pi <= hi[k] + 1e-9:
                q[k] += 2 * np.pi
            elif q[k] > hi[k] + 1e-9 and lo[k] - 1e-9 <= q[k] - 2 * np.pi <= hi[k] + 1e-9:
                q[k] -= 2 * np.pi
        return q

    def ik_leg(self, leg: int, p_body_foot: np.ndarray) -> np.ndarray:
        """Returns joint angles (3,) that put the foot center at p_body_foot (3,); raises ReachError."""
        # Python floats (see jacobian_leg); NumPy's arctan2 and arccos kept (their results differ from math's in
        # the last bit), the square root is exact in both
        s0, s1, s2, lu, ll, a, b, z_flex, y, hx, hy, hz, d_min, d_max, branch = self._leg_floats[leg]
        fx, fy, fz = np.asarray(p_body_foot, dtype=float).tolist()
        px, py, pz = fx - hx, fy - hy, fz - hz
        r2 = py * py + pz * pz - y * y
        name = LEGS[leg]
        if r2 <= 0.0:
            raise ReachError(f"{name}: foot at {np.round(p_body_foot, 3).tolist()} is inside the hip offset")
        zp = -math.sqrt(r2)
        q0 = float(np.arctan2(pz, py)) - float(np.arctan2(zp, y))
        q0 = (q0 + math.pi) % (2 * math.pi) - math.pi
        zs = zp - z_flex
        D = float(np.hypot(px, zs))
        if D > d_max + 1e-9 or D < d_min - 1e-9:
            raise ReachError(
                f"{name}: foot at {np.round(p_body_foot, 3).tolist()} (body frame) is {D:.3f} m from the hip; "
                f"the leg reaches {d_min:.3f}–{d_max:.3f} m"
            )
        c2 = min(max((D * D - lu * lu - ll * ll) / (2 * lu * ll), -1.0), 1.0)  # np.clip
        psi2 = branch * float(np.arccos(c2))
        phi = float(np.arctan2(-px, -zs))
        psi1 = phi - float(np.arctan2(ll * math.sin(psi2), lu + ll * math.cos(psi2)))
        q = [s0 * q0, s1 * (psi1 - a), s2 * (psi2 - b + a)]
        lo, hi = self.q_min[leg].tolist(), self.q_max[leg].tolist()
        two_pi = 2 * math.pi
        for k in (1, 2):  # _wrap_into_range on floats
            if q[k] < lo[k] - 1e-9 and lo[k] - 1e-9 <= q[k] + two_pi <= hi[k] + 1e-9:
                q[k] += two_pi
            elif q[k] > hi[k] + 1e-9 and lo[k] - 1e-9 <= q[k] - two_pi <= hi[k] + 1e-9:
                q[k] -= two_pi
        for j in range(3):
            if q[j] < lo[j] - 1e-9 or q[j] > hi[j] + 1e-9:
                jn = ("hip abduction", "hip flexion", "knee")[j]
                raise ReachError(
                    f"{name}: foot at {np.round(p_body_foot, 3).tolist()} needs {jn} {q[j]:.2f} rad, "
                    f"outside its range [{self.q_min[leg, j]:.2f}, {self.q_max[leg, j]:.2f}]"
                )
        return np.array(q)

    def knee_of_foot(self, leg: int, fx: float, fy: float, fz: float) -> tuple[float, float, float] | None:
        """knee_body(leg, ik_leg(leg, foot)) for a foot center (fx, fy, fz) in the body frame, all in Python floats
        (the math module's atan2/acos/hypot: equal to ik_leg's NumPy calls to the last bit or two); None where
        ik_leg raises ReachError. For the swing planner's knee checks, a few samples at a time."""
        s0, s1, s2, lu, ll, a, b, z_flex, y, hx, hy, hz, d_min, d_max, branch = self._leg_floats[leg]
        px, py, pz = fx - hx, fy - hy, fz - hz
        r2 = py * py + pz * pz - y * y
        if r2 <= 0.0:
            return None
        zp = -math.sqrt(r2)
        q0 = math.atan2(pz, py) - math.atan2(zp, y)
        q0 = (q0 + math.pi) % (2 * math.pi) - math.pi
        zs = zp - z_flex
        D = math.hypot(px, zs)
        if D > d_max + 1e-9 or D < d_min - 1e-9:
            return None
        c2 = min(max((D * D - lu * lu - ll * ll) / (2 * lu * ll), -1.0), 1.0)
        psi2 = branch * math.acos(c2)
        psi1 = math.atan2(-px, -zs) - math.atan2(ll * math.sin(psi2), lu + ll * math.cos(psi2))
        q0, q1, q2 = s0 * q0, s1 * (psi1 - a), s2 * (psi2 - b + a)
        lo0, lo1, lo2 = self._q_lo_f[leg]
        hi0, hi1, hi2 = self._q_hi_f[leg]
        two_pi = 2 * math.pi
        # as ik_leg: the hip and knee angles wrapped by a turn when that brings them within their ranges (written
        # out per joint: a list and loops cost a sixth of the call)
        if q1 < lo1 and lo1 <= q1 + two_pi <= hi1:
            q1 += two_pi
        elif q1 > hi1 and lo1 <= q1 - two_pi <= hi1:
            q1 -= two_pi
        if q2 < lo2 and lo2 <= q2 + two_pi <= hi2:
            q2 += two_pi
        elif q2 > hi2 and lo2 <= q2 - two_pi <= hi2:
            q2 -= two_pi
        if q0 < lo0 or q0 > hi0 or q1 < lo1 or q1 > hi1 or q2 < lo2 or q2 > hi2:
            return None
        # knee_body
        qa, p1 = s0 * q0, s1 * q1 + a
        kx = -lu * math.sin(p1)
        kz = -lu * math.cos(p1) + z_flex
        yk = self._y_knee_f[leg]
        c, sn = math.cos(qa), math.sin(qa)
        return hx + kx, hy + (c * yk - sn * kz), hz + (sn * yk + c * kz)

    def ik_leg_many(self, leg: int, p_body_foot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorized ik_leg: joint angles (K,3) for foot centers p_body_foot (K,3) in the body frame, and which rows
        are reachable (K,) bool (the rows ik_leg would raise ReachError for hold meaningless angles).

        Same arithmetic as ik_leg, element by element, so reachable rows are bit-identical to it.
        """
        p = p_body_foot - self.p_body_hip[leg]
        px, py, pz = p[:, 0], p[:, 1], p[:, 2]
        y = self._side(leg)
        # Python floats: the same IEEE arithmetic, less overhead
        lu, ll = float(self._lu[leg]), float(self._ll[leg])
        r2 = py * py + pz * pz - y * y
        ok = r2 > 0.0
        # rows with r2 ≤ 0 are out of reach: taking the root of 0 there keeps NaNs (and their warnings) out
        zp = -np.sqrt(np.maximum(r2, 0.0))
        q = np.empty((len(p), 3))
        q0 = np.arctan2(pz, py) - np.arctan2(zp, y)
        q0 = (q0 + np.pi) % (2 * np.pi) - np.pi
        zs = zp - self._z_flex[leg]
        D = np.hypot(px, zs)
        ok &= (D <= self._d_max[leg] + 1e-9) & (D >= self._d_min[leg] - 1e-9)
        c2 = np.minimum(np.maximum((D * D - lu * lu - ll * ll) / (2 * lu * ll), -1.0), 1.0)  # np.clip
        psi2 = self._knee_branch[leg] * np.arccos(c2)
        psi1 = np.arctan2(-px, -zs) - np.arctan2(ll * np.sin(psi2), lu + ll * np.cos(psi2))
        sg = self._sign[leg]
        a, b = self._alpha[leg], self._beta[leg]
        q[:, 0] = sg[0] * q0
        q[:, 1] = sg[1] * (psi1 - a)
        q[:, 2] = sg[2] * (psi2 - b + a)
        lo, hi = self.q_min[leg] - 1e-9, self.q_max[leg] + 1e-9
        inside = (q >= lo) & (q <= hi)
        if not inside[:, 1:].all():  # only angles out of range may wrap
            for k in (1, 2):
                up = (q[:, k] < lo[k]) & (q[:, k] + 2 * np.pi >= lo[k]) & (q[:, k] + 2 * np.pi <= hi[k])
                down = (q[:, k] > hi[k]) & (q[:, k] - 2 * np.pi >= lo[k]) & (q[:, k] - 2 * np.pi <= hi[k])
                if up.any():
                    q[up, k] += 2 * np.pi
                if down.any():
                    q[down, k] -= 2 * np.pi
            inside = (q >= lo) & (q <= hi)
        ok &= inside.all(axis=1)
        return q, ok

    def knee_body_many(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Vectorized knee_body: knee positions (K,3) in the body frame for joint angles q (K,3)."""
        s0, s1 = self._sign[leg, 0], self._sign[leg, 1]
        q0 = s0 * q[:, 0]
        p1 = s1 * q[:, 1] + self._alpha[leg]
        x = -self._lu[leg] * np.sin(p1)
        z = -self._lu[leg] * np.cos(p1) + self._z_flex[leg]
        y = float(self._y_knee[leg])
        c, s = np.cos(q0), np.sin(q0)
        out = np.empty((len(q), 3))
        out[:, 0] = x
        out[:, 1] = c * y - s * z
        out[:, 2] = s * y + c * z
        out += self.p_body_hip[leg]
        return out

    def nominal_footholds(self, p_world_body: np.ndarray, yaw: float) -> np.ndarray:
        """Returns the nominal foot contact points (4,3) in the world for a body at p_world_body with yaw (rad)."""
        c, s = np.cos(yaw), np.sin(yaw)
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        out = (Rz @ self.nominal_foot_body[:, :2].T).T
        res = np.empty((4, 3))
        res[:, :2] = out[:, :2] + np.asarray(p_world_body)[:2]
        res[:, 2] = 0.0
        return res

    def hips_world(self, p_world_body: np.ndarray, R_world_body: np.ndarray) -> np.ndarray:
        """Returns the hip positions (4,3) in the world."""
        return np.asarray(p_world_body) + self.p_body_hip @ np.asarray(R_world_body).T

    # ---- checks ------------------------------------------------------------------------------------------------
    def kinematics_error(self, samples: int = 200, seed: int = 0) -> tuple[float, float]:
        """Compares the analytic foot and knee positions against MuJoCo's at `samples` random poses inside the joint
        ranges; returns the largest foot and knee errors (m)."""
        m = self.model
        d = mujoco.MjData(m)
        rng = np.random.default_rng(seed)
        worst_foot = worst_knee = 0.0
        for _ in range(samples):
            d.qpos[:] = self.home_qpos(0.0)
            qs = self.q_min + rng.random((4, 3)) * (self.q_max - self.q_min)
            for i in range(4):
                d.qpos[self.qpos_idx[i]] = qs[i]
            mujoco.mj_kinematics(m, d)
            for i in range(4):
                p_mj = d.site_xpos[self.foot_site_ids[i]] - d.xpos[self.body_id]
                worst_foot = max(worst_foot, float(np.linalg.norm(self.fk_leg(i, qs[i]) - p_mj)))
                k_mj = d.xanchor[self.legs[i].joint_ids[2]] - d.xpos[self.body_id]
                worst_knee = max(worst_knee, float(np.linalg.norm(self.knee_body(i, qs[i]) - k_mj)))
        return worst_foot, worst_knee

    def near_foot_m(self) -> float:
        """A lower-leg geom's contact within this distance (m) of the foot center counts as the foot's (0: none
        does, the description's near_foot_contact: false)."""
        return NEAR_FOOT_FACTOR * self.foot_radius_m if self.near_foot_contact else 0.0
