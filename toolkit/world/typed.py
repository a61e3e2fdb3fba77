"""Typed options and files: one pydantic model declares a thing's fields, types, ranges, units and
descriptions once; construction, validation, ``--set`` overrides, help tables and JSON Schemas all come
from it.

Why pydantic v2 (and not attrs with cattrs): it is already installed with the command line (typer
needs it), it validates with per-field constraints (``ge``, ``le``, ``Literal``), reports every error
with the path of the field that failed, nests models, tells the members of a union apart by a tag
(discriminated unions, for the events of a recording) and writes a JSON Schema of any model.

Every model of the toolkit derives from `Typed` (frozen, unknown fields refused). `build` turns a
mapping into a model and a pydantic error into one `ConfigError` line naming where (a file, an option),
the field's dotted path and the value. `with_sets` applies ``section.key=value`` overrides (values read
as YAML) to a model, nested groups included.

>>> from pydantic import Field
>>> class Motion(Typed):
...     sd_cm: float = Field(1.0, ge=0, description="drive noise", json_schema_extra={"unit": "cm"})
>>> class Robot(Typed):
...     radius_cm: float = Field(10.0, gt=0)
...     motion: Motion = Motion()
>>> with_sets(Robot(), {"motion.sd_cm": "2.5"}).motion.sd_cm
2.5
>>> build(Robot, {"radius_cm": -1}, "robot.yaml")
Traceback (most recent call last):
...
toolkit.world.errors.ConfigError: robot.yaml: radius_cm: -1 must be greater than 0
>>> with_sets(Robot(), {"motion.speed": "3"})
Traceback (most recent call last):
...
toolkit.world.errors.ConfigError: --set: no option 'motion.speed'; motion has: sd_cm
>>> [(name, f.annotation.__name__) for name, f in fields_of(Robot)]
[('radius_cm', 'float'), ('motion.sd_cm', 'float')]
"""

from __future__ import annotations

import dataclasses
import functools
import typing
from collections.abc import Iterator, Mapping
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError
from pydantic.fields import FieldInfo
from pydantic_core import ArgsKwargs, PydanticCustomError

from .errors import ConfigError
from .yaml_text import YAMLError, load_yaml

__all__ = ["Typed", "build", "checked", "fields_of", "group_fields", "one_line", "parse_value", "with_sets",
           "with_values", "worded"]

T = TypeVar("T", bound=BaseModel)
C = TypeVar("C", bound=type)


