"""How often a sweep is called garbage (`localisation.scan.sweep_fault`), clean and with random readings.

Run from the repository root (about a minute)::

    .venv/bin/python docs/garbage_share.py

For each sonar model (``ideal``, ``nxt``) and sweep (a full turn at 2 degrees, the four 15-degree
tracking windows at 2 degrees), 100 simulated sweeps at random poses of each of maps 1-3; each sweep
again with every reading replaced by a random value from 0 to 255 with probability P. Prints the
largest `garbage_share` and the share of sweeps above `GARBAGE_SHARE` (called garbage).
"""

from __future__ import annotations

import numpy as np

from localisation.scan import GARBAGE_SHARE, garbage_share, sweep_angles
from toolkit.robots.sim import SimRobot
from toolkit.world import Scan, load_map

SWEEPS = {"full": sweep_angles(2.0), "windows": sweep_angles(2.0, 15.0)}
RATES = (0.0, 0.3, 0.5, 0.7, 0.9, 1.0)


def main() -> None:
    rng = np.random.default_rng(11)
    shares: dict[tuple[str, str, float], list[float]] = {}
    for sonar in ("ideal", "nxt"):
        for name in ("map1", "map2", "map3"):
            m = load_map(name)
            for _ in range(100):
                robot = SimRobot(m, m.random_pose(rng, 10.0), sonar=sonar, rng=int(rng.integers(1 << 30)))
                for kind, angles in SWEEPS.items():
                    scan = robot.ultrascan(angles)
                    for p in RATES:
                        r = scan.ranges.copy()
                        hit = rng.random(r.size) < p
                        r[hit] = rng.integers(0, 256, int(hit.sum()))
                        share = garbage_share(Scan.from_readings(scan.angles, r))
                        shares.setdefault((sonar, kind, p), []).append(share)
    print(f"| sonar | sweep | P random | sweeps | largest share | called garbage (> {GARBAGE_SHARE:g}) |")
    print("|---|---|---:|---:|---:|---:|")
    for (sonar, kind, p), v in sorted(shares.items()):
        a = np.array(v)
        print(f"| {sonar} | {kind} | {p:g} | {a.size} | {a.max():.3f} | {100 * np.mean(a > GARBAGE_SHARE):.1f} % |")


if __name__ == "__main__":
    main()
