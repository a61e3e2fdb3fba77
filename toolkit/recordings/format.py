"""The lines of a recording as typed models, shared by the writer (`toolkit.recordings.recorder.Recorder`) and
the reader (`toolkit.recordings.reading.read_recording`).

A recording is a `Header` line, then event lines told apart by their ``type`` field: `Event` is the
discriminated union of `Localiser`, `Turn`, `Move`, `Turnback`, `Scan`, `Plan`, `Reset`, `Predict`,
`Update`, `Estimate`, `Fault`, `Recovery` and `End`. `check_header` and `check_event` validate one
decoded line; their errors are `RecordingError` lines naming where (the file and line), the field
and the value. What depends on more than the line itself comes through the validation context
(`Context`): the header's format version (a ``plan`` line needs version 3) and the scans read so far
(an ``update`` refers to one of them).

Floats are written as JSON numbers, the non-finite ones as ``"inf"``, ``"-inf"``, ``"nan"``
(`toolkit.recordings.recorder.encode_floats`). The models check the lines and describe them (their JSON
Schemas are in ``docs/reference/schemas/``); the file keeps the text it was written with.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, ConfigDict, Field, TypeAdapter, ValidationError, ValidationInfo, model_validator

from localisation.base import LOCALISERS

from ..world import NxtnavError
from ..world.typed import Typed, worded
from .fields import (
    FORMAT_NAME,
    FORMAT_VERSION,
    Angles,
    Clock,
    Context,
    Encoded,
    Flag,
    Floats,
    Integer,
    Invalid,
    Line,
    Matrix,
    Number,
    PoseList,
    RecordingError,
    Since3,
    Text,
    TruePose,
    angles_size,
    context_of,
    decode_options,
    encoded,
    field_error,
    floats_of,
    got,
    is_of,
    line_error,
    message,
    points,
    readings_agree,
    since,
    sonar_from_dict,
)

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Context", "End", "Estimate", "Event", "Fault", "Header", "Localiser",
           "Move", "Plan", "Predict", "RecordingError", "Recovery", "Reset", "Scan", "Turn", "Turnback", "Update",
           "check_event", "check_header", "event_schema", "header_schema"]


# -- robot events -----------------------------------------------------------------------------------------

class Odometry(Line):
    """What the robot's tachometers counted around a command (null: no tachometers, or the link lost)."""

    tacho_before: dict[str, float] | None = None
    tacho_after: dict[str, float] | None = None


class _Command(Line):
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


class Scan(Line):
    """A sweep of the sonar (a robot's, or one taken elsewhere at a known position)."""

    type: Literal["scan"]
    t: Clock
    true_pose: TruePose = None
    id: Integer
    t_start: Clock
    label: Annotated[str | None, BeforeValidator(is_of((str,)))] = None
    angles_rad: Angles
    ranges_cm: Floats
    invalid: Invalid
    times_s: Annotated[list[Encoded] | None, BeforeValidator(floats_of(None))] = None

    @property
    def size(self) -> int:
        """The number of readings."""
        return angles_size(self.angles_rad)

    @model_validator(mode="after")
    def _consistent(self) -> Scan:
        readings_agree(self.angles_rad, self.ranges_cm, self.invalid)
        if self.times_s is not None and len(self.times_s) != self.size:
            raise line_error(f"field 'times_s' must have {self.size} values, got {len(self.times_s)}")
        return self


class Plan(Since3):
    """A path the mission planned (version 3)."""

    type: Literal["plan"]
    path: Annotated[list[list[Encoded]], BeforeValidator(points(2, "must list at least two [x, y] points", 2))]


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
        raise field_error("must hold an integer 'entropy' and a 'spawn_key' list")
    return value


class Localiser(Line):
    """The localiser the mission built: its registry name, constructor options and random stream."""

    type: Literal["localiser"]
    name: Text
    options: Annotated[dict[str, Any], BeforeValidator(is_of((dict,)))] = Field(
        description="constructor keywords; a sonar_model option as its to_dict()")
    rng: Annotated[RandomStream | None, BeforeValidator(_rng)]

    @model_validator(mode="after")
    def _known(self) -> Localiser:
        if self.name not in LOCALISERS:
            raise worded(f"unknown localiser {self.name!r}; known: {', '.join(LOCALISERS.names())}")
        try:
            decode_options(self.options)
        except NxtnavError as exc:
            raise worded(f"options.sonar_model: {exc}") from None
        return self


class HeadingPriorFields(Line):
    """A heading known roughly, the position not."""

    heading_deg: float
    sd_deg: float = Field(gt=0)


class GaussianPrior(Line):
    """A Gaussian prior around a pose."""

    mean: PoseList
    cov: Matrix


