"""The lines of a recording as typed models, shared by the writer (`toolkit.recording.Recorder`) and
the reader (`toolkit.replay_reading.read_recording`).

A recording is a `Header` line, then event lines told apart by their ``type`` field: `Event` is the
discriminated union of `Localiser`, `Turn`, `Move`, `Turnback`, `Scan`, `Plan`, `Reset`, `Predict`,
`Update`, `Estimate`, `Fault`, `Recovery` and `End`. `check_header` and `check_event` validate one
decoded line; their errors are `RecordingError` lines naming where (the file and line), the field
and the value. What depends on more than the line itself comes through the validation context
(`Context`): the header's format version (a ``plan`` line needs version 3) and the scans read so far
(an ``update`` refers to one of them).

Floats are written as JSON numbers, the non-finite ones as ``"inf"``, ``"-inf"``, ``"nan"``
(`toolkit.recording.encode_floats`). The models check the lines and describe them (their JSON
Schemas are in ``docs/reference/schemas/``); the file keeps the text it was written with.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, ConfigDict, Field, TypeAdapter, ValidationError, ValidationInfo, model_validator
from pydantic_core import PydanticCustomError

from .world import NxtnavError
from .world.typed import Typed, worded

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Context", "End", "Estimate", "Event", "Fault", "Header", "Localiser",
           "Move", "Plan", "Predict", "RecordingError", "Recovery", "Reset", "Scan", "Turn", "Turnback", "Update",
           "check_event", "check_header", "event_schema", "header_schema"]

FORMAT_NAME = "nxtnav-recording"
FORMAT_VERSION = 3
"""Version 2 adds to version 1: a ``true_pose`` whose heading is null (the position is known, the
heading is not), scans whose ``t_start`` and ``t`` are null (no robot clock) and a scan's ``label``.
Version 3 adds the ``plan`` event, an estimate's optional ``particles``, the ``fault`` and ``recovery``
events (a lost link, a sonar swept again) and an ``odometry`` whose ``tacho_after`` is null (the link
broke right after the command). Readers read every version up to theirs and refuse later ones by
their version."""


class RecordingError(NxtnavError):
    """A recording that does not follow the format (the message names the file and the line)."""


@dataclass
class Context:
    """What validating one line needs from the lines before it: the header's `version` and the
    number of readings of each scan read so far, by id (`scans`)."""

    version: int = FORMAT_VERSION
    scans: dict[int, int] = field(default_factory=dict)


# -- the messages -------------------------------------------------------------------------------------
# Three kinds of error, told apart by their type: "field" (about the field being validated: the
# message follows "field 'name'"), "line" (about the model being validated: the message follows the
# path of a nested model, "particles: ") and `toolkit.world.typed.worded` (the whole message).

def _field_error(text: str) -> PydanticCustomError:
    return PydanticCustomError("field", "{text}", {"text": text})


def _line_error(text: str) -> PydanticCustomError:
    return PydanticCustomError("line", "{text}", {"text": text})


def _got(value: Any) -> str:
    if isinstance(value, bool):
        return repr(value)
    try:
        return json.dumps(value)[:40]
    except (TypeError, ValueError):
        return repr(value)[:40]


def _message(err: Any, tagged: bool) -> str:
    """One pydantic error of a recording line as the reader's message (without the place); `tagged`:
    the error's path starts with the event's ``type`` (the member of the union)."""
    loc = [str(p) for p in err.get("loc", ())]
    if not tagged:
        loc = ["", *loc]
    kind = err.get("type")
    text = str((err.get("ctx") or {}).get("text", err.get("msg", "invalid")))
    if kind == "union_tag_invalid":
        return f"unknown event type {(err.get('ctx') or {}).get('tag')!r}"
    if kind == "worded":
        return text
    nest = "".join(f"{p}: " for p in (loc[1:] if kind == "line" else loc[1:-1]))
    name = loc[-1] if loc else "?"
    if kind == "line":
        return nest + text
    if kind == "missing":
        return f"{nest}missing field '{name}'"
    if kind == "extra_forbidden":
        return f"{nest}unknown field '{name}'"
    if kind == "field":
        return f"{nest}field '{name}'{text if text.startswith(':') else ' ' + text}"
    return f"{nest}field '{name}': {_got(err.get('input'))} {text[:1].lower() + text[1:]}"


# -- field types ----------------------------------------------------------------------------------------
# Each checks its value with the reader's messages before pydantic converts it.

_NAMES = {int: "a number", float: "a number", str: "a string", list: "a list", dict: "an object", bool: "true/false"}


def _is(types: tuple[type, ...], nullable: bool = False, what: str = "") -> Callable[[Any], Any]:
    """A check that a value is of `types` (a bool is no number), or null when `nullable`."""
    name = what or " or ".join(dict.fromkeys(_NAMES[t] for t in types))

    def check(value: Any) -> Any:
        if value is None and nullable:
            return value
        if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
            raise _field_error(f"must be {name}, got {_got(value)}")
        return value
    return check


def _encoded(value: Any, n: int | None = None) -> list[Any]:
    """Check a list of encoded floats (of `n` values when given)."""
    if not isinstance(value, list):
        raise _field_error(f"must be a list, got {_got(value)}")
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float | str):
            raise _field_error(f": item {i}: expected a number, got {v!r}")
        if isinstance(v, str):
            try:
                float(v)
            except ValueError as exc:
                raise _field_error(f": {exc}") from None
    if n is not None and len(value) != n:
        raise _field_error(f"must have {n} values, got {len(value)}")
    return value


def _floats_of(n: int | None) -> Callable[[Any], Any]:
    return lambda value: _encoded(value, n)


def _matrix(value: Any) -> Any:
    if not (isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value)):
        if not isinstance(value, list):
            raise _field_error(f"must be a list, got {_got(value)}")
        raise _field_error("must be a 3x3 matrix")
    for row in value:
        _encoded(row, 3)
    return value


def _points(size: int, what: str, least: int = 0) -> Callable[[Any], Any]:
    """A check of a list of points of `size` encoded floats each (at least `least` of them)."""
    def check(value: Any) -> Any:
        if not isinstance(value, list):
            raise _field_error(f"must be a list, got {_got(value)}")
        if len(value) < least or not all(isinstance(p, list) for p in value):
            raise _field_error(what)
        for p in value:
            _encoded(p, size)
        return value
    return check


def _clock(value: Any, info: ValidationInfo) -> Any:
    """A scan's ``t_start`` or ``t``: a number, or (version 2) null."""
    return _is((int, float), nullable=_context(info).version >= 2)(value)


