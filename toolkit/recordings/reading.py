"""Reading a recording for `toolkit.recordings.replay`: `read_recording` parses and checks it.

`read_recording` checks every line against the format of ``docs/recording.md`` and raises
`RecordingError` naming the file, the line and the field at fault. A recording cut short (the last
line incomplete, or no ``end`` line) is not an error: it is read up to the break and
`Recording.truncated` says where it broke.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from localisation.base import HeadingPrior

from ..world import Map, MapError, Pose, map_from_dict
from .format import FORMAT_NAME, Context, HeadingPriorFields, RecordingError, check_event, check_header
from .recorder import decode_options

__all__ = ["CALLS", "ROBOT_EVENTS", "LocaliserSpec", "Recording", "RecordingError", "heading_prior_of",
           "read_recording", "truth_of"]

CALLS = ("reset", "predict", "update")
ROBOT_EVENTS = ("turn", "move", "turnback", "scan", "recovery")


@dataclass(frozen=True)
class LocaliserSpec:
    """The localiser a recording was made with: name, constructor options and its random stream."""

    name: str
    options: dict[str, Any]
    rng: dict[str, Any] | None

    def generator(self) -> np.random.Generator | None:
        """The Generator the live localiser was built with (None when the recording does not say)."""
        if self.rng is None:
            return None
        seq = np.random.SeedSequence(self.rng["entropy"], spawn_key=tuple(self.rng["spawn_key"]))
        return np.random.Generator(np.random.PCG64(seq))


@dataclass(frozen=True, eq=False)
class Recording:
    """A parsed recording.

    Attributes
    ----------
    path : Path
    header : dict
        The header line.
    map : Map
    localiser : LocaliserSpec or None
    events : list of (line number, event dict)
        Every event after the header, in order (1-based line numbers).
    truncated : str or None
        Where and how the recording was cut short, or None for a complete one.
    """

    path: Path
    header: dict[str, Any]
    map: Map
    localiser: LocaliserSpec | None
    events: list[tuple[int, dict[str, Any]]]
    truncated: str | None = None

    @property
    def calls(self) -> int:
        """Localiser calls recorded."""
        return sum(1 for _, e in self.events if e["type"] in CALLS)


# -- reading ------------------------------------------------------------------------------------------


def truth_of(e: dict[str, Any]) -> tuple[Pose, bool] | None:
    """A checked robot event's true pose and whether its heading is known (a pose of heading 0 when not)."""
    a = e.get("true_pose")
    if a is None:
        return None
    known = a[2] is not None
    return Pose(float(a[0]), float(a[1]), float(a[2]) if known else 0.0), known


def heading_prior_of(prior: dict[str, Any], where: str) -> HeadingPrior:
    """A reset's heading prior (``{"heading_deg", "sd_deg"}``); `RecordingError` naming `where` if it is not one."""
    try:
        checked = HeadingPriorFields.model_validate(prior)
    except ValidationError:
        raise RecordingError(f"{where}: field 'prior': a heading prior needs a finite heading_deg and sd_deg > 0, "
                             f"got {prior!r}") from None
    return HeadingPrior(math.radians(checked.heading_deg), math.radians(checked.sd_deg))


def read_recording(path: str | Path) -> Recording:
    """Parse and check a recording (see the module docstring); raises `RecordingError` naming the line."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read the recording ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise RecordingError(f"{p}: not a text file (not UTF-8)") from None
    lines = text.split("\n")
    complete_last = text.endswith("\n")
    if complete_last:
        lines = lines[:-1]
    if not lines or not lines[0].strip():
        raise RecordingError(f"{p}: empty file, expected a {FORMAT_NAME} header on line 1")
    events: list[tuple[int, dict[str, Any]]] = []
    truncated: str | None = None
    header: dict[str, Any] | None = None
    context = Context()
    for i, line in enumerate(lines, start=1):
        where = f"{p} line {i}"
        last = i == len(lines)
        try:
            obj = json.loads(line)
        except json.JSONDecodeError as exc:
            if last and not complete_last and i > 1:
                truncated = f"{where}: cut short ({exc.msg} at column {exc.colno}); read up to line {i - 1}"
                break
            raise RecordingError(f"{where}: not valid JSON ({exc.msg} at column {exc.colno})") from None
        if not isinstance(obj, dict) or not isinstance(obj.get("type"), str):
            raise RecordingError(f"{where}: expected a JSON object with a string field 'type'")
        if i == 1:
            header = obj
            context = Context(check_header(obj, where).version)
            continue
        if obj["type"] == "header":
            raise RecordingError(f"{where}: a second header")
        check_event(obj, where, context)
        events.append((i, obj))
        if obj["type"] == "end" and not last:
            raise RecordingError(f"{p} line {i + 1}: lines after the 'end' line")
    assert header is not None
    if truncated is None and not (events and events[-1][1]["type"] == "end"):
        truncated = f"{p} line {len(lines)}: the recording stops without an 'end' line (cut short)"
    try:
        m = map_from_dict(header["map"], source=p)
    except MapError as exc:
        raise RecordingError(f"{p} line 1: field 'map': {exc}") from None
    specs = [LocaliserSpec(e["name"], decode_options(e["options"]), e["rng"]) for _, e in events
             if e["type"] == "localiser"]
    return Recording(p, header, m, specs[0] if specs else None, events, truncated)