def _prior(value: Any) -> Any:
    if value is None:
        return value
    if not isinstance(value, dict):
        raise field_error(f"must be an object, got {got(value)}")
    if "heading_deg" in value:
        for key in ("heading_deg", "sd_deg"):
            if key not in value:
                raise worded(f"missing field '{key}'")
            if isinstance(value[key], bool) or not isinstance(value[key], int | float):
                raise worded(f"field '{key}' must be a number, got {got(value[key])}")
        h, sd = float(value["heading_deg"]), float(value["sd_deg"])
        if not (math.isfinite(h) and math.isfinite(sd) and sd > 0.0):
            raise field_error(f": a heading prior needs a finite heading_deg and sd_deg > 0, got {h!r} and {sd!r}")
        return value
    if value.get("mean") is None:
        raise field_error("needs a 'mean'")
    if "cov" not in value:
        raise worded("missing field 'cov'")
    return value


class Reset(Line):
    """A reset of the localiser: global (prior null), around a pose, or with the heading known roughly."""

    type: Literal["reset"]
    prior: Annotated[HeadingPriorFields | GaussianPrior | None, BeforeValidator(_prior)]


class Predict(Line):
    """The localiser told of a motion."""

    type: Literal["predict"]
    turn_rad: Number
    distance_cm: Number


class Update(Line):
    """The localiser weighing a scan: indices into an earlier scan line, or readings of its own."""

    type: Literal["update"]
    scan: Integer | None = Field(None, description="the id of an earlier scan")
    index: Annotated[list[int] | None, BeforeValidator(is_of((list,), nullable=True))] = None
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
            raise worded(f"field 'scan' must be a number, got {got(sid)}")
        scans = context_of(info).scans
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
            readings_agree(self.angles_rad, self.ranges_cm, self.invalid)
        return self


class Particles(Line):
    """A thinned copy of the localiser's particle cloud (version 3)."""

    n: Integer = Field(description="the whole cloud's size")
    poses: Annotated[list[list[Encoded]], BeforeValidator(points(3, "must list [x, y, theta] triples"))]
    weights: Floats

    @model_validator(mode="after")
    def _sizes(self) -> Particles:
        if len(self.weights) != len(self.poses):
            raise line_error(f"field 'weights' must have {len(self.poses)} values, got {len(self.weights)}")
        if self.n < len(self.poses):
            raise line_error(f"field 'n' ({self.n}) is smaller than the {len(self.poses)} poses")
        return self


def _pose_not_null(value: Any) -> Any:
    if value is None:
        raise field_error("must not be null")
    return encoded(value, 3)


class Estimate(Line):
    """The localiser's estimate after each call."""

    type: Literal["estimate"]
    pose: Annotated[list[Encoded], BeforeValidator(_pose_not_null), Field(description="[x_cm, y_cm, theta_rad]")]
    cov: Matrix
    converged: Flag
    iterations: Integer
    particles: Annotated[Particles | None, BeforeValidator(is_of((dict,)))] = None

    @model_validator(mode="before")
    @classmethod
    def _cloud_since_3(cls, data: Any, info: ValidationInfo) -> Any:
        if isinstance(data, dict) and "particles" in data:
            since(3, "field 'particles'", info)
        return data


# -- faults and the end ---------------------------------------------------------------------------------------

class Fault(Since3):
    """A fault as it was noticed (version 3)."""

    type: Literal["fault"]
    kind: Text = Field(description="link-lost, sonar or motion")
    t: Number
    detail: Text


class Resumption(Line):
    """What a motion cut short by a lost link did, by the tachometers."""

    action: Text
    requested: Number
    done: Number
    tacho_before: dict[str, float] | None = None
    tacho_after: dict[str, float] | None = None


class Recovery(Since3):
    """What came of a fault (version 3)."""

    type: Literal["recovery"]
    kind: Text
    robot_time_s: Number
    detail: Text
    recovered: Flag
    outage_s: Number = Field(description="wall-clock seconds without a link")
    recovery_robot_s: Number
    resumption: Annotated[Resumption | None, BeforeValidator(is_of((dict,), nullable=True))]
    true_pose: TruePose = None


class End(Line):
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
    is_of((int,))(value)
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
    map: Annotated[dict[str, Any], BeforeValidator(is_of((dict,)))] = Field(description="the map in its file form")
    robot: Annotated[RobotInfo, BeforeValidator(is_of((dict,)))]
    sonar: Annotated[SonarInfo, BeforeValidator(is_of((dict,)))]
    seed: Annotated[int | None, BeforeValidator(is_of((int,), nullable=True))]
    versions: Annotated[dict[str, Any], BeforeValidator(is_of((dict,)))]

    @model_validator(mode="before")
    @classmethod
    def _is_header(cls, data: Any) -> Any:
        if not isinstance(data, dict) or data.get("type") != "header" or data.get("format") != FORMAT_NAME:
            raise worded(f"expected the header (type 'header', format '{FORMAT_NAME}')")
        return data


# -- checking -----------------------------------------------------------------------------------------------

def _first(exc: ValidationError, where: str, tagged: bool = True) -> RecordingError:
    return RecordingError(f"{where}: {message(exc.errors()[0], tagged)}")


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