class Typed(BaseModel):
    """Base of every typed option group and file record: immutable, unknown fields refused, numbers
    checked finite unless a field says otherwise."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False, validate_default=True)


def worded(text: str) -> PydanticCustomError:
    """An error for a validator to raise when it words the whole message itself (the field's name and
    the value included, as a file's reader has always said it): `build` writes `text` as it is.

    >>> from pydantic import field_validator
    >>> class Row(Typed):
    ...     n_bins: int
    ...     @field_validator("n_bins", mode="before")
    ...     @classmethod
    ...     def _whole(cls, v: Any) -> Any:
    ...         if str(v).strip() != str(v) or not str(v).isdigit():
    ...             raise worded(f"field 'n_bins' must be a whole number, got {v!r}")
    ...         return int(v)
    >>> build(Row, {"n_bins": "3.5"}, "sweeps.csv:2")
    Traceback (most recent call last):
    ...
    toolkit.world.errors.ConfigError: sweeps.csv:2: field 'n_bins' must be a whole number, got '3.5'
    """
    return PydanticCustomError("worded", "{text}", {"text": text})


def _message(err: Mapping[str, Any]) -> str:
    """One pydantic error as ``path: value message`` (pydantic's own wording, lower-cased first letter),
    or the text of a `worded` error."""
    if err.get("type") == "worded":
        return str((err.get("ctx") or {}).get("text", err.get("msg", "")))
    path = ".".join(str(p) for p in err.get("loc", ()))
    text = str(err.get("msg", "invalid"))
    if text.startswith("Value error, "):
        text = text[len("Value error, "):]
    text = text[:1].lower() + text[1:]
    if text.startswith("input should be "):  # pydantic's "Input should be greater than 0"
        text = "must be " + text[len("input should be "):]
    if err.get("type") == "extra_forbidden":
        return f"{path}: unknown field"
    if err.get("type") == "missing":
        return f"{path}: missing"
    value = err.get("input")
    if isinstance(value, dict | list | ArgsKwargs):  # a whole group failed its own check: its message names the value
        return f"{path}: {text}" if path else text
    return f"{path}: {value!r} {text}" if path else f"{value!r}: {text}"


def one_line(exc: ValidationError, where: str) -> str:
    """Every error of `exc` on one line, prefixed by `where` (a file, an option) when given."""
    text = "; ".join(_message(e) for e in exc.errors())
    return f"{where}: {text}" if where else text


def build(cls: type[T], data: Any, where: str = "") -> T:
    """`cls` validated from `data` (a mapping); a failure is one `ConfigError` line naming `where`."""
    try:
        return cls.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(one_line(exc, where)) from None


def checked(cls: C) -> C:
    """A pydantic dataclass (``pydantic.dataclasses.dataclass``: built by position or keyword, and by
    ``dataclasses.replace``) whose construction fails with one `ConfigError` line naming the class, the field
    and the value, as `build` words it.

    >>> from pydantic import Field
    >>> from pydantic.dataclasses import dataclass
    >>> @checked
    ... @dataclass(frozen=True)
    ... class Budget:
    ...     runs: int = Field(1, ge=1)
    >>> Budget(0)
    Traceback (most recent call last):
    ...
    toolkit.world.errors.ConfigError: Budget: runs: 0 must be greater than or equal to 1
    """
    init = cls.__init__  # type: ignore[misc]  # the class's own, wrapped below
    names = [f.name for f in dataclasses.fields(cls) if f.init]

    @functools.wraps(init)
    def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
        if len(args) > len(names):
            raise ConfigError(f"{cls.__name__}: {len(args)} values for {len(names)} fields")
        try:  # by name, so that an error names the field
            init(self, **dict(zip(names, args, strict=False)), **kwargs)
        except ValidationError as exc:
            raise ConfigError(one_line(exc, cls.__name__)) from None

    cls.__init__ = __init__  # type: ignore[misc]
    return cls


def group_fields(kind: Any) -> dict[str, Any] | None:
    """The fields of a group type (a pydantic model, or a standard dataclass nested in one) by name, each
    with its type; None when `kind` is a value, not a group."""
    if isinstance(kind, type) and issubclass(kind, BaseModel):
        return {name: info.annotation for name, info in kind.model_fields.items()}
    if isinstance(kind, type) and dataclasses.is_dataclass(kind):
        hints = typing.get_type_hints(kind)
        return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(kind)}
    return None


def fields_of(cls: type[BaseModel], prefix: str = "") -> Iterator[tuple[str, FieldInfo]]:
    """Every leaf field of `cls` as (dotted name, field), nested groups expanded, in declaration order
    (a standard dataclass nested in a model counts as one field)."""
    for name, info in cls.model_fields.items():
        kind = info.annotation
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            yield from fields_of(kind, f"{prefix}{name}.")
        else:
            yield f"{prefix}{name}", info


def parse_value(text: str) -> Any:
    """A command-line text as a value: YAML (``3``, ``0.5``, ``true``, ``null``, ``[1, 2]``), else the text."""
    try:
        return load_yaml(text) if text.strip() else text
    except YAMLError:
        return text


def with_sets(model: T, sets: Mapping[str, str], where: str = "--set") -> T:
    """`model` with each ``dotted.key`` of `sets` replaced by its text read as YAML, validated again."""
    return with_values(model, {key: parse_value(text) for key, text in sets.items()}, where)


def _fields(value: Any) -> Any:
    """A model's (or a nested dataclass group's) fields as nested dicts, every other value as it is (unlike
    ``model_dump``, which would turn objects held in ``Any`` fields into dicts too)."""
    if isinstance(value, BaseModel):
        return {name: _fields(getattr(value, name)) for name in type(value).model_fields}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    return value


def with_values(model: T, values: Mapping[str, Any], where: str = "--set") -> T:
    """`model` with each ``dotted.key`` of `values` replaced by its value, validated again (groups may be
    pydantic models or standard dataclasses nested in them)."""
    data = _fields(model)
    for key, value in values.items():
        node, parts = data, key.split(".")
        known = group_fields(type(model)) or {}
        for depth, part in enumerate(parts):
            group = ".".join(parts[:depth]) or type(model).__name__
            if part not in known:
                raise ConfigError(f"{where}: no option {key!r}; {group} has: {', '.join(known)}")
            inner = group_fields(known[part])
            if depth < len(parts) - 1:
                if inner is None:
                    raise ConfigError(f"{where}: {'.'.join(parts[:depth + 1])} is a value, not a group")
                node, known = node[part], inner
            else:
                node[part] = value
    return build(type(model), data, where)
