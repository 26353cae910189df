"""Writes the shipped robot MJCFs from a handful of dimensions (run: python -m planning.robot._author).

The XML files in ``assets/`` are the product; this script is how they were authored, kept so that a change of
dimensions is one edit and not sixteen. Geometry is ours; sizes and masses follow public figures (Spot: ~32 kg,
1.1 m long; Go1: ~12 kg).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

ASSETS = Path(__file__).parent / "assets"


@dataclass(frozen=True)
class Dims:
    name: str
    trunk_half: tuple[float, float, float]  # m, half extents of the body box
    trunk_mass: float  # kg
    hip_x: float  # m, hip abduction axis fore/aft of the body center
    hip_y: float  # m, hip abduction axis lateral of the body center
    abd_offset: float  # m, lateral offset from the abduction axis to the leg plane
    upper: float  # m, hip flexion axis to knee
    lower: float  # m, knee to foot center
    foot_radius: float  # m
    upper_radius: float  # m
    lower_radius: float  # m
    hip_mass: float  # kg
    upper_mass: float  # kg
    lower_mass: float  # kg
    foot_mass: float  # kg
    tau: tuple[float, float, float]  # N·m, abduction / flexion / knee
    range_hx: tuple[float, float]  # rad
    range_hy: tuple[float, float]  # rad
    range_kn: tuple[float, float]  # rad
    armature: tuple[float, float, float]  # kg·m²
    damping: float  # N·m·s/rad
    start_height: float  # m, body height of the keyframe "home"


SPOT = Dims(
    name="spot",
    trunk_half=(0.42, 0.12, 0.08),
    trunk_mass=23.0,
    hip_x=0.30,
    hip_y=0.055,
    abd_offset=0.11,
    upper=0.32,
    lower=0.34,
    foot_radius=0.035,
    upper_radius=0.035,
    lower_radius=0.02,
    hip_mass=0.6,
    upper_mass=1.2,
    lower_mass=0.35,
    foot_mass=0.05,
    tau=(45.0, 45.0, 115.0),
    range_hx=(-0.78, 0.78),
    range_hy=(-0.90, 2.30),
    range_kn=(-2.79, -0.25),
    armature=(0.02, 0.02, 0.04),
    damping=0.2,
    start_height=0.52,
)

GO1 = Dims(
    name="go1",
    trunk_half=(0.19, 0.047, 0.057),
    trunk_mass=5.2,
    hip_x=0.1881,
    hip_y=0.04675,
    abd_offset=0.08,
    upper=0.213,
    lower=0.213,
    foot_radius=0.02,
    upper_radius=0.022,
    lower_radius=0.012,
    hip_mass=0.68,
    upper_mass=1.0,
    lower_mass=0.18,
    foot_mass=0.02,
    tau=(23.7, 23.7, 35.55),
    range_hx=(-0.86, 0.86),
    range_hy=(-0.69, 4.50),
    range_kn=(-2.82, -0.89),
    armature=(0.005, 0.005, 0.01),
    damping=0.1,
    start_height=0.30,
)

LEGS = (("FL", 1, 1), ("FR", 1, -1), ("RL", -1, 1), ("RR", -1, -1))


def _leg(d: Dims, leg: str, sx: int, sy: int) -> str:
    f = lambda v: f"{v:.5g}"  # noqa: E731
    hx, hy, kn = d.range_hx, d.range_hy, d.range_kn
    return f"""
      <body name="{leg}_hip" pos="{f(sx * d.hip_x)} {f(sy * d.hip_y)} 0">
        <inertial pos="0 {f(sy * 0.03)} 0" mass="{f(d.hip_mass)}" diaginertia="0.0009 0.0011 0.0011"/>
        <joint name="{leg}_hx" axis="1 0 0" range="{f(hx[0])} {f(hx[1])}" armature="{f(d.armature[0])}"/>
        <geom name="{leg}_hip_geom" type="cylinder" size="{f(d.upper_radius * 1.2)} {f(d.abd_offset * 0.35)}"
              pos="0 {f(sy * d.abd_offset * 0.6)} 0" zaxis="0 1 0" class="link"/>
        <body name="{leg}_uleg" pos="0 {f(sy * d.abd_offset)} 0">
          <inertial pos="0 0 {f(-d.upper / 2)}" mass="{f(d.upper_mass)}"
                    diaginertia="{f(d.upper_mass * d.upper**2 / 12)} {f(d.upper_mass * d.upper**2 / 12)} 0.0008"/>
          <joint name="{leg}_hy" axis="0 1 0" range="{f(hy[0])} {f(hy[1])}" armature="{f(d.armature[1])}"/>
          <geom name="{leg}_uleg_geom" type="capsule" fromto="0 0 0 0 0 {f(-d.upper)}" size="{f(d.upper_radius)}"
                class="link"/>
          <body name="{leg}_lleg" pos="0 0 {f(-d.upper)}">
            <inertial pos="0 0 {f(-d.lower / 2)}" mass="{f(d.lower_mass)}"
                      diaginertia="{f(d.lower_mass * d.lower**2 / 12)} {f(d.lower_mass * d.lower**2 / 12)} 0.0002"/>
            <joint name="{leg}_kn" axis="0 1 0" range="{f(kn[0])} {f(kn[1])}" armature="{f(d.armature[2])}"/>
            <geom name="{leg}_lleg_geom" type="capsule" fromto="0 0 0 0 0 {f(-d.lower + d.foot_radius)}"
                  size="{f(d.lower_radius)}" class="link"/>
            <geom name="{leg}_foot" type="sphere" pos="0 0 {f(-d.lower)}" size="{f(d.foot_radius)}"
                  mass="{f(d.foot_mass)}" class="foot"/>
            <site name="{leg}_foot_site" pos="0 0 {f(-d.lower)}" size="0.01"/>
          </body>
        </body>
      </body>"""


def mjcf(d: Dims) -> str:
    legs = "".join(_leg(d, leg, sx, sy) for leg, sx, sy in LEGS)
    acts = "\n".join(
        f'    <motor name="{leg}_{j}_motor" joint="{leg}_{j}" ctrlrange="{-t:.5g} {t:.5g}"/>'
        for leg, _, _ in LEGS
        for j, t in zip(("hx", "hy", "kn"), d.tau, strict=True)
    )
    tx, ty, tz = d.trunk_half
    return f"""<!-- footfall robot '{d.name}': authored for this project from primitives (planning/robot/_author.py).
     Contact filtering: robot geoms have contype 2 / conaffinity 1, the world contype 1 / conaffinity 1, so the robot
     touches the world but never itself. Only the feet are meant to touch the world; any other contact is a fall. -->
