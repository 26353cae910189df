"""Every shipped maneuver on a robot: `python -m benchmarks.robots ROBOT [MANEUVER ...]` runs each (scaled to the
robot, planning.maneuver.scale) and prints one line per run and the success count. ROBOT is a shipped name or an
MJCF path. The suite runs a few short closed-loop checks per robot (tests/robot); this is the whole library.
"""

from __future__ import annotations

import sys
import time

from planning.maneuver import SHIPPED_LIBRARY, find_maneuver, load_maneuver
from planning.sim.run import RunOptions, run_maneuver


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    robot, names = argv[0], argv[1:] or sorted(p.stem for p in SHIPPED_LIBRARY.glob("*.yaml"))
    ok = 0
    for name in names:
        t0 = time.perf_counter()
        rep = run_maneuver(load_maneuver(find_maneuver(name)), RunOptions(robot=robot))
        ok += bool(rep["success"])
        why = "" if rep["success"] else f" ({rep.get('failure_reason')})"
        print(
            f"{name}: {'success' if rep['success'] else 'FAILED'}{why}; {rep['duration_s']:.1f} s simulated in "
            f"{time.perf_counter() - t0:.1f} s",
            flush=True,
        )
    print(f"{robot}: {ok} of {len(names)} shipped maneuvers succeed")
    return 0 if ok == len(names) else 1


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
