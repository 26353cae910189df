"""Closed loop in MuJoCo with the depth sensor: the regions pipeline's body path over stepping stones, as a rate.

The stones quick spec's draws (sweeps/family-stones-quick.yaml) walked for their first 4 s with the sensor: the
pit slot between a left and a right stone shows the stones' top edges 0.3 m above the pit floor, which the body
band measured from the slot's own ground made a body obstacle, and the body path swerved 0.3-0.6 m aside around it
(then walked the feet off the stones). With the band also measured from the ground the robot stands on
(MapParams.band_from_support) the path stays on the line. Measured 4 of 4 within 0.003 m; main at 270539c without it: 0 of 4 (0.51-0.72 m off the line). About 15 s CPU.
The claim is a rate, >= 3 of 4, so a last-bit difference between machines cannot flip it.
"""

from __future__ import annotations

import numpy as np
import pytest

from planning.sim.run import RunOptions, WalkCommand, WalkSession
from planning.terrain.spec import load_terrain

# (terrain, seed): draws 3, 2, 1 and 8 of the quick spec (gaps 0.15-0.30 m, tops jittered 1.4-2.8 cm)
DRAWS = [
    ("stones:gap_m=0.15..0.2,stone_depth_m=0.25..0.35,stone_width_m=0.4..0.5,jitter_z_m=0.0137", 506),
    ("stones:gap_m=0.25..0.3,stone_depth_m=0.3..0.4,stone_width_m=0.4..0.5,jitter_z_m=0.0222", 169),
    ("stones:gap_m=0.2..0.25,stone_depth_m=0.35..0.45,stone_width_m=0.4..0.5,jitter_z_m=0.0219", 813),
    ("stones:gap_m=0.15..0.2,stone_depth_m=0.35..0.45,stone_width_m=0.35..0.45,jitter_z_m=0.0281", 160),
]


@pytest.mark.sim
def test_the_body_path_over_stones_stays_on_the_line_with_the_sensor_at_a_rate() -> None:
    straight = []
    for terrain, seed in DRAWS:
        scene = load_terrain(terrain, seed=seed)
        cmd = WalkCommand(goal=scene.goal_xy)
        sess = WalkSession(cmd, RunOptions(terrain=terrain, seed=seed, duration_s=4.0))
        worst = [0.0]

        y_goal = float(scene.goal_xy[1])

        def watch(
            _s: object, sess: WalkSession = sess, worst: list[float] = worst, y0: float = y_goal
        ) -> None:
            path = sess.pipeline.path
            if path is not None:
                worst[0] = max(worst[0], float(np.max(np.abs(path.xy[:, 1] - y0))))

        sess.loop.monitors.append(watch)
        r = sess.run()
        assert r["navigator"]["pipeline"] == "regions" and r["navigator"]["body_paths"] > 0
        straight.append(worst[0] <= 0.10)
        print(f"{terrain} seed {seed}: body path at most {worst[0]:.3f} m off the line")
    assert sum(straight) >= 3, list(zip(DRAWS, straight, strict=True))
