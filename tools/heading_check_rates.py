"""How often the heading check (`localisation.heading_check`) calls a heading off, by true heading error.

Usage: ``python tools/heading_check_rates.py [--poses 60] [--seed 1]``

On each paper map, `--poses` positions at least 12 cm from the walls with a drawn heading; the belief
lies at the true position plus 1 cm of Gaussian error (a fix's) and at the drawn heading. For every
heading error (0, 10, 20, 35 degrees, either way at random) one check sweep (the three 15-degree
windows ahead and to the sides at 2 degrees, as a mission checks) is simulated with the ``nxt`` sonar at the true
pose and checked against the belief. Prints, per error, the share of checks that call the heading
off and the share that also put it within 8 degrees of the truth.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from localisation.heading_check import check_heading
from localisation.scan import sweep_angles
from toolkit.world import NxtSonar, Pose, Scan, load_map

ERRORS_DEG = (0.0, 10.0, 20.0, 35.0)
MAPS = ("map1", "map2", "map3")


def rates(poses: int, seed: int) -> dict[float, tuple[float, float, int]]:
    """Per heading error (degrees): (share called off, share called off within 8 degrees, checks)."""
    sonar = NxtSonar().simulated()
    rng = np.random.default_rng(seed)
    angles = sweep_angles(2.0, 15.0, (-90.0, 0.0, 90.0))
    out: dict[float, list[tuple[bool, bool]]] = {e: [] for e in ERRORS_DEG}
    for name in MAPS:
        m = load_map(name)
        kept = 0
        while kept < poses:
            xy = m.sample_free(1, rng=rng)[0]
            if m.wall_distance(xy) < 12.0:
                continue
            kept += 1
            heading = float(rng.uniform(-math.pi, math.pi))
            est = xy + rng.normal(0.0, 1.0, 2)
            for err in ERRORS_DEG:
                slip = math.radians(err) * float(rng.choice([-1.0, 1.0]))
                readings = sonar.measure(m.walls, xy[None, :], heading + slip + angles, rng=rng).ravel()
                check = check_heading(m, Pose(float(est[0]), float(est[1]), heading),
                                      Scan.from_readings(angles, readings), sonar)
                out[err].append((check.off, check.off and abs(check.offset_rad - slip) <= math.radians(8.0)))
    return {e: (float(np.mean([o for o, _ in r])), float(np.mean([n for _, n in r])), len(r)) for e, r in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=60, help="positions per map (default 60)")
    parser.add_argument("--seed", type=int, default=1, help="seed of every draw (default 1)")
    args = parser.parse_args()
    if args.poses < 1:
        parser.error(f"--poses must be >= 1, got {args.poses}")
    print("| heading error (deg) | called off | called off, within 8 deg | checks |")
    print("|---:|---:|---:|---:|")
    for err, (off, near, n) in rates(args.poses, args.seed).items():
        print(f"| {err:g} | {off:.1%} | {near:.1%} | {n} |")


if __name__ == "__main__":
    main()
