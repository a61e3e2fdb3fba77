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
...     sd_cm: float = Field(default=1.0, ge=0, description="drive noise", json_schema_extra={"unit": "cm"})
>>> class Robot(Typed):
...     radius_cm: float = Field(default=10.0, gt=0)
...     motion: Motion = Motion()
>>> with_sets(Robot(), {"motion.sd_cm": "2.5"}).motion.sd_cm
2.5
>>> build(Robot, {"radius_cm": -1}, "robot.yaml")
Traceback (most recent call last):
...
toolkit.world.errors.ConfigError: robot.yaml: radius_cm: -1 is out of its range (0, inf)
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
import types
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Annotated, Any, Literal, TypeVar, Union, get_args, get_origin

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, Strict, TypeAdapter, ValidationError
from pydantic.dataclasses import dataclass as pydantic_dataclass
from pydantic.fields import FieldInfo
from pydantic_core import ArgsKwargs, PydanticCustomError

from .errors import ConfigError
from .yaml_text import YAMLError, load_yaml

__all__ = ["Choices", "Count", "NonNegative", "Positive", "Real", "Typed", "Whole", "build", "choices_of",
           "fields_of", "group_fields", "kinds_of", "model_fields", "one_line", "parse_value", "range_text",
           "schema_of", "type_name", "typed_dataclass", "with_sets", "with_unit", "with_values", "worded"]

T = TypeVar("T")
C = TypeVar("C", bound=type)