def _truth(value: Any, info: ValidationInfo) -> Any:
    """A ``true_pose``: null, ``[x, y, theta]`` or (version 2) ``[x, y, null]``."""
    if value is None:
        return value
    if isinstance(value, list) and len(value) == 3 and value[2] is None:
        version = _context(info).version
        if version < 2:
            raise _field_error(f"has a null heading, which needs format version 2 (the header says {version})")
        _encoded(value[:2], 2)
        return value
    return _encoded(value, 3)


def _context(info: ValidationInfo) -> Context:
    ctx = info.context
    return ctx if isinstance(ctx, Context) else Context()


NonFinite = Literal["inf", "-inf", "nan"]
Encoded = float | NonFinite
Number = Annotated[float, BeforeValidator(_is((int, float)))]
Integer = Annotated[int, BeforeValidator(_is((int,)))]
Text = Annotated[str, BeforeValidator(_is((str,)))]
Flag = Annotated[bool, BeforeValidator(_is((bool,)))]
Floats = Annotated[list[Encoded], BeforeValidator(_floats_of(None))]
PoseList = Annotated[list[Encoded], BeforeValidator(_floats_of(3)),
                     Field(description="[x_cm, y_cm, theta_rad]", min_length=3, max_length=3)]
Matrix = Annotated[list[list[Encoded]], BeforeValidator(_matrix), Field(description="3x3 covariance")]
TruePose = Annotated[list[Encoded | None] | None, BeforeValidator(_truth),
                     Field(description="[x_cm, y_cm, theta_rad]; the heading null when unknown (version 2)")]
