"""How often the heading check (`localisation.heading_check`) calls a heading off, by true heading error.

Usage: ``python tools/heading_check_rates.py [--poses 60] [--seed 1]``

On each paper map, `--poses` positions at least 12 cm from the walls with a drawn heading; the belief
lies at the true position plus 1 cm of Gaussian error (a fix's) and at the drawn heading. For every
heading error (0, 10, 20, 35 degrees, either way at random) a check is simulated as a mission makes
it, with the ``nxt`` sonar at the true pose: one sweep of the front half (-90 to +90 degrees) at 2
degrees; ``--windows`` sweeps the three 15-degree tracking windows ahead and to the sides instead
(what missions swept before). Prints, per error, the share of checks that call the heading off, the
share that also put it within 8 degrees of the truth, and the share left unsure
(`HeadingCheck.unsure`: another heading fits as well, but not by enough to call it off).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from localisation.heading_check import HeadingCheck, check_heading
from localisation.scan import sweep_angles
from toolkit.mission import MissionConfig
from toolkit.mission.config import TRACK_WINDOWS
from toolkit.world import Map, NxtSonar, Pose, Scan, load_map

ERRORS_DEG = (0.0, 10.0, 20.0, 35.0)
MAPS = ("map1", "map2", "map3")


def _check(m: Map, true: Pose, belief: Pose, angles: np.ndarray, sonar: NxtSonar,
           rng: np.random.Generator) -> HeadingCheck:
    """A check of `belief` with one sweep of `angles` simulated at `true`."""
    readings = sonar.measure(m.walls, np.array([[true.x, true.y]]), true.theta + angles, rng=rng).ravel()
    return check_heading(m, belief, Scan.from_readings(angles, readings), sonar)


def rates(poses: int, seed: int, windows: bool = False) -> dict[float, tuple[float, float, float, int]]:
    """Per heading error (degrees): (share called off, share called off within 8 degrees, share left
    unsure, checks)."""
    sonar = NxtSonar().simulated()
    rng = np.random.default_rng(seed)
    s = MissionConfig.for_sonar("nxt").sweeps
    angles = (sweep_angles(s.track_scan_step_deg, s.track_window_deg, TRACK_WINDOWS["sides"]) if windows
              else s.heading_check_angles())
    out: dict[float, list[tuple[bool, bool, bool]]] = {e: [] for e in ERRORS_DEG}
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
            belief = Pose(float(est[0]), float(est[1]), heading)
            for err in ERRORS_DEG:
                slip = math.radians(err) * float(rng.choice([-1.0, 1.0]))
                true = Pose(float(xy[0]), float(xy[1]), heading + slip)
                c = _check(m, true, belief, angles, sonar, rng)
                out[err].append((c.off, c.off and abs(c.offset_rad - slip) <= math.radians(8.0), c.unsure))
    return {e: (float(np.mean([o for o, _, _ in r])), float(np.mean([n for _, n, _ in r])),
                float(np.mean([u for _, _, u in r])), len(r)) for e, r in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=60, help="positions per map (default 60)")
    parser.add_argument("--seed", type=int, default=1, help="seed of every draw (default 1)")
    parser.add_argument("--windows", action="store_true", help="first look: the three tracking windows")
    args = parser.parse_args()
    if args.poses < 1:
        parser.error(f"--poses must be >= 1, got {args.poses}")
    print("| heading error (deg) | called off | called off, within 8 deg | unsure | checks |")
    print("|---:|---:|---:|---:|---:|")
    for err, (off, near, unsure, n) in rates(args.poses, args.seed, args.windows).items():
        print(f"| {err:g} | {off:.1%} | {near:.1%} | {unsure:.1%} | {n} |")


if __name__ == "__main__":
    main()
