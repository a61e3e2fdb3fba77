"""The vocabulary of a recording's lines (`toolkit.recordings.format`): the format's name and version,
its error, the validation context, and the field types that check a value with the reader's messages
(naming the field and the value) before pydantic converts it.

Three kinds of error, told apart by their type: `field_error` (about the field being validated: the
message follows "field 'name'"), `line_error` (about the model being validated: the message follows
the path of a nested model, "particles: ") and `toolkit.world.typed.worded` (the whole message).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, ConfigDict, Field, ValidationInfo, model_validator
from pydantic_core import PydanticCustomError

from ..world import SONAR_MODELS, ConfigError, NxtnavError, SonarModel
from ..world.typed import Typed, worded

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Angles", "Clock", "Context", "Encoded", "Flag", "Floats", "Integer",
           "Invalid", "Line", "Matrix", "Number", "PoseList", "RecordingError", "RegularAngles", "Since3", "Text",
           "TruePose", "angles_size", "context_of", "decode_options", "encoded", "field_error", "floats_of", "got",
           "is_of", "line_error", "message", "points", "readings_agree", "since", "sonar_from_dict"]

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


# -- a sonar model in a line -------------------------------------------------------------------------

def sonar_from_dict(d: Any) -> SonarModel:
    """The sonar model a ``to_dict`` describes (``{"name": "nxt", "noise_sd": 1.0, ...}``); `ConfigError`
    says what is wrong with it."""
    if not isinstance(d, dict) or not isinstance(d.get("name"), str):
        raise ConfigError(f"a sonar model is a mapping with a 'name' and its parameters, got {d!r}")
    params = {k: v for k, v in d.items() if k != "name"}
    try:
        cls = SONAR_MODELS.get(d["name"])
    except NxtnavError as exc:  # an unknown name: the message lists the known ones
        raise ConfigError(str(exc)) from None
    known: set[str] = {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    unknown = sorted(set(params) - known)
    if unknown:
        raise ConfigError(f"sonar model {d['name']!r} has no parameter {', '.join(unknown)}")
    try:
        return cls(**params)
    except NxtnavError as exc:
        raise ConfigError(f"sonar model {d['name']!r}: {exc}") from None


def decode_options(options: dict[str, Any]) -> dict[str, Any]:
    """The inverse of `encode_options`: a ``sonar_model`` option (at any depth of the options' groups,
    ``sensor.sonar_model``) rebuilt as its model."""
    return {k: sonar_from_dict(v) if k.rpartition(".")[2] == "sonar_model" and isinstance(v, dict) else v
            for k, v in options.items()}



# -- the messages -------------------------------------------------------------------------------------

def field_error(text: str) -> PydanticCustomError:
    """An error about the field being validated: `text` follows "field 'name'" (a space between, unless
    it starts with a colon)."""
    return PydanticCustomError("field", "{text}", {"text": text})


def line_error(text: str) -> PydanticCustomError:
    """An error about the model being validated: `text` follows the path of a nested model ("particles: ")."""
    return PydanticCustomError("line", "{text}", {"text": text})


def got(value: Any) -> str:
    """A value as a message shows it: JSON (cut at 40 characters), a bool as Python writes it."""
    if isinstance(value, bool):
        return repr(value)
    try:
        return json.dumps(value)[:40]
    except (TypeError, ValueError):
        return repr(value)[:40]


def message(err: Any, tagged: bool) -> str:
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
    return f"{nest}field '{name}': {got(err.get('input'))} {text[:1].lower() + text[1:]}"


# -- field types ----------------------------------------------------------------------------------------
# Each checks its value with the reader's messages before pydantic converts it.

_NAMES = {int: "a number", float: "a number", str: "a string", list: "a list", dict: "an object", bool: "true/false"}


def is_of(types: tuple[type, ...], nullable: bool = False, what: str = "") -> Callable[[Any], Any]:
    """A check that a value is of `types` (a bool is no number), or null when `nullable`."""
    name = what or " or ".join(dict.fromkeys(_NAMES[t] for t in types))

    def check(value: Any) -> Any:
        if value is None and nullable:
            return value
        if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
            raise field_error(f"must be {name}, got {got(value)}")
        return value
    return check


def encoded(value: Any, n: int | None = None) -> list[Any]:
    """Check a list of encoded floats (of `n` values when given)."""
    if not isinstance(value, list):
        raise field_error(f"must be a list, got {got(value)}")
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float | str):
            raise field_error(f": item {i}: expected a number, got {v!r}")
        if isinstance(v, str):
            try:
                float(v)
            except ValueError as exc:
                raise field_error(f": {exc}") from None
    if n is not None and len(value) != n:
        raise field_error(f"must have {n} values, got {len(value)}")
    return value


def floats_of(n: int | None) -> Callable[[Any], Any]:
    return lambda value: encoded(value, n)


def matrix(value: Any) -> Any:
    if not (isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value)):
        if not isinstance(value, list):
            raise field_error(f"must be a list, got {got(value)}")
        raise field_error("must be a 3x3 matrix")
    for row in value:
        encoded(row, 3)
    return value


def points(size: int, what: str, least: int = 0) -> Callable[[Any], Any]:
    """A check of a list of points of `size` encoded floats each (at least `least` of them)."""
    def check(value: Any) -> Any:
        if not isinstance(value, list):
            raise field_error(f"must be a list, got {got(value)}")
        if len(value) < least or not all(isinstance(p, list) for p in value):
            raise field_error(what)
        for p in value:
            encoded(p, size)
        return value
    return check


def clock(value: Any, info: ValidationInfo) -> Any:
    """A scan's ``t_start`` or ``t``: a number, or (version 2) null."""
    return is_of((int, float), nullable=context_of(info).version >= 2)(value)