Clock = Annotated[float | None, BeforeValidator(_clock), Field(description="robot clock (s); null (version 2): none")]


class _Line(Typed):
    """A recording line: its fields as the format declares them, no others."""

    model_config = ConfigDict(validate_default=False)


def _since(version: int, what: str, info: ValidationInfo) -> None:
    """Refuse `what` in a recording of a format version below `version`."""
    got = _context(info).version
    if got < version:
        raise worded(f"{what} needs format version {version} (the header says {got})")


class _Since3(_Line):
    """A line that needs format version 3."""

    @model_validator(mode="before")
    @classmethod
    def _version_3(cls, data: Any, info: ValidationInfo) -> Any:
        kind = data.get("type") if isinstance(data, dict) else None
        _since(3, "a 'plan' event" if kind == "plan" else f"a '{kind}' line", info)
        return data


# -- robot events -----------------------------------------------------------------------------------------

class Odometry(_Line):
    """What the robot's tachometers counted around a command (null: no tachometers, or the link lost)."""

    tacho_before: dict[str, float] | None = None
    tacho_after: dict[str, float] | None = None


class _Command(_Line):
    t: Number = Field(description="robot clock after the command (s)")
    true_pose: TruePose = None
    odometry: Odometry | None = None


class Turn(_Command):
    """A turn on the spot (after it was carried out)."""

    type: Literal["turn"]
    angle_rad: Number = Field(description="commanded (rad, counter-clockwise)")


class Move(_Command):
    """A straight move (after it was carried out)."""

    type: Literal["move"]
    requested_cm: Number
    driven_cm: Number = Field(description="what the robot measured (cm)")
    watchdog: Flag


class Turnback(Move):
    """The robot backing out of a collision."""

    type: Literal["turnback"]  # type: ignore[assignment]


class RegularAngles(_Line):
    """Angles ``i * step`` for i = 0..n-1 in float64."""

    n: int = Field(ge=2)
    step: float


def _angles(value: Any) -> Any:
    if isinstance(value, dict):
        n, step = value.get("n"), value.get("step")
        if not (isinstance(n, int) and not isinstance(n, bool) and n >= 2 and isinstance(step, int | float)
                and not isinstance(step, bool)):
            raise worded("bad scan: 'angles_rad' must be a list or {\"n\": integer >= 2, \"step\": number}")
        return value
    if not isinstance(value, list):
        raise _field_error(f"must be a list or an object, got {_got(value)}")
    return _encoded(value)


def _angles_size(angles: list[Encoded] | RegularAngles) -> int:
    return angles.n if isinstance(angles, RegularAngles) else len(angles)


def _readings_agree(angles: list[Encoded] | RegularAngles, ranges: list[Encoded], invalid: list[int]) -> None:
    """Check that a scan has one range per angle and that its invalid readings are among them."""
    n = _angles_size(angles)
    if len(ranges) != n:
        raise _line_error(f"bad scan: 'ranges_cm' has {len(ranges)} values for {n} angles")
    if not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < n for i in invalid):
        raise _line_error(f"bad scan: 'invalid' must list indices 0..{n - 1}")


Angles = Annotated[list[Encoded] | RegularAngles, BeforeValidator(_angles),
                   Field(description="turret angles relative to the heading (rad)")]
Invalid = Annotated[list[int], BeforeValidator(_is((list,))), Field(description="indices of the invalid readings")]


