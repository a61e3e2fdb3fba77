"""The states of a mission and how one ends (`toolkit.mission.machine.Mission` runs them)."""

from __future__ import annotations

from enum import Enum

from .report import Outcome

__all__ = ["MissionEnded", "State"]


class State(Enum):
    """Where a mission is; `toolkit.mission.machine.Mission.step` runs one state and names the next."""

    CHECK_TARGET = "check-target"
    """Is the target inside the map and clear of the walls? Then localise globally."""
    LOCALISE_GLOBAL = "localise-global"
    """Find the robot from nothing (the exploration policy, `GlobalLocalisation`); then plan."""
    PLAN = "plan"
    """A path from the estimate to the target; then drive its first waypoint."""
    DRIVE = "drive"
    """One leg toward the current waypoint: aim, move in steps; the fix policy says whether to re-localise."""
    CHECK_HEADING = "check-heading"
    """After a large turn: one sweep against the believed heading; drive on when it agrees, else
    re-localise from the heading it fits and re-plan."""
    RELOCALISE = "relocalise"
    """A fix where a leg ended; a fix far off the prediction re-plans, else the next leg."""
    RECOVER_STOP = "recover-stop"
    """After a watchdog stop or a blocked move: back off, re-localise (from a wider belief when the
    stops say it is wrong), re-plan."""
    REPLAN = "replan"
    """Count a re-plan (give up past `LimitsConfig.max_replans`), then plan."""
    FINAL_CORRECTION = "final-correction"
    """At the target: re-localise and decide (the final-correction policy): done, a correction move, or re-plan."""
    RECONNECT = "reconnect"
    """The link was lost: reach the robot again, re-localise, plan again (`toolkit.mission.recovery`)."""
    DONE = "done"
    """Ended with the target reached."""
    FAILED = "failed"
    """Ended otherwise (`MissionReport.outcome` says how)."""


class MissionEnded(Exception):
    """The mission ends with `outcome`, `status` saying it in words (raised from inside an action or a look,
    such as the action limit or a global localisation that stays lost)."""

    def __init__(self, outcome: Outcome, status: str) -> None:
        super().__init__(status)
        self.outcome = outcome
        self.status = status