class Typed(BaseModel):
    """Base of every typed option group and file record: immutable, unknown fields refused, numbers
    checked finite unless a field says otherwise."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False, validate_default=True)


_DATACLASS_CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True)


@typing.dataclass_transform(field_specifiers=(dataclasses.field, Field))
def typed_dataclass(*, frozen: bool = True) -> Callable[[C], C]:
    """`Typed`'s rules for a class that must stay a dataclass (built with positional arguments, copied with
    ``dataclasses.replace``, read with ``dataclasses.asdict``): a pydantic dataclass, its fields validated
    on construction and on ``replace``, unknown fields refused, numbers finite.

    >>> from pydantic import Field
    >>> @typed_dataclass()
    ... class Wheel:
    ...     diameter_cm: Real = Field(default=5.6, gt=0)
    >>> Wheel(6).diameter_cm, dataclasses.replace(Wheel(), diameter_cm=4.0).diameter_cm
    (6.0, 4.0)
    >>> build(Wheel, {"diameter_cm": True}, "wheel.yaml")
    Traceback (most recent call last):
    ...
    toolkit.world.errors.ConfigError: wheel.yaml: diameter_cm must be a number, got True
    >>> Wheel(-1)
    Traceback (most recent call last):
    ...
    toolkit.world.errors.ConfigError: Wheel: diameter_cm: -1 is out of its range (0, inf)
    """
    def wrap(cls: C) -> C:
        made: Any = pydantic_dataclass(frozen=frozen, config=_DATACLASS_CONFIG)(cls)
        validating_init = made.__init__
        names = list(made.__pydantic_fields__)

        @functools.wraps(validating_init)
        def init(self: Any, *args: Any, **kwargs: Any) -> None:
            if len(args) <= len(names):  # by name, so that an error names the field
                args, kwargs = (), {**dict(zip(names, args, strict=False)), **kwargs}
            try:
                validating_init(self, *args, **kwargs)
            except ValidationError as exc:  # built in code: the same one line as from a file, named by class
                raise ConfigError(one_line(exc, made.__name__, made)) from None

        made.__init__ = init
        return typing.cast(C, made)

    return wrap


def _number(value: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise PydanticCustomError("needs", "must be a number")
    return value


def _whole(value: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, int | float) or (isinstance(value, float)
                                                                       and not value.is_integer()):
        raise PydanticCustomError("needs", "must be a whole number")
    return int(value)


Real = Annotated[float, BeforeValidator(_number), Strict()]
"""A float field that takes a number (an int too), never a text or true/false: ``x must be a number, got 'a'``."""
Whole = Annotated[int, BeforeValidator(_whole)]
"""An int field that takes a whole number (``17`` or ``17.0``), never a text, true/false or ``17.5``."""
Positive = Annotated[Real, Field(gt=0)]
"""A `Real` > 0."""
NonNegative = Annotated[Real, Field(ge=0)]
"""A `Real` >= 0."""
Count = Annotated[Whole, Field(ge=0)]
"""A `Whole` >= 0."""


class Choices:
    """Metadata of a text option whose allowed values live in a registry (read when checked, so a name
    registered later counts): ``Annotated[str, Choices(names)]``. ``--set`` refuses another text (the
    plug-in's constructor checks it again against its registry); the JSON Schema lists them (``enum``)."""

    def __init__(self, names: Callable[[], Sequence[str]]) -> None:
        self.names = names

    def __get_pydantic_json_schema__(self, core_schema: Any, handler: Any) -> Any:
        schema = handler(core_schema)
        schema["enum"] = list(self.names())
        return schema


def kinds_of(annotation: Any) -> set[Any]:
    """The plain types an annotation admits (``int | None`` -> {int, NoneType}; a ``Literal`` -> {str})."""
    origin = get_origin(annotation)
    if origin in (Union, types.UnionType):
        return set().union(*(kinds_of(a) for a in get_args(annotation)))
    if origin is typing.Annotated:
        return kinds_of(get_args(annotation)[0])
    if origin is Literal:
        return {str}
    return {origin or annotation}


def choices_of(annotation: Any, metadata: Sequence[Any] = ()) -> tuple[str, ...]:
    """The allowed texts of a field: its `Choices`, or the members of its ``Literal``; empty for any other."""
    for item in metadata:
        if isinstance(item, Choices):
            return tuple(item.names())
    for arg in (annotation, *get_args(annotation)):
        if get_origin(arg) is Literal:
            return tuple(str(c) for c in get_args(arg))
    return ()


def _bounds(metadata: list[Any]) -> tuple[str, str]:
    """The two ends of a field's range as written in `range_text` (``[1``, ``inf)``; ``(0`` when exclusive)."""
    low = next((f"[{m.ge:g}" for m in metadata if getattr(m, "ge", None) is not None),
               next((f"({m.gt:g}" for m in metadata if getattr(m, "gt", None) is not None), ""))
    high = next((f"{m.le:g}]" for m in metadata if getattr(m, "le", None) is not None),
                next((f"{m.lt:g})" for m in metadata if getattr(m, "lt", None) is not None), ""))
    return low, high


def _item_metadata(info: FieldInfo) -> list[Any]:
    """The bounds of a field, or of the items of a tuple field (``tuple[Annotated[float, Field(ge=0)], ...]``)."""
    if info.metadata:
        return list(info.metadata)
    args = get_args(info.annotation) if get_origin(info.annotation) is tuple else ()
    if args and get_origin(args[0]) is typing.Annotated:
        return [m for a in get_args(args[0])[1:] for m in getattr(a, "metadata", [a])]
    return []


def range_text(info: FieldInfo) -> str:
    """``[1, inf)``, ``(0, 1]``, ``one of a, b`` or empty."""
    choices = choices_of(info.annotation, info.metadata)
    if choices:
        return "one of " + ", ".join(choices)
    low, high = _bounds(_item_metadata(info))
    if not (low or high):
        return ""
    return f"{low or '(-inf'}, {high or 'inf)'}"


def type_name(info: FieldInfo) -> str:
    """``int``, ``float or null``, ``3 x float``, ``str``, ``mapping``, ``model`` (an object the robot model sets)."""
    kinds = kinds_of(info.annotation)
    optional = type(None) in kinds
    kinds.discard(type(None))
    names = {bool: "bool", int: "int", float: "float", str: "str", dict: "mapping"}
    if kinds == {tuple}:
        inner = get_args(info.annotation)
        kind = f"{len(inner)} x {names.get(next(iter(kinds_of(inner[0]))), 'model')}"
    else:
        kind = names.get(next(iter(kinds)), "model") if len(kinds) == 1 else "model"
    return kind + (" or null" if optional else "")


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


_BOUND_ERRORS = ("greater_than_equal", "less_than_equal", "greater_than", "less_than")
_EXPECTED = (("int_", "an integer"), ("float_", "a finite number"), ("finite_number", "a finite number"),
             ("bool_", "true or false"), ("string_", "a text"))


def _leaf(model: Any, loc: Sequence[str]) -> FieldInfo | None:
    """The field an error's location names in `model` (item indexes left out), None when it names none."""
    if model is None:
        return None
    return dict(fields_of(model)).get(".".join(p for p in loc if not p.isdigit()))


def _problem(err: Mapping[str, Any], info: FieldInfo | None) -> str:
    """What is wrong, in the toolkit's words: the value and the rule it breaks."""
    kind, value = str(err.get("type")), err.get("input")
    tuple_size = (len(get_args(info.annotation)) if info is not None and kinds_of(info.annotation) == {tuple}
                  and Ellipsis not in get_args(info.annotation) else 0)
    if kind in ("extra_forbidden", "unexpected_keyword_argument"):  # a model's, a dataclass's
        return "unknown field"
    if kind == "missing":
        return "missing"
    if tuple_size and kind not in _BOUND_ERRORS:
        return f"expected {tuple_size} numbers, got {value!r}"
    if value is None and kind != "value_error":
        kind_text = type_name(info) if info is not None else "value"
        return f"must be {'an' if kind_text[0] in 'aeiou' else 'a'} {kind_text}, got null"
    if info is not None and kind in _BOUND_ERRORS and range_text(info):
        return f"{value!r} is out of its range {range_text(info)}"
    if info is not None and kind == "literal_error":
        return f"{value!r} is not {range_text(info)}"
    expected = next((words for prefix, words in _EXPECTED if kind.startswith(prefix)), None)
    if expected is not None:
        return f"expected {expected}, got {value!r}"
    text = str(err.get("msg", "invalid")).removeprefix("Value error, ")
    text = text[:1].lower() + text[1:]
    if text.startswith("input should be "):  # pydantic's "Input should be a valid date"
        text = "must be " + text[len("input should be "):]
    if isinstance(value, dict | list | ArgsKwargs):  # a whole group failed its own check: it names the value
        return text
    return f"{value!r} {text}"


def _message(err: Mapping[str, Any], model: Any = None, prefix: tuple[str, ...] = ()) -> str:
    """One pydantic error as ``path: what is wrong`` (`_problem`), or the text of a `worded` error; the path
    is `prefix` (where `model` sits in a larger one) and the field's dotted name in `model` (item indexes
    left out) or, for a field it does not know, the error's whole location."""
    if err.get("type") == "worded":
        return str((err.get("ctx") or {}).get("text", err.get("msg", "")))
    loc = [str(p) for p in err.get("loc", ())]
    if err.get("type") == "needs":  # the field's kind of value: worded as the readers have always said it
        return f"{'.'.join((*prefix, *loc))} {err.get('msg')}, got {err.get('input')!r}"
    info = _leaf(model, loc)
    named = [p for p in loc if not p.isdigit()] if info is not None else loc
    path = ".".join((*prefix, *named))
    problem = _problem(err, info)
    if path:
        return f"{path}: {problem}"
    return problem if isinstance(err.get("input"), dict | list | ArgsKwargs) else f"{err.get('input')!r}: {problem}"


def one_line(exc: ValidationError, where: str, model: Any = None) -> str:
    """Every error of `exc` on one line, prefixed by `where` (a file, an option) when given; `model` (the
    class validated) names each field's range, choices and type."""
    text = "; ".join(_message(e, model) for e in exc.errors())
    return f"{where}: {text}" if where else text


@functools.cache
def _adapter(cls: type) -> TypeAdapter[Any]:
    return TypeAdapter(cls)


def _validated(cls: type[T], data: Any) -> T:
    if issubclass(cls, BaseModel):
        return typing.cast(T, cls.model_validate(data))
    return typing.cast(T, _adapter(typing.cast(Any, cls)).validate_python(data))


def build(cls: type[T], data: Any, where: str = "") -> T:
    """`cls` (a `Typed` model or a `typed_dataclass`) validated from `data` (a mapping); a failure is one
    `ConfigError` line naming `where`."""
    try:
        return _validated(cls, data)
    except ValidationError as exc:
        raise ConfigError(one_line(exc, where, cls)) from None


def schema_of(cls: type) -> dict[str, Any]:
    """The JSON Schema of a `Typed` model or a `typed_dataclass`."""
    return _adapter(cls).json_schema()


def model_fields(cls: Any) -> dict[str, FieldInfo]:
    """The pydantic fields of a model or a pydantic dataclass by name ({} for any other class)."""
    if isinstance(cls, type) and issubclass(cls, BaseModel):
        return dict(cls.model_fields)
    return dict(getattr(cls, "__pydantic_fields__", None) or {})


def group_fields(kind: Any) -> dict[str, Any] | None:
    """The fields of a group type (a pydantic model, or a standard dataclass nested in one) by name, each
    with its type; None when `kind` is a value, not a group."""
    if isinstance(kind, type) and (issubclass(kind, BaseModel) or hasattr(kind, "__pydantic_fields__")):
        return {name: info.annotation for name, info in model_fields(kind).items()}
    if isinstance(kind, type) and dataclasses.is_dataclass(kind):
        hints = typing.get_type_hints(kind)
        return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(kind)}
    return None