class Scan(_Line):
    """A sweep of the sonar (a robot's, or one taken elsewhere at a known position)."""

    type: Literal["scan"]
    t: Clock
    true_pose: TruePose = None
    id: Integer
    t_start: Clock
    label: Annotated[str | None, BeforeValidator(_is((str,)))] = None
    angles_rad: Angles
    ranges_cm: Floats
    invalid: Invalid
    times_s: Annotated[list[Encoded] | None, BeforeValidator(_floats_of(None))] = None

    @property
    def size(self) -> int:
        """The number of readings."""
        return _angles_size(self.angles_rad)

    @model_validator(mode="after")
    def _consistent(self) -> Scan:
        _readings_agree(self.angles_rad, self.ranges_cm, self.invalid)
        if self.times_s is not None and len(self.times_s) != self.size:
            raise _line_error(f"field 'times_s' must have {self.size} values, got {len(self.times_s)}")
        return self


class Plan(_Since3):
    """A path the mission planned (version 3)."""

    type: Literal["plan"]
    path: Annotated[list[list[Encoded]], BeforeValidator(_points(2, "must list at least two [x, y] points", 2))]


# -- localiser calls -----------------------------------------------------------------------------------------

class RandomStream(Typed):
    """A numpy Generator's seed sequence."""

    model_config = ConfigDict(extra="allow")

    bit_generator: str = "PCG64"
    entropy: int | list[int]
    spawn_key: list[Annotated[int, Field(ge=0)]]


def _rng(value: Any) -> Any:
    if value is None:
        return value
    ent, key = (value.get("entropy"), value.get("spawn_key")) if isinstance(value, dict) else (None, None)
    if not (isinstance(ent, int) or (isinstance(ent, list) and all(isinstance(x, int) for x in ent))) \
            or not (isinstance(key, list) and all(isinstance(x, int) and x >= 0 for x in key)):
        raise _field_error("must hold an integer 'entropy' and a 'spawn_key' list")
    return value


class Localiser(_Line):
    """The localiser the mission built: its registry name, constructor options and random stream."""

    type: Literal["localiser"]
    name: Text
    options: Annotated[dict[str, Any], BeforeValidator(_is((dict,)))] = Field(
        description="constructor keywords; a sonar_model option as its to_dict()")
    rng: Annotated[RandomStream | None, BeforeValidator(_rng)]

    @model_validator(mode="after")
    def _known(self) -> Localiser:
        from localisation.base import LOCALISERS

        from .recording import decode_options

        if self.name not in LOCALISERS:
            raise worded(f"unknown localiser {self.name!r}; known: {', '.join(LOCALISERS.names())}")
        try:
            decode_options(self.options)
        except NxtnavError as exc:
            raise worded(f"options.sonar_model: {exc}") from None
        return self


class HeadingPriorFields(_Line):
    """A heading known roughly, the position not."""

    heading_deg: float
    sd_deg: float = Field(gt=0)


class GaussianPrior(_Line):
    """A Gaussian prior around a pose."""

    mean: PoseList
    cov: Matrix


def _prior(value: Any) -> Any:
    if value is None:
        return value
    if not isinstance(value, dict):
        raise _field_error(f"must be an object, got {_got(value)}")
    if "heading_deg" in value:
        for key in ("heading_deg", "sd_deg"):
            if key not in value:
                raise worded(f"missing field '{key}'")
            if isinstance(value[key], bool) or not isinstance(value[key], int | float):
                raise worded(f"field '{key}' must be a number, got {_got(value[key])}")
        h, sd = float(value["heading_deg"]), float(value["sd_deg"])
        if not (math.isfinite(h) and math.isfinite(sd) and sd > 0.0):
            raise _field_error(f": a heading prior needs a finite heading_deg and sd_deg > 0, got {h!r} and {sd!r}")
        return value
    if value.get("mean") is None:
        raise _field_error("needs a 'mean'")
    if "cov" not in value:
        raise worded("missing field 'cov'")
    return value


class Reset(_Line):
    """A reset of the localiser: global (prior null), around a pose, or with the heading known roughly."""

    type: Literal["reset"]
    prior: Annotated[HeadingPriorFields | GaussianPrior | None, BeforeValidator(_prior)]


class Predict(_Line):
    """The localiser told of a motion."""

    type: Literal["predict"]
    turn_rad: Number
    distance_cm: Number


