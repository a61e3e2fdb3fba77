"""The mission stack: localise, plan, drive with the watchdog, re-localise and re-plan, final correction.

`run_mission` runs any registered localiser and planner on any `toolkit.world.Robot` (the simulator
or a real NXT) from an unknown start pose to a target, the way the paper's system does:

1. **Localise** globally by the strategy the localiser benchmark measures too
   (`localisation.global_localisation.GlobalLocalisation`, built by `MissionConfig.global_strategy`):
   by default one full sweep at 2-degree steps whose readings near the minimum reading's direction
   and its perpendiculars go to the localiser (the paper's processing without the turn and the second
   sweep; `MissionConfig.global_align` restores them). While the belief is ambiguous (the identical
   rooms of map3) the robot drives toward open space along a move that is collision-free from
   every candidate pose the localiser reports, and sweeps again. A fix is confirmed by a second,
   independent look. The mission drives those moves itself (it is the strategy's `Driver`), so they
   are counted, checked and recorded like its own.
2. **Plan** in the configuration space from the estimate with the chosen planner and the shared FCL
   `CollisionChecker` (with a safety margin on the robot radius when the map allows it).
3. **Drive** the path segment by segment: Turn to the segment heading (from the estimate), then Move in
   steps with the collision watchdog on; the localiser predicts after every action, so the belief
   is tracked through the motion. Legs end at each waypoint, after a short first leg following a
   global fix, where a heading error of a few degrees could bring the robot to a wall, and every
   `relocalise_every_cm` when set. Where a leg ends the robot re-localises (tracking: one sweep of
   the paper's windows ahead and to the sides, from its belief) only when the belief's predicted
   spread would not leave the way ahead clear of the walls (`MissionConfig.fix_rule`); a missed
   waypoint is skipped when the belief can drive on to the next one. A next segment that is no longer free
   from the new estimate is re-planned.
4. On a **watchdog stop** (or a move that makes no progress): Turnback, re-localise, re-plan.
5. At the **target**: re-localise and correct (turn + move toward the target from the estimate, backing
   up for short moves behind the robot) until the estimate is within
   `MissionConfig.goal_tolerance_cm` of the target or the retry limit is hit.

The robot's time (on the simulator, `toolkit.robots.sim.RobotTiming`) goes mostly to sweeps; the
report splits it into sweeping, turning the turret back, driving and turning
(`MissionReport.time_split`), and `toolkit.bench.paper_pareto` measures what each sweep option
costs against what it buys.

Every action is recorded in a trace (action, estimate, and the true pose when the robot exposes one,
as `SimRobot` does). Nothing here raises for an unreachable target, a target in a wall or a lost
robot: the `MissionReport` says so in `status`.

Examples
--------
>>> from toolkit.robots.sim import SimRobot
>>> from toolkit.world import Pose, load_map
>>> m = load_map("map1")
>>> robot = SimRobot(m, Pose(20, 20, 1.0), rng=1)
>>> report = run_mission(robot, m, (80, 80), rng=1)   # doctest: +SKIP
>>> report.success, round(report.final_error_cm, 1)   # doctest: +SKIP
(True, 0.4)
"""

from __future__ import annotations

from localisation.exploration import explore_direction
from localisation.robot_options import localiser_options
from localisation.scan import sweep_angles

from .config import MissionConfig
from .report import Action, MissionReport, Outcome, RobotTimeSplit, TraceStep
from .runner import run_mission
from .simulated import run_sim_mission

__all__ = [
    "Action",
    "MissionConfig",
    "MissionReport",
    "Outcome",
    "RobotTimeSplit",
    "TraceStep",
    "explore_direction",
    "localiser_options",
    "run_mission",
    "run_sim_mission",
    "sweep_angles",
]
