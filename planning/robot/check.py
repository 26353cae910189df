"""`footfall robot check PATH`: what the loader detected in an MJCF, the analytic kinematics against MuJoCo's at
sampled poses, and every problem in one message."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from planning.robot.mjcf import JOINT_ROLES, LEGS, RobotDescriptionError
from planning.robot.model import RobotModel, load_robot

KINEMATICS_TOLERANCE_M = 1e-3  # the analytic feet and knees may differ from MuJoCo's by this much
KINEMATICS_SAMPLES = 200  # random poses inside the joint ranges
TUNED_ARMATURE_KGM2 = 0.04  # the swing gains are tuned on robots with at most this joint armature


def check_robot(name_or_path: str | Path) -> tuple[bool, str]:
    """Returns (ok, report text) for a robot name or file; never raises for a bad file (the report names why)."""
    try:
        robot = load_robot(name_or_path, strict=False)
    except RobotDescriptionError as e:
        return False, f"problems:\n  - {e}"
    return _report(robot)


def _report(r: RobotModel) -> tuple[bool, str]:
    import mujoco

    m = r.model
    name = lambda kind, i: mujoco.mj_id2name(m, kind, int(i)) or f"#{i}"  # noqa: E731
    out = [
        f"robot {r.name}: {r.mjcf_path}",
        f"  mass {r.mass_kg:.2f} kg, {m.nbody - 1} bodies, {m.nu} actuators",
    ]
    out += [f"  {n}" for n in r.notes]
    out.append("legs (hip abduction, hip flexion, knee):")
    for i, leg in enumerate(LEGS):
        ids = r.legs[i]
        joints = ", ".join(name(mujoco.mjtObj.mjOBJ_JOINT, j) for j in ids.joint_ids)
        acts = ", ".join(name(mujoco.mjtObj.mjOBJ_ACTUATOR, a) if a >= 0 else "-" for a in ids.actuator_ids)
        tau = "/".join(f"{t:.4g}" for t in r.tau_max[i])
        out.append(
            f"  {leg}: joints {joints}; actuators {acts} ({tau} N·m); foot geom "
            f"{name(mujoco.mjtObj.mjOBJ_GEOM, ids.foot_geom)} (r {r.leg_geometry[i].foot_radius:.3f} m)"
        )
    g = r.leg_geometry[0]
    out.append(
        f"kinematics: hip at {np.round(np.abs(r.p_body_hip[0]), 4).tolist()} m, abduction offset "
        f"{abs(r.abd_offset[0]):.4f} m, upper {r.l_upper:.4f} m, lower {r.l_lower:.4f} m, knee offset "
        f"{np.degrees(g.alpha):.2f}°, foot offset {np.degrees(g.beta):.2f}°, reach "
        f"{r.min_leg_length_m:.3f}–{r.max_leg_length_m:.3f} m"
    )
    arm = float(max(m.dof_armature[r.dof_idx].max(), 0.0))
    if arm > TUNED_ARMATURE_KGM2:
        out.append(
            f"  note: joint armature up to {arm:.3g} kg·m² (the swing controller is tuned for ≤ "
            f"{TUNED_ARMATURE_KGM2:g}; a trot may fail on it)"
        )
    problems = list(r.problems)
    if not any("standing pose" in p for p in problems):
        sx, sy = r.nominal_stance_xy
        out.append(
            f"standing ({r.standing_source}): height {r.standing_height_m:.3f} m, stance ±{sx:.3f} × ±{sy:.3f} m, "
            f"joints {np.round(r.q_nominal[0], 3).tolist()} rad"
        )
    foot_err, knee_err = r.kinematics_error(KINEMATICS_SAMPLES)
    out.append(
        f"analytic vs MuJoCo kinematics over {KINEMATICS_SAMPLES} poses: feet {foot_err * 1e3:.3g} mm, "
        f"knees {knee_err * 1e3:.3g} mm (worst)"
    )
    if foot_err > KINEMATICS_TOLERANCE_M or knee_err > KINEMATICS_TOLERANCE_M:
        problems.append(
            f"the analytic leg kinematics differ from MuJoCo's by {max(foot_err, knee_err) * 1e3:.1f} mm "
            f"(> {KINEMATICS_TOLERANCE_M * 1e3:g} mm): the legs are not {' → '.join(JOINT_ROLES)} as footfall models them"
        )
    if problems:
        out.append(f"{len(problems)} problem(s):")
        out += [f"  - {p}" for p in problems]
    else:
        out.append("ok: footfall can drive this robot")
    return not problems, "\n".join(out)