def fields_of(cls: Any, prefix: str = "") -> Iterator[tuple[str, FieldInfo]]:
    """Every leaf field of `cls` as (dotted name, field), nested groups expanded, in declaration order
    (a standard dataclass nested in a model counts as one field, a `typed_dataclass` as a group)."""
    for name, info in model_fields(cls).items():
        kind = info.annotation
        if model_fields(kind):
            yield from fields_of(kind, f"{prefix}{name}.")
        else:
            yield f"{prefix}{name}", info


def parse_value(text: str) -> Any:
    """A command-line text as a value: YAML (``3``, ``0.5``, ``true``, ``null``, ``[1, 2]``), else the text."""
    try:
        return load_yaml(text) if text.strip() else text
    except YAMLError:
        return text


def with_sets(model: T, sets: Mapping[str, str], where: str = "--set", section: str = "") -> T:
    """`model` with each ``dotted.key`` of `sets` replaced by its text read as YAML, validated again (an error
    names a key as ``section.key`` when `section` is given: ``--set robot.timing.drive_speed_cm_s``)."""
    return with_values(model, {key: parse_value(text) for key, text in sets.items()}, where, section)


class _Group(dict[str, Any]):
    """The overrides of one nested group (by field name), as `with_values` collects them."""


def with_values(model: T, values: Mapping[str, Any], where: str = "--set", section: str = "") -> T:
    """`model` with each ``dotted.key`` of `values` replaced by its value, validated again. Groups may be
    pydantic models, pydantic or standard dataclasses; a key is looked up in the group the model holds
    (its own class, which may be a subclass of the declared one: a `RobotModel`'s sonar). With `section`,
    messages name each key as ``section.key``."""
    edits = _Group()
    head = (section,) if section else ()
    for key, value in values.items():
        node, parts, here = edits, key.split("."), typing.cast(Any, model)
        for depth, part in enumerate(parts):
            known = group_fields(type(here)) or {}
            if part not in known:
                group = ".".join((*head, *parts[:depth])) or type(model).__name__
                raise ConfigError(f"{where}: no option {'.'.join((*head, key))!r}; {group} has: {', '.join(known)}")
            if depth == len(parts) - 1:
                node[part] = value
                break
            here = getattr(here, part)
            if group_fields(type(here)) is None:
                raise ConfigError(f"{where}: {'.'.join((*head, *parts[:depth + 1]))} is a value, not a group")
            inner = node.get(part)
            if not isinstance(inner, _Group):
                inner = node[part] = _Group()
            node = inner
    return typing.cast(T, _rebuilt(model, edits, where, head, top=True))


def _rebuilt(group: Any, edits: _Group, where: str, path: tuple[str, ...], top: bool = False) -> Any:
    """`group` (at `path` in the model) with `edits`, validated as its own class; an error names the field by
    its whole dotted path."""
    data = {name: getattr(group, name) for name in group_fields(type(group)) or {}}
    for name, edit in edits.items():
        data[name] = _rebuilt(getattr(group, name), edit, where, (*path, name)) if isinstance(edit, _Group) else edit
    if top and not path:
        return build(type(group), data, where)
    if not top and not model_fields(type(group)):  # a standard dataclass: the model holding it validates the values
        return data
    try:
        return _validated(type(group), data)
    except ValidationError as exc:
        raise ConfigError(f"{where}: " + "; ".join(_message(e, type(group), path) for e in exc.errors())) from None


def with_unit(unit: str) -> dict[str, Any]:
    """A field's unit as its ``json_schema_extra``: ``Field(1.0, json_schema_extra=with_unit("cm"))``; the
    parameters page, ``show`` commands and the JSON Schema show it.

    >>> with_unit("cm")
    {'unit': 'cm'}
    """
    return {"unit": unit}