def truth(value: Any, info: ValidationInfo) -> Any:
    """A ``true_pose``: null, ``[x, y, theta]`` or (version 2) ``[x, y, null]``."""
    if value is None:
        return value
    if isinstance(value, list) and len(value) == 3 and value[2] is None:
        version = context_of(info).version
        if version < 2:
            raise field_error(f"has a null heading, which needs format version 2 (the header says {version})")
        encoded(value[:2], 2)
        return value
    return encoded(value, 3)


def context_of(info: ValidationInfo) -> Context:
    ctx = info.context
    return ctx if isinstance(ctx, Context) else Context()


NonFinite = Literal["inf", "-inf", "nan"]
Encoded = float | NonFinite
Number = Annotated[float, BeforeValidator(is_of((int, float)))]
Integer = Annotated[int, BeforeValidator(is_of((int,)))]
Text = Annotated[str, BeforeValidator(is_of((str,)))]
Flag = Annotated[bool, BeforeValidator(is_of((bool,)))]
Floats = Annotated[list[Encoded], BeforeValidator(floats_of(None))]
PoseList = Annotated[list[Encoded], BeforeValidator(floats_of(3)),
                     Field(description="[x_cm, y_cm, theta_rad]", min_length=3, max_length=3)]
Matrix = Annotated[list[list[Encoded]], BeforeValidator(matrix), Field(description="3x3 covariance")]
TruePose = Annotated[list[Encoded | None] | None, BeforeValidator(truth),
                     Field(description="[x_cm, y_cm, theta_rad]; the heading null when unknown (version 2)")]
Clock = Annotated[float | None, BeforeValidator(clock), Field(description="robot clock (s); null (version 2): none")]


class Line(Typed):
    """A recording line: its fields as the format declares them, no others."""

    model_config = ConfigDict(validate_default=False)


def since(version: int, what: str, info: ValidationInfo) -> None:
    """Refuse `what` in a recording of a format version below `version`."""
    got = context_of(info).version
    if got < version:
        raise worded(f"{what} needs format version {version} (the header says {got})")


class Since3(Line):
    """A line that needs format version 3."""

    @model_validator(mode="before")
    @classmethod
    def _version_3(cls, data: Any, info: ValidationInfo) -> Any:
        kind = data.get("type") if isinstance(data, dict) else None
        since(3, "a 'plan' event" if kind == "plan" else f"a '{kind}' line", info)
        return data


class RegularAngles(Line):
    """Angles ``i * step`` for i = 0..n-1 in float64."""

    n: int = Field(ge=2)
    step: float


def angles(value: Any) -> Any:
    if isinstance(value, dict):
        n, step = value.get("n"), value.get("step")
        if not (isinstance(n, int) and not isinstance(n, bool) and n >= 2 and isinstance(step, int | float)
                and not isinstance(step, bool)):
            raise worded("bad scan: 'angles_rad' must be a list or {\"n\": integer >= 2, \"step\": number}")
        return value
    if not isinstance(value, list):
        raise field_error(f"must be a list or an object, got {got(value)}")
    return encoded(value)


def angles_size(angles: list[Encoded] | RegularAngles) -> int:
    return angles.n if isinstance(angles, RegularAngles) else len(angles)


def readings_agree(angles: list[Encoded] | RegularAngles, ranges: list[Encoded], invalid: list[int]) -> None:
    """Check that a scan has one range per angle and that its invalid readings are among them."""
    n = angles_size(angles)
    if len(ranges) != n:
        raise line_error(f"bad scan: 'ranges_cm' has {len(ranges)} values for {n} angles")
    if not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < n for i in invalid):
        raise line_error(f"bad scan: 'invalid' must list indices 0..{n - 1}")


Angles = Annotated[list[Encoded] | RegularAngles, BeforeValidator(angles),
                   Field(description="turret angles relative to the heading (rad)")]
Invalid = Annotated[list[int], BeforeValidator(is_of((list,))), Field(description="indices of the invalid readings")]