class Update(_Line):
    """The localiser weighing a scan: indices into an earlier scan line, or readings of its own."""

    type: Literal["update"]
    scan: Integer | None = Field(None, description="the id of an earlier scan")
    index: Annotated[list[int] | None, BeforeValidator(_is((list,), nullable=True))] = None
    angles_rad: Angles | None = None
    ranges_cm: Floats | None = None
    invalid: Invalid | None = None

    @model_validator(mode="before")
    @classmethod
    def _either(cls, data: Any, info: ValidationInfo) -> Any:
        if not isinstance(data, dict):
            return data
        if "scan" not in data:
            for key in ("angles_rad", "ranges_cm", "invalid"):
                if key not in data:
                    raise worded(f"missing field '{key}'")
                if data[key] is None:
                    raise worded(f"field '{key}' must be a list, got null")
            return data
        sid = data["scan"]
        if isinstance(sid, bool) or not isinstance(sid, int):
            raise worded(f"field 'scan' must be a number, got {_got(sid)}")
        scans = _context(info).scans
        if sid not in scans:
            raise worded(f"update refers to scan {sid}, which no earlier line holds")
        if "index" not in data:
            raise worded("missing field 'index'")
        idx = data["index"]
        if not (isinstance(idx, list) and all(isinstance(i, int) and not isinstance(i, bool)
                                              and 0 <= i < scans[sid] for i in idx)):
            raise worded(f"field 'index' must hold indices of scan {sid} (0..{scans[sid] - 1})")
        return data

    @model_validator(mode="after")
    def _consistent(self) -> Update:
        if self.scan is None and self.angles_rad is not None and self.ranges_cm is not None \
                and self.invalid is not None:
            _readings_agree(self.angles_rad, self.ranges_cm, self.invalid)
        return self


class Particles(_Line):
    """A thinned copy of the localiser's particle cloud (version 3)."""

    n: Integer = Field(description="the whole cloud's size")
    poses: Annotated[list[list[Encoded]], BeforeValidator(_points(3, "must list [x, y, theta] triples"))]
    weights: Floats

    @model_validator(mode="after")
    def _sizes(self) -> Particles:
        if len(self.weights) != len(self.poses):
            raise _line_error(f"field 'weights' must have {len(self.poses)} values, got {len(self.weights)}")
        if self.n < len(self.poses):
            raise _line_error(f"field 'n' ({self.n}) is smaller than the {len(self.poses)} poses")
        return self


def _pose_not_null(value: Any) -> Any:
    if value is None:
        raise _field_error("must not be null")
    return _encoded(value, 3)


class Estimate(_Line):
    """The localiser's estimate after each call."""

    type: Literal["estimate"]
    pose: Annotated[list[Encoded], BeforeValidator(_pose_not_null), Field(description="[x_cm, y_cm, theta_rad]")]
    cov: Matrix
    converged: Flag
    iterations: Integer
    particles: Annotated[Particles | None, BeforeValidator(_is((dict,)))] = None

    @model_validator(mode="before")
    @classmethod
    def _cloud_since_3(cls, data: Any, info: ValidationInfo) -> Any:
        if isinstance(data, dict) and "particles" in data:
            _since(3, "field 'particles'", info)
        return data


# -- faults and the end ---------------------------------------------------------------------------------------

class Fault(_Since3):
    """A fault as it was noticed (version 3)."""

    type: Literal["fault"]
    kind: Text = Field(description="link-lost, sonar or motion")
    t: Number
    detail: Text


class Resumption(_Line):
    """What a motion cut short by a lost link did, by the tachometers."""

    action: Text
    requested: Number
    done: Number
    tacho_before: dict[str, float] | None = None
    tacho_after: dict[str, float] | None = None


class Recovery(_Since3):
    """What came of a fault (version 3)."""

    type: Literal["recovery"]
    kind: Text
    robot_time_s: Number
    detail: Text
    recovered: Flag
    outage_s: Number = Field(description="wall-clock seconds without a link")
    recovery_robot_s: Number
    resumption: Annotated[Resumption | None, BeforeValidator(_is((dict,), nullable=True))]
    true_pose: TruePose = None