<mujoco model="{d.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.002" integrator="implicitfast" cone="pyramidal" gravity="0 0 -9.81"/>
  <default>
    <joint damping="{d.damping:.5g}" frictionloss="0.05"/>
    <motor ctrllimited="true"/>
    <geom contype="2" conaffinity="1" friction="0.8 0.02 0.01" rgba="0.95 0.78 0.1 1"/>
    <default class="link">
      <geom rgba="0.15 0.15 0.15 1" mass="0"/>
    </default>
    <default class="foot">
      <geom rgba="0.1 0.1 0.1 1" condim="3" priority="1" friction="0.8 0.02 0.01" solref="0.005 1"/>
    </default>
  </default>
  <worldbody>
    <body name="trunk" pos="0 0 {d.start_height:.5g}">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="{d.trunk_mass:.5g}"
                diaginertia="{d.trunk_mass * (ty**2 + tz**2) / 3:.5g} {d.trunk_mass * (tx**2 + tz**2) / 3:.5g} {d.trunk_mass * (tx**2 + ty**2) / 3:.5g}"/>
      <geom name="trunk_geom" type="box" size="{tx:.5g} {ty:.5g} {tz:.5g}" mass="0"/>
      <site name="imu" pos="0 0 0" size="0.01"/>{legs}
    </body>
  </worldbody>
  <actuator>
{acts}
  </actuator>
</mujoco>
"""


def main() -> None:
    for d in (SPOT, GO1):
        (ASSETS / f"{d.name}.xml").write_text(mjcf(d))
        print("wrote", ASSETS / f"{d.name}.xml")


if __name__ == "__main__":
    main()
