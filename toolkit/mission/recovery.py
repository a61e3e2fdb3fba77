"""What a mission does when its robot fails it: a lost link, a stuck or garbage sonar.

A lost link (`toolkit.world.LinkLostError`: a pulled cable, Bluetooth out of range, a brick that
stopped answering) does not end the run. The motors stop (the robot braked them, or the brick's
tacho limits did), and `Recovery.resume`:

1. reconnects with a growing pause between attempts (0.25 s doubling up to 2 s) for up to
   `Recovery.timeout_s` seconds; a link that does not come back ends the mission (`Outcome.LINK_LOST`);
2. reads the tachometers (`toolkit.world.Resumption`) to learn how much of the interrupted motion
   happened, and tells the localiser of that part;
3. re-localises around the last estimate, its spread widened by half the interrupted motion (the
   motion could have gone anywhere between not at all and all of it, should the tachos mislead), with
   the mission's tracking sweep; a re-localisation that does not converge falls back to the global
   strategy the mission starts with (`localisation.global_localisation.GlobalLocalisation`), and so
   does a link lost before the first fix;
4. goes on: the mission plans again from the new estimate (the `RECONNECT` state of
   `toolkit.mission.states.State`).

A sweep a look (`localisation.procedure.look`) takes again because the sensor looked stuck or gave garbage
(`localisation.scan.sweep_fault`) is noted too, and so is a fix that lies further from the belief
predicted through the motions than motion noise explains (`off_course`: a wheel that slipped); the
mission then plans again from the fix instead of steering back to the old path. Every fault and
recovery becomes a `FaultNote` in the report, a trace step, and a ``fault`` / ``recovery`` line of
the recording.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from localisation.base import Motion, PoseEstimate, Prior

from ..world import (
    LinkLostError,
    Reconnectable,
    Resumption,
    Robot,
    RobotError,
    angle_diff,
    ray_cast,
)
from .fault_log import FaultLog, FaultNote
from .report import Action, Outcome
from .robot_distances import BACKOFF_CM, backoff_cm, watchdog_cm
from .states import MissionEnded

if TYPE_CHECKING:
    from .context import MissionContext
    from .localising import Fixes

__all__ = ["BACKOFF_CM", "DEFAULT_RECONNECT_TIMEOUT_S", "OFF_COURSE_CM", "OFF_COURSE_DEG", "UNEXPLAINED_STOP_CM",
           "WIDE_STD_CM", "WIDE_STD_DEG", "FaultLog", "FaultNote", "Recovery", "StopCheck", "backoff_cm",
           "off_course", "watchdog_cm", "widened_prior"]

log = logging.getLogger(__name__)

DEFAULT_RECONNECT_TIMEOUT_S = 30.0
"""How long (wall-clock s) a mission tries to reach its robot again after a lost link."""
_FIRST_PAUSE_S = 0.25
_LONGEST_PAUSE_S = 2.0

OFF_COURSE_CM = 5.0
OFF_COURSE_DEG = 10.0
"""A fix further than `OFF_COURSE_CM` or `OFF_COURSE_DEG` from the belief predicted through the
motions since the last one means the robot did not move as commanded (docs/missions.md: how far
normal fixes stay inside)."""


UNEXPLAINED_STOP_CM = 10.0
"""A watchdog stop is unexplained when the map, seen from the belief, has no wall within the watchdog
distance plus this much (cm) straight ahead while the wheels stalled or a second reading hears one;
two such stops within this distance of each other mean the belief is wrong (a slipping turn can leave
the heading further off than a tracking sweep looks)."""
WIDE_STD_CM = 10.0
WIDE_STD_DEG = 45.0
"""Position and heading spreads of the prior a re-localisation starts from after two unexplained stops."""


def widened_prior(est: PoseEstimate, floor_cm: float, floor_rad: float) -> Prior:
    """`est` as a prior whose position and heading spreads are at least `floor_cm` and `floor_rad`."""
    cov = np.array(est.cov, dtype=float)
    if not np.all(np.isfinite(cov)):
        cov = np.zeros((3, 3))
    cov[0, 0] = max(cov[0, 0], floor_cm ** 2)
    cov[1, 1] = max(cov[1, 1], floor_cm ** 2)
    cov[2, 2] = max(cov[2, 2], floor_rad ** 2)
    return Prior(est.pose, cov)


class StopCheck:
    """Watches the watchdog stops of one mission for the second unexplained one in the same place: a stop
    where the map, seen from the belief, has no wall near straight ahead, and where the wheels stalled
    or a second reading straight ahead hears a wall."""

    def __init__(self) -> None:
        self._last: np.ndarray | None = None

    def __call__(self, mission: MissionContext) -> str | None:
        """Why the stop just made says the belief is wrong (see `UNEXPLAINED_STOP_CM`), or None."""
        est = mission.estimate
        if est is None:
            return None
        ahead = float(np.asarray(ray_cast(mission.map.walls, est.pose.xy, np.array([est.pose.theta])))[0])
        near = watchdog_cm(mission.robot) + UNEXPLAINED_STOP_CM
        if ahead <= near:
            self._last = None
            return None
        # one more reading straight ahead: the NXT sonar's short readings stop a move where nothing is;
        # a wall the belief does not see is heard again, a wrong reading is not
        # (wheels that stalled met something: no second reading needed)
        if not (mission.last_move is not None and mission.last_move.stalled):
            again = mission.robot.ultrascan(np.array([0.0]))
            if not (bool(again.valid[0]) and float(again.ranges[0]) <= near):
                return None
        last, self._last = self._last, est.pose.xy.copy()
        if last is None or float(np.hypot(*(last - est.pose.xy))) > UNEXPLAINED_STOP_CM:
            return None
        self._last = None
        return (f"two watchdog stops where the map shows {ahead:.0f} cm free ahead of the belief: the belief is "
                "wrong (did a wheel slip?); re-localising from a wider belief")


def off_course(predicted: PoseEstimate | None, fix: PoseEstimate) -> str | None:
    """Why `fix` lies further from `predicted` than motion noise explains (see `OFF_COURSE_CM`), in words;
    None when it does not (or there was no prediction)."""
    if predicted is None:
        return None
    d = predicted.pose.distance_to(fix.pose)
    turn = abs(math.degrees(float(angle_diff(fix.pose.theta, predicted.pose.theta))))
    if d <= OFF_COURSE_CM and turn <= OFF_COURSE_DEG:
        return None
    return (f"the fix is {d:.1f} cm and {turn:.0f} degrees from where the motions should have taken the robot "
            "(did a wheel slip?); planning again from the fix")


class _Ended(Exception):
    """Internal: the link did not come back (`Recovery.resume` turns it into the mission's end)."""


class Recovery:
    """The mission's answer to a lost link and a faulty sonar (see the module docstring).

    Parameters
    ----------
    timeout_s : float
        How long (wall-clock s) to try to reach the robot again after a lost link.
    log : FaultLog
        Where the faults go.
    sleep : callable
        Waits between attempts (`time.sleep`; tests pass their own).
    """

    def __init__(self, timeout_s: float = DEFAULT_RECONNECT_TIMEOUT_S, log: FaultLog | None = None,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if not (math.isfinite(timeout_s) and timeout_s >= 0):
            raise ValueError(f"reconnect timeout must be >= 0 s, got {timeout_s!r}")
        self.timeout_s = float(timeout_s)
        self.log = log if log is not None else FaultLog()
        self._sleep = sleep

    # -- the sonar ----------------------------------------------------------------------------------
    def sonar_fault(self, mission: MissionContext, detail: str) -> None:
        """A look sweeps again because of `detail` (its `on_sweep_fault`, global or tracking)."""
        t = float(mission.robot.robot_time_s)
        self.log.say_once(detail.split(":", 1)[0], f"the sonar looks faulty ({detail}); sweeping again")
        self.log.fault("sonar", t, detail)
        self.log.add(FaultNote("sonar", t, detail), mission.truth)
        mission.record(Action.SONAR_FAULT, note=f"{detail}; sweeping again")

    def motion_fault(self, mission: MissionContext, detail: str) -> None:
        """A fix far off the prediction (the mission's `on_motion_fault`)."""
        t = float(mission.robot.robot_time_s)
        self.log.fault("motion", t, detail)
        self.log.add(FaultNote("motion", t, detail), mission.truth)

    # -- the link -----------------------------------------------------------------------------------
    def resume_or_end(self, mission: MissionContext, fixes: Fixes, lost: LinkLostError) -> None:
        """`resume`; a link that does not come back ends the mission (`Outcome.LINK_LOST`)."""
        try:
            self.resume(mission, fixes, lost)
        except _Ended as end:
            raise MissionEnded(Outcome.LINK_LOST, str(end)) from None

    def resume(self, mission: MissionContext, fixes: Fixes, lost: LinkLostError) -> None:
        """Reconnect, account for the interrupted motion, re-localise (see the module docstring)."""
        robot = mission.robot
        t_lost = float(robot.robot_time_s)
        detail = str(lost)
        self.log.fault("link-lost", t_lost, detail)
        mission.record(Action.LINK_LOST, note=detail)
        wall0 = time.monotonic()
        try:
            back = self._reconnect(robot, detail, wall0)
        except _Ended as end:
            self.log.add(FaultNote("link-lost", t_lost, str(end), False, time.monotonic() - wall0))
            mission.record(Action.LINK_LOST, note=str(end))
            raise
        outage = time.monotonic() - wall0
        t_back = float(robot.robot_time_s)
        self._account(mission, back)
        mission.record(Action.LINK_RESTORED, note=f"after {outage:.1f} s; the interrupted {back.action or 'action'} "
                                             f"did {back.done:.2f} of {back.requested:.2f} by the tachometers")
        self._relocalise(mission, fixes, back)
        note = FaultNote("link-lost", t_lost, detail, True, outage, float(robot.robot_time_s) - t_back, back)
        self.log.add(note, mission.truth)

    def _reconnect(self, robot: Robot, detail: str, wall0: float) -> Resumption:
        """Reach the robot again within the timeout, or end the mission with one line."""
        if not isinstance(robot, Reconnectable):
            raise _Ended(f"link lost ({detail}); this robot cannot reconnect")
        reconnect = robot.reconnect
        pause = _FIRST_PAUSE_S
        last = ""
        while True:
            try:
                back = reconnect()
                if not isinstance(back, Resumption):
                    raise RobotError(f"reconnect returned {back!r}, not a Resumption")
                return back
            except LinkLostError as exc:
                last = str(exc)
            except RobotError as exc:
                raise _Ended(f"link lost ({detail}); cannot reconnect: {exc}") from None
            left = self.timeout_s - (time.monotonic() - wall0)
            if left <= 0:
                raise _Ended(f"link to the robot lost and not back within {self.timeout_s:g} s "
                             f"(last attempt: {last.split('. ')[0]})")
            self._sleep(min(pause, left))
            pause = min(2.0 * pause, _LONGEST_PAUSE_S)

    @staticmethod
    def _account(mission: MissionContext, back: Resumption) -> None:
        """Tell the localiser of the part of the interrupted motion the tachometers measured."""
        if back.action == "move" and back.done:
            mission.localiser.predict(Motion(distance_cm=back.done))
            mission.counts.path_cm += abs(back.done)
            mission.since_fix_cm += abs(back.done)
        elif back.action == "turn" and back.done:
            mission.localiser.predict(Motion(turn_rad=back.done))
        mission.estimate = mission.localiser.estimate()

    def _relocalise(self, mission: MissionContext, fixes: Fixes, back: Resumption) -> None:
        """Localise again from the estimate widened by the interrupted motion, the mission's way (tracking,
        then a wider prior, then global); globally at once when the mission had no fix yet."""
        est = mission.estimate
        if not mission.plans or est is None or not np.all(np.isfinite(est.cov)):
            fixes.localise_global()  # the link dropped before the first fix: start it again
            return
        cfg = mission.cfg.fix
        move = 0.5 * abs(back.requested) if back.action == "move" else 0.0
        turn = 0.5 * abs(back.requested) if back.action == "turn" else 0.0
        prior = widened_prior(est, cfg.tracking_std_cm + move, math.radians(cfg.tracking_std_deg) + turn)
        fixes.relocalise_from(prior, f"after the lost link, from the last estimate widened by the interrupted "
                                       f"{back.action or 'action'}")
