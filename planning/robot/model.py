"""RobotModel: a quadruped loaded from an MJCF plus a small description, with analytic leg kinematics.

Frames: ``body`` is the trunk frame (x forward, y left, z up, origin at the trunk center); ``world`` is MuJoCo's.
Every leg is hip abduction (about body x) → hip flexion (about y) → knee (about y); at zero angles the leg hangs
straight down. The kinematic lengths are read from the MJCF, so the description carries only names, the nominal
stance and what the MJCF does not say.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import yaml

LEGS: tuple[str, str, str, str] = ("FL", "FR", "RL", "RR")
ASSETS = Path(__file__).parent / "assets"


class ReachError(ValueError):
    """A foot position the leg cannot reach (too far, too close, or outside a joint's range)."""


class RobotDescriptionError(ValueError):
    """A robot description that does not match its MJCF (a missing joint, body or geom, a malformed field)."""


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


def load_robot(name_or_path: str | Path = "spot") -> RobotModel:
    """Returns the RobotModel of a shipped robot name ("spot", "go1") or a description file path."""
    p = Path(name_or_path)
    path = p if p.suffix in (".yaml", ".yml") else _builtin(str(name_or_path))
    if not path.exists():
        raise RobotDescriptionError(
            f"robot {str(name_or_path)!r}: no such robot description (shipped: {', '.join(available_robots())})"
        )
    try:
        desc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise RobotDescriptionError(f"{path}: not valid YAML: {e}") from None
    if not isinstance(desc, dict):
        raise RobotDescriptionError(f"{path}: a robot description must be a mapping")
    return RobotModel(desc, base_dir=path.parent)


class RobotModel:
    """A quadruped: MuJoCo model, names resolved to ids, analytic kinematics per leg."""

    def __init__(self, desc: dict[str, Any], base_dir: Path = ASSETS) -> None:
        def field(key: str) -> Any:
            if key not in desc:
                raise RobotDescriptionError(f"robot description: missing field {key!r}")
            return desc[key]

        self.name: str = str(field("name"))
        self.title: str = str(desc.get("title", self.name))
        self.mjcf_path: Path = (base_dir / str(field("mjcf"))).resolve()
        if not self.mjcf_path.exists():
            raise RobotDescriptionError(f"robot {self.name}: mjcf: file {self.mjcf_path} does not exist")
        self.mjcf_xml: str = self.mjcf_path.read_text()
        self.model = mujoco.MjModel.from_xml_string(self.mjcf_xml)
        m = self.model

        def resolve(kind: mujoco.mjtObj, name: str, where: str) -> int:
            i = mujoco.mj_name2id(m, kind, name)
            if i < 0:
                raise RobotDescriptionError(
                    f"robot {self.name}: {where}: {kind.name[6:].lower()} {name!r} is not in {self.mjcf_path.name}"
                )
            return int(i)

        self.body_id = resolve(mujoco.mjtObj.mjOBJ_BODY, str(field("body")), "body")
        legs = field("legs")
        if not isinstance(legs, dict) or set(legs) != set(LEGS):
            raise RobotDescriptionError(f"robot {self.name}: legs: must name exactly {', '.join(LEGS)}")
        ids: list[LegIds] = []
        for leg in LEGS:
            d = legs[leg]
            where = f"legs.{leg}"
            joints = d.get("joints", [])
            if len(joints) != 3:
                raise RobotDescriptionError(f"robot {self.name}: {where}.joints: needs 3 joints (hx, hy, kn)")
            jids = tuple(resolve(mujoco.mjtObj.mjOBJ_JOINT, j, f"{where}.joints") for j in joints)
            act = []
            for j, jid in zip(joints, jids, strict=True):
                a = [k for k in range(m.nu) if m.actuator_trnid[k, 0] == jid]
                if not a:
                    raise RobotDescriptionError(f"robot {self.name}: {where}: joint {j!r} has no actuator")
                act.append(a[0])
            ids.append(
                LegIds(
                    joint_ids=jids,  # type: ignore[arg-type]
                    qpos_adr=tuple(int(m.jnt_qposadr[j]) for j in jids),  # type: ignore[arg-type]
                    dof_adr=tuple(int(m.jnt_dofadr[j]) for j in jids),  # type: ignore[arg-type]
                    actuator_ids=tuple(act),  # type: ignore[arg-type]
                    foot_geom=resolve(mujoco.mjtObj.mjOBJ_GEOM, d.get("foot", ""), f"{where}.foot"),
                    foot_site=resolve(mujoco.mjtObj.mjOBJ_SITE, d.get("foot_site", ""), f"{where}.foot_site"),
                    hip_body=resolve(mujoco.mjtObj.mjOBJ_BODY, d.get("hip", ""), f"{where}.hip"),
                    knee_body=resolve(mujoco.mjtObj.mjOBJ_BODY, d.get("knee", ""), f"{where}.knee"),
                )
            )
        self.legs: tuple[LegIds, ...] = tuple(ids)
        self.qpos_idx = np.array([leg.qpos_adr for leg in ids], dtype=np.int64)  # (4,3)
        self.dof_idx = np.array([leg.dof_adr for leg in ids], dtype=np.int64)  # (4,3)
        self.act_idx = np.array([leg.actuator_ids for leg in ids], dtype=np.int64)  # (4,3)
        self.foot_geom_ids = np.array([leg.foot_geom for leg in ids], dtype=np.int64)
        self.foot_site_ids = np.array([leg.foot_site for leg in ids], dtype=np.int64)

        # Kinematic lengths from the MJCF tree: hip body pos (in trunk), upper-leg body pos (abduction offset),
        # lower-leg body pos (upper length), foot geom pos (lower length).
        self.p_body_hip = np.array([m.body_pos[leg.hip_body] for leg in ids])  # (4,3)
        self.abd_offset = np.array([m.body_pos[m.body_parentid[leg.knee_body]][1] for leg in ids])
        self.l_upper = float(-m.body_pos[ids[0].knee_body][2])
        self.l_lower = float(-m.geom_pos[ids[0].foot_geom][2])
        self.foot_radius_m = float(m.geom_size[ids[0].foot_geom][0])
        self.q_min = np.array([[m.jnt_range[j][0] for j in leg.joint_ids] for leg in ids])
        self.q_max = np.array([[m.jnt_range[j][1] for j in leg.joint_ids] for leg in ids])
        self.tau_max = np.array([[m.actuator_ctrlrange[a][1] for a in leg.actuator_ids] for leg in ids])
        self.qd_max = float(desc.get("joint_velocity_limit", 20.0))
        self.mass_kg = float(np.sum(m.body_mass))
        self.standing_height_m = float(field("standing_height"))
        st = field("nominal_stance")
        sx, sy = float(st["x"]), float(st["y"])
        sign = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]], dtype=float)
        self.nominal_foot_body = np.column_stack(
            [sign[:, 0] * sx, sign[:, 1] * sy, np.full(4, -self.standing_height_m)]
        )  # (4,3) contact points
        kmin, kmax = self.q_min[0, 2], self.q_max[0, 2]
        lu, ll = self.l_upper, self.l_lower
        self.max_leg_length_m = float(np.sqrt(lu**2 + ll**2 + 2 * lu * ll * np.cos(kmax)))
        self.min_leg_length_m = float(np.sqrt(lu**2 + ll**2 + 2 * lu * ll * np.cos(kmin)))
        self.q_nominal = np.array(
            [self.ik_leg(i, self.nominal_foot_body[i] + [0, 0, self.foot_radius_m]) for i in range(4)]
        )
        self.inertia_body = self._composite_inertia()

    # ----------------------------------------------------------------------------------------------------------
    def home_qpos(self, height: float | None = None) -> np.ndarray:
        """Returns the full qpos (free joint + legs) of the nominal stance with the body at ``height`` m."""
        q = np.zeros(self.model.nq)
        q[2] = self.standing_height_m if height is None else height
        q[3] = 1.0
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
        q0, q1, q2 = q
        lu, ll = self.l_upper, self.l_lower
        x = -lu * np.sin(q1) - ll * np.sin(q1 + q2)
        z = -lu * np.cos(q1) - ll * np.cos(q1 + q2)
        y = self._side(leg)
        c, s = np.cos(q0), np.sin(q0)
        return self.p_body_hip[leg] + np.array([x, c * y - s * z, s * y + c * z])

    def knee_body(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Returns the knee position (3,) in the body frame."""
        q0, q1, _ = q
        x = -self.l_upper * np.sin(q1)
        z = -self.l_upper * np.cos(q1)
        y = self._side(leg)
        c, s = np.cos(q0), np.sin(q0)
        return self.p_body_hip[leg] + np.array([x, c * y - s * z, s * y + c * z])

    def jacobian_leg(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Returns d p_body_foot / d q (3,3) for leg joint angles q (3,)."""
        q0, q1, q2 = q
        lu, ll = self.l_upper, self.l_lower
        s1, c1, s12, c12 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2)
        z = -lu * c1 - ll * c12
        dx1, dz1 = -lu * c1 - ll * c12, lu * s1 + ll * s12
        dx2, dz2 = -ll * c12, ll * s12
        y = self._side(leg)
        c, s = np.cos(q0), np.sin(q0)
        J = np.empty((3, 3))
        J[0] = (0.0, dx1, dx2)
        J[1] = (-s * y - c * z, -s * dz1, -s * dz2)
        J[2] = (c * y - s * z, c * dz1, c * dz2)
        return J

    def ik_leg(self, leg: int, p_body_foot: np.ndarray) -> np.ndarray:
        """Returns joint angles (3,) that put the foot center at p_body_foot (3,); raises ReachError."""
        p = np.asarray(p_body_foot, dtype=float) - self.p_body_hip[leg]
        px, py, pz = p
        y = self._side(leg)
        r2 = py * py + pz * pz - y * y
        name = LEGS[leg]
        if r2 <= 0.0:
            raise ReachError(f"{name}: foot at {np.round(p_body_foot, 3).tolist()} is inside the hip offset")
        zp = -np.sqrt(r2)
        q0 = np.arctan2(pz, py) - np.arctan2(zp, y)
        q0 = (q0 + np.pi) % (2 * np.pi) - np.pi
        D = np.hypot(px, zp)
        if D > self.max_leg_length_m + 1e-9 or D < self.min_leg_length_m - 1e-9:
            raise ReachError(
                f"{name}: foot at {np.round(p_body_foot, 3).tolist()} (body frame) is {D:.3f} m from the hip; "
                f"the leg reaches {self.min_leg_length_m:.3f}–{self.max_leg_length_m:.3f} m"
            )
        lu, ll = self.l_upper, self.l_lower
        c2 = np.clip((D * D - lu * lu - ll * ll) / (2 * lu * ll), -1.0, 1.0)
        q2 = -np.arccos(c2)
        phi = np.arctan2(-px, -zp)
        q1 = phi - np.arctan2(ll * np.sin(q2), lu + ll * np.cos(q2))
        q = np.array([q0, q1, q2])
        lo, hi = self.q_min[leg] - 1e-9, self.q_max[leg] + 1e-9
        bad = (q < lo) | (q > hi)
        if bad.any():
            j = int(np.argmax(bad))
            jn = ("hip abduction", "hip flexion", "knee")[j]
            raise ReachError(
                f"{name}: foot at {np.round(p_body_foot, 3).tolist()} needs {jn} {q[j]:.2f} rad, "
                f"outside its range [{self.q_min[leg, j]:.2f}, {self.q_max[leg, j]:.2f}]"
            )
        return q

    def ik_leg_many(self, leg: int, p_body_foot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorized ik_leg: joint angles (K,3) for foot centers p_body_foot (K,3) in the body frame, and which rows
        are reachable (K,) bool (the rows ik_leg would raise ReachError for hold meaningless angles).

        Same arithmetic as ik_leg, element by element, so reachable rows are bit-identical to it.
        """
        p = p_body_foot - self.p_body_hip[leg]
        px, py, pz = p[:, 0], p[:, 1], p[:, 2]
        y = self._side(leg)
        lu, ll = self.l_upper, self.l_lower
        r2 = py * py + pz * pz - y * y
        ok = r2 > 0.0
        # rows with r2 ≤ 0 are out of reach: taking the root of 0 there keeps NaNs (and their warnings) out
        zp = -np.sqrt(np.maximum(r2, 0.0))
        q = np.empty((len(p), 3))
        q0 = np.arctan2(pz, py) - np.arctan2(zp, y)
        q[:, 0] = (q0 + np.pi) % (2 * np.pi) - np.pi
        D = np.hypot(px, zp)
        ok &= (D <= self.max_leg_length_m + 1e-9) & (D >= self.min_leg_length_m - 1e-9)
        c2 = np.clip((D * D - lu * lu - ll * ll) / (2 * lu * ll), -1.0, 1.0)
        q2 = -np.arccos(c2)
        q[:, 2] = q2
        q[:, 1] = np.arctan2(-px, -zp) - np.arctan2(ll * np.sin(q2), lu + ll * np.cos(q2))
        ok &= ((q >= self.q_min[leg] - 1e-9) & (q <= self.q_max[leg] + 1e-9)).all(axis=1)
        return q, ok

    def knee_body_many(self, leg: int, q: np.ndarray) -> np.ndarray:
        """Vectorized knee_body: knee positions (K,3) in the body frame for joint angles q (K,3)."""
        q0, q1 = q[:, 0], q[:, 1]
        x = -self.l_upper * np.sin(q1)
        z = -self.l_upper * np.cos(q1)
        y = self._side(leg)
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