class End(_Line):
    """The run ended (absent when it broke off)."""

    type: Literal["end"]
    status: str | None = None
    success: bool | None = None


Event = Annotated[Localiser | Turn | Move | Turnback | Scan | Plan | Reset | Predict | Update | Estimate | Fault
                  | Recovery | End, Field(discriminator="type")]
"""One event line: the member of the union its ``type`` names."""

_EVENTS: TypeAdapter[Any] = TypeAdapter(Event)


# -- the header -----------------------------------------------------------------------------------------------

class RobotInfo(Typed):
    """What the header says of the robot: its ``kind`` and anything else."""

    model_config = ConfigDict(extra="allow")
    kind: Text = Field(description="sim, nxt or ros")


def _sonar_params(value: Any) -> Any:
    from .recording import sonar_from_dict

    try:
        sonar_from_dict(value)
    except NxtnavError as exc:
        raise worded(f"sonar.params: {exc}") from None
    return value


class SonarInfo(Typed):
    """The header's sonar: its ``model`` and, when known, the model's parameters."""

    model_config = ConfigDict(extra="allow", validate_default=False)
    model: Text = Field(description="ideal, nxt, real or laser")
    params: Annotated[dict[str, Any] | None, BeforeValidator(_sonar_params)] = None


def _version(value: Any) -> Any:
    _is((int,))(value)
    if value > FORMAT_VERSION or value < 1:
        raise worded(f"format version {value} is not supported (this nxtnav reads {FORMAT_NAME} versions 1 "
                          f"to {FORMAT_VERSION})")
    return value


class Header(Typed):
    """A recording's first line (more fields, such as ``noise`` and ``source``, are kept as they are)."""

    model_config = ConfigDict(extra="allow")
    type: Literal["header"]
    format: Literal["nxtnav-recording"]
    version: Annotated[int, BeforeValidator(_version)]
    created: str | None = None
    map: Annotated[dict[str, Any], BeforeValidator(_is((dict,)))] = Field(description="the map in its file form")
    robot: Annotated[RobotInfo, BeforeValidator(_is((dict,)))]
    sonar: Annotated[SonarInfo, BeforeValidator(_is((dict,)))]
    seed: Annotated[int | None, BeforeValidator(_is((int,), nullable=True))]
    versions: Annotated[dict[str, Any], BeforeValidator(_is((dict,)))]

    @model_validator(mode="before")
    @classmethod
    def _is_header(cls, data: Any) -> Any:
        if not isinstance(data, dict) or data.get("type") != "header" or data.get("format") != FORMAT_NAME:
            raise worded(f"expected the header (type 'header', format '{FORMAT_NAME}')")
        return data


# -- checking -----------------------------------------------------------------------------------------------

def _first(exc: ValidationError, where: str, tagged: bool = True) -> RecordingError:
    return RecordingError(f"{where}: {_message(exc.errors()[0], tagged)}")


def check_header(obj: Any, where: str) -> Header:
    """The header line `obj` as a `Header`; `RecordingError` naming `where` when it is not one."""
    try:
        return Header.model_validate(obj)
    except ValidationError as exc:
        raise _first(exc, where, tagged=False) from None


def check_event(obj: Any, where: str, context: Context) -> Any:
    """The event line `obj` as its `Event` model, checked in `context` (a scan line adds its size to
    ``context.scans``); `RecordingError` naming `where`, the field and the value when it breaks the format."""
    try:
        event = _EVENTS.validate_python(obj, context=context)
    except ValidationError as exc:
        raise _first(exc, where) from None
    if isinstance(event, Scan):
        context.scans[event.id] = event.size
    return event


def event_schema() -> dict[str, Any]:
    """The JSON Schema of an event line."""
    return _EVENTS.json_schema()


def header_schema() -> dict[str, Any]:
    """The JSON Schema of the header line."""
    return Header.model_json_schema()
