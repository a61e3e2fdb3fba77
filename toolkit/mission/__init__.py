"""The mission stack: localise, plan, drive with the watchdog, re-localise and re-plan, final correction.

`run_mission` runs any registered localiser and planner on any `toolkit.world.Robot` (the simulator
or a real NXT) from an unknown start pose to a target, the way the paper's system does. The mission
is a state machine (`toolkit.mission.machine.Mission`, its states listed in
`toolkit.mission.states.State`) whose decisions sit in named policies:

1. **Localise** globally by the exploration policy, `MissionConfig.global_localisation` (a
   `localisation.global_localisation.GlobalLocalisation`, the strategy the localiser benchmark measures
   too): one full sweep, the readings near the minimum reading's direction and its perpendiculars to
   the localiser; while the belief is ambiguous (the identical rooms of map3) a move toward open
   space that is collision-free from every candidate pose, and another sweep; a fix confirmed by a
   second, independent look. The mission drives those moves itself (it is the strategy's `Driver`),
   so they are counted, checked and recorded like its own.
2. **Plan** in the configuration space from the estimate with the chosen planner and the mission's
   `CollisionChecker` (with a safety margin on the robot radius when the map allows it).
3. **Drive** the path leg by leg: Turn to the waypoint from the estimate, then Move in steps with the
   collision watchdog on; the localiser predicts after every action. The `FixPolicy`
   (`toolkit.mission.fix_policy`, `MissionConfig.fix`) says how long a leg is (a short first leg after
   a global fix, where a heading error could bring the robot to a wall) and whether the robot
   re-localises where it ends (tracking: one sweep of the paper's windows, from its belief) or drives
   on because the belief's predicted spread leaves the way ahead clear; a missed waypoint is passed
   when the belief can drive on to the next one. A fix far off the prediction, or a next segment no
   longer free from the new estimate, is re-planned.
4. On a **watchdog stop** (or a move that makes no progress): Turnback, re-localise, re-plan.
5. At the **target**, the `FinalCorrectionPolicy` (`toolkit.mission.final_correction`): re-localise
   and correct (turn + move toward the target, backing up for short moves behind the robot) until the
   estimate is within `FinalConfig.goal_tolerance_cm` of the target or the corrections run out.

The robot's time (on the simulator, `toolkit.robots.sim.RobotTiming`) goes mostly to sweeps; the
report splits it into sweeping, turning the turret back, driving and turning
(`MissionReport.times`, `MissionTimes.split`), and `toolkit.bench.paper_pareto` measures what each sweep option
costs against what it buys.

Every action is recorded in a trace (action, estimate, and the true pose when a truth source is
given, `run_mission(truth=...)`: the simulator, the virtual brick's world). Nothing here raises for
an unreachable target, a target in a wall or a lost robot: the `MissionReport` says so in `status`.

Examples
--------
>>> from toolkit.robots.sim import SimRobot
>>> from toolkit.world import Pose, load_map
>>> m = load_map("map1")
>>> robot = SimRobot(m, Pose(20, 20, 1.0), rng=1)
>>> report = run_mission(robot, m, (80, 80), rng=1, truth=robot)   # doctest: +SKIP
>>> report.success, round(report.final_error_cm, 1)   # doctest: +SKIP
(True, 0.4)
"""

from __future__ import annotations

from localisation.exploration import explore_direction
from localisation.robot_options import localiser_options
from localisation.scan import sweep_angles

from .config import (
    DriveConfig,
    FinalConfig,
    FixConfig,
    LimitsConfig,
    MissionConfig,
    PlanningConfig,
    SweepConfig,
)
from .report import Action, MissionCounts, MissionPoses, MissionReport, MissionTimes, Outcome, RobotTimeSplit, TraceStep
from .runner import run_mission
from .simulated import run_sim_mission

__all__ = [
    "Action",
    "DriveConfig",
    "FinalConfig",
    "FixConfig",
    "LimitsConfig",
    "MissionConfig",
    "MissionCounts",
    "MissionPoses",
    "MissionReport",
    "MissionTimes",
    "Outcome",
    "PlanningConfig",
    "RobotTimeSplit",
    "SweepConfig",
    "TraceStep",
    "explore_direction",
    "localiser_options",
    "run_mission",
    "run_sim_mission",
    "sweep_angles",
]
