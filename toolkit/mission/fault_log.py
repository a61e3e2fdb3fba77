"""The faults a mission meets, as they go into its report and its recording (`FaultNote`, `FaultLog`).

Kept apart from `toolkit.mission.recovery`, which acts on the faults, so that the report can name the
notes without importing the recovery.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..world import Resumption, TruthSource

if TYPE_CHECKING:
    from ..recordings.recorder import Recorder

__all__ = ["FaultLog", "FaultNote"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FaultNote:
    """One fault the mission met and what came of it.

    Attributes
    ----------
    kind : {"link-lost", "sonar", "motion"}
        A lost link, a sweep taken again because the sensor looked stuck or gave garbage, or a fix far
        from where the motions should have taken the robot.
    robot_time_s : float
        The robot's clock when the mission noticed it (s).
    detail : str
        What happened, in words.
    recovered : bool
        Whether the mission went on after it (the link came back and the robot was localised again;
        a sonar fault: the procedure swept again; a motion fault: the mission planned again).
    outage_s : float
        Wall-clock seconds without a link (link faults).
    recovery_robot_s : float
        Robot time spent on the recovery: the reconnection and the re-localisation after it (s).
    resumption : Resumption or None
        What the interrupted motion did, by the tachometers (link faults that came back).
    """

    kind: str
    robot_time_s: float
    detail: str
    recovered: bool = True
    outage_s: float = 0.0
    recovery_robot_s: float = 0.0
    resumption: Resumption | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "robot_time_s": self.robot_time_s, "detail": self.detail,
                "recovered": self.recovered, "outage_s": self.outage_s, "recovery_robot_s": self.recovery_robot_s,
                "resumption": None if self.resumption is None else self.resumption.to_dict()}


class FaultLog:
    """The faults of one mission: kept for the report and written to the recording (when there is one)."""

    def __init__(self, recorder: Recorder | None = None) -> None:
        self.notes: list[FaultNote] = []
        self._recorder = recorder
        self._said: set[str] = set()

    def fault(self, kind: str, robot_time_s: float, detail: str) -> None:
        """A fault as it is noticed: a ``fault`` line in the recording."""
        if self._recorder is not None:
            self._recorder.event("fault", kind=kind, t=robot_time_s, detail=detail)

    def add(self, note: FaultNote, truth: TruthSource | None = None) -> None:
        """What came of a fault: kept for the report, a ``recovery`` line in the recording (with the
        true pose from `truth`, else from the recording's own truth, when there is one)."""
        self.notes.append(note)
        if self._recorder is not None:
            self._recorder.event("recovery", **note.to_dict(), true_pose=self._recorder.true_pose(truth))

    def say_once(self, key: str, message: str) -> None:
        """Log `message` as a warning the first time `key` comes up in this mission."""
        if key not in self._said:
            self._said.add(key)
            log.warning("%s", message)
