"""Plug-in options (planners and localisers) as one typed model each, built on `toolkit.world.typed`.

A plug-in declares its options once, as an `Options` model: every field's type, default, range
(``ge``/``le``), choices (``Literal``), unit and one-line description live in its ``Field`` (written with
`option`), and options that belong together are a nested group (a localiser's motion model, sensor
model, recovery, convergence, as nav2 groups its parameters). From that one model come:

- the constructor's options: a plug-in takes ``options`` (the model, or None for the defaults) and any
  keyword overrides, merged by `configure` (a key is a dotted path, ``sensor.z_hit``, or the field's own
  name when that names one field: ``z_hit``);
- ``--set NAME.PATH=VALUE`` on the command line (`parse_sets`): dotted paths only; a grouped option
  given by its bare name is refused with one line naming its path;
- ``nxtnav planners show`` / ``nxtnav localisers show`` and the parameter tables of the docs
  (`describe`, `markdown`), and a JSON Schema per plug-in (`json_schema`).

Options a localiser takes from the robot model (`toolkit.world.RobotModel`: motion noise, the sonar's
sigma, lobe and range limit, the robot's radius) are marked ``robot=True`` (``json_schema_extra``): the run
sets them from the one model every localiser is given, and ``--set`` may still override them.

>>> class Search(Options):
...     n: int = option(10, "samples", ge=1)
>>> class Planner(Options):
...     search: Search = Search()
...     mode: Literal["a", "b"] = option("a", "the mode")
>>> Planner().search.n
10
>>> configure(Planner, None, {"n": 20}).search.n
20
>>> parse_sets(Planner, {"search.n": "0"})
Traceback (most recent call last):
...
toolkit.world.errors.ConfigError: search.n: 0 is out of its range [1, inf)
>>> parse_sets(Planner, {"n": "3"})
Traceback (most recent call last):
...
toolkit.world.errors.ConfigError: n: the options are grouped: use search.n
"""

from __future__ import annotations

import json
import types
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, TypeVar, Union, get_args, get_origin

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from pydantic.fields import FieldInfo

from .errors import ConfigError
from .typed import Typed, fields_of, parse_value

__all__ = [
    "Choices",
    "OptionInfo",
    "Options",
    "configure",
    "describe",
    "grouped_paths",
    "groups",
    "json_schema",
    "markdown",
    "option",
    "option_names",
    "parse_sets",
    "resolve",
    "robot_paths",
]

OptionsT = TypeVar("OptionsT", bound="Options")


def option(default: Any, description: str, *, unit: str = "", ge: float | None = None, le: float | None = None,
           robot: bool = False) -> Any:
    """A field of an `Options` model: its default, one-line description, unit, inclusive bounds and
    whether the robot model sets it (``robot``)."""
    extra: dict[str, Any] = {}
    if unit:
        extra["unit"] = unit
    if robot:
        extra["robot"] = True
    return Field(default, description=description, ge=ge, le=le, json_schema_extra=extra or None)


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


class Options(Typed):
    """Base of a plug-in's option model (and of its groups): a number is never a truth value and a truth
    value never a number, as ``--set KEY=true`` means one of them."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_truth_for_numbers(cls, value: Any, info: Any) -> Any:
        kinds = _kinds(cls.model_fields[info.field_name].annotation)
        if isinstance(value, bool) and bool not in kinds and kinds & {int, float}:
            raise ValueError(f"expected {_number_text(kinds)}, got {value!r}")
        if not isinstance(value, bool) and value is not None and kinds == {bool}:
            raise ValueError(f"expected true or false, got {value!r}")
        return value


def _kinds(annotation: Any) -> set[Any]:
    """The plain types an annotation admits (``int | None`` -> {int, NoneType})."""
    origin = get_origin(annotation)
    if origin in (Union, types.UnionType):
        return set().union(*(_kinds(a) for a in get_args(annotation)))
    if origin is typing.Annotated:
        return _kinds(get_args(annotation)[0])
    if origin is Literal:
        return {str}
    return {origin or annotation}


def _number_text(kinds: set[Any]) -> str:
    return "an integer" if int in kinds else "a finite number"


@dataclass(frozen=True)
class OptionInfo:
    """One option as shown: dotted name, type, default, range or choices, unit, description, robot."""

    name: str
    type_name: str
    default: Any
    range_text: str
    unit: str
    description: str
    robot: bool

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "type": self.type_name, "default": _plain(self.default),
                "range": self.range_text, "unit": self.unit, "description": self.description, "robot": self.robot}


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _extra(info: FieldInfo) -> dict[str, Any]:
    extra = info.json_schema_extra
    return extra if isinstance(extra, dict) else {}


def _bounds(metadata: list[Any]) -> tuple[float | None, float | None]:
    low = next((m.ge for m in metadata if hasattr(m, "ge")), None)
    high = next((m.le for m in metadata if hasattr(m, "le")), None)
    return low, high


def _item_metadata(info: FieldInfo) -> list[Any]:
    """The bounds of a field, or of the items of a tuple field (``tuple[Annotated[float, Field(ge=0)], ...]``)."""
    if info.metadata:
        return list(info.metadata)
    args = get_args(info.annotation) if get_origin(info.annotation) is tuple else ()
    if args and get_origin(args[0]) is typing.Annotated:
        return [m for a in get_args(args[0])[1:] for m in getattr(a, "metadata", [a])]
    return []


def _choices(annotation: Any, metadata: Sequence[Any] = ()) -> tuple[str, ...]:
    for item in metadata:
        if isinstance(item, Choices):
            return tuple(item.names())
    for arg in (annotation, *get_args(annotation)):
        if get_origin(arg) is Literal:
            return tuple(str(c) for c in get_args(arg))
    return ()


def range_text(info: FieldInfo) -> str:
    """``[1, inf)``, ``one of a, b`` or empty."""
    choices = _choices(info.annotation, info.metadata)
    if choices:
        return "one of " + ", ".join(choices)
    low, high = _bounds(_item_metadata(info))
    if low is None and high is None:
        return ""
    lo = "(-inf" if low is None else f"[{low:g}"
    hi = "inf)" if high is None else f"{high:g}]"
    return f"{lo}, {hi}"


def type_name(info: FieldInfo) -> str:
    """``int``, ``float or null``, ``3 x float``, ``str``, ``model`` (an object the robot model sets)."""
    kinds = _kinds(info.annotation)
    optional = type(None) in kinds
    kinds.discard(type(None))
    names = {bool: "bool", int: "int", float: "float", str: "str"}
    if kinds == {tuple}:
        inner = get_args(info.annotation)
        kind = f"{len(inner)} x {names.get(next(iter(_kinds(inner[0]))), 'model')}"
    else:
        kind = names.get(next(iter(kinds)), "model") if len(kinds) == 1 else "model"
    return kind + (" or null" if optional else "")


def describe(cls: type[BaseModel]) -> list[OptionInfo]:
    """Every option of `cls` (groups expanded, dotted names), in declaration order."""
    return [OptionInfo(name, type_name(info), info.default, range_text(info), str(_extra(info).get("unit", "")),
                       info.description or "", bool(_extra(info).get("robot"))) for name, info in fields_of(cls)]


def robot_paths(cls: type[BaseModel]) -> list[str]:
    """The dotted names of the options the robot model sets."""
    return [o.name for o in describe(cls) if o.robot]


def _shown(value: Any) -> str:
    if isinstance(value, tuple):
        return "(" + ", ".join(_shown(v) for v in value) + ")"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    return f"`{value}`" if isinstance(value, str) else f"{value:g}" if isinstance(value, float) else str(value)


def markdown(cls: type[BaseModel]) -> str:
    """The options of `cls` as a Markdown table (the docs' parameter tables)."""
    rows = ["| option | type | default | range | unit | description |", "|---|---|---|---|---|---|"]
    for o in describe(cls):
        desc = o.description + (" *(from the robot model)*" if o.robot else "")
        rows.append(f"| `{o.name}` | {o.type_name} | {_shown(o.default)} | {o.range_text} | {o.unit} | {desc} |")
    return "\n".join(rows)


def json_schema(cls: type[BaseModel], title: str) -> str:
    """The JSON Schema of `cls` (titled `title`), as stable text (sorted keys, two-space indent, newline)."""
    schema = cls.model_json_schema()
    schema["title"] = title
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def _leaves(cls: type[BaseModel]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for name, _ in fields_of(cls):
        out.setdefault(name.rpartition(".")[2], []).append(name)
    return out


def grouped_paths(cls: type[BaseModel], key: str) -> list[str]:
    """The dotted paths of the grouped options whose own name is `key` (``z_hit`` -> ``sensor.z_hit``)."""
    return [path for path in _leaves(cls).get(key, []) if path != key]


def resolve(cls: type[BaseModel], key: str, *, bare: bool = True) -> str:
    """The dotted path `key` names in `cls`: the path itself, or (with `bare`) the name of one field;
    `ConfigError` naming the options otherwise (or the path, for a grouped option given bare)."""
    paths = dict(fields_of(cls))
    if key in paths:
        return key
    found = _leaves(cls).get(key, [])
    if len(found) == 1 and bare:
        return found[0]
    if found:
        raise ConfigError(f"{key}: the options are grouped: use {' or '.join(found)}")
    raise ConfigError(f"no option {key!r}; options: {option_names(cls)}")


def option_names(cls: type[BaseModel]) -> str:
    """The top-level options of `cls` and its groups, for a message: ``n, m and the groups a.*, b.*``."""
    own = [name for name in cls.model_fields if name not in set(groups(cls))]
    nested = [f"{name}.*" for name in groups(cls)]
    text = ", ".join(own) or "none"
    return f"{text} and the groups {', '.join(nested)}" if nested else text


def _nest(model: BaseModel | None, cls: type[BaseModel]) -> dict[str, Any]:
    """`model`'s values as nested mappings (objects kept), or an empty tree for the defaults."""
    out: dict[str, Any] = {}
    for name, info in cls.model_fields.items():
        kind = info.annotation
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            out[name] = _nest(None if model is None else getattr(model, name), kind)
        elif model is not None:
            out[name] = getattr(model, name)
    return out


def configure(cls: type[OptionsT], options: OptionsT | None = None, overrides: Mapping[str, Any] | None = None,
              where: str = "") -> OptionsT:
    """`options` (None: the defaults) with `overrides` (dotted paths or field names, in order) on top,
    validated; a bad key or value is one `ConfigError` line naming the option, the value and the rule."""
    if options is not None and not isinstance(options, cls):
        raise ConfigError(f"{where + ': ' if where else ''}options must be a {cls.__name__}, got "
                          f"{type(options).__name__}")
    if options is not None and not overrides:
        return options
    tree = _nest(options, cls)
    for key, value in (overrides or {}).items():
        path = resolve(cls, str(key))
        node = tree
        *groups, leaf = path.split(".")
        for group in groups:
            node = node[group]
        node[leaf] = value
    try:
        return cls.model_validate(tree)
    except ValidationError as exc:
        text = "; ".join(_wording(cls, dict(e)) for e in exc.errors())
        raise ConfigError(f"{where}: {text}" if where else text) from None


def parse_sets(cls: type[BaseModel], texts: Mapping[str, str]) -> dict[str, Any]:
    """``--set`` texts by dotted path as values (read as YAML; a text option keeps the text as given),
    checked against `cls`: an unknown path, a grouped option named bare or a bad value is a `ConfigError`."""
    paths = dict(fields_of(cls))
    values: dict[str, Any] = {}
    for key, text in texts.items():
        path = resolve(cls, key, bare=False)
        value = parse_value(text)
        if _kinds(paths[path].annotation) & {str} and value is not None and not isinstance(value, str):
            value = text.strip()
        choices = _choices(None, paths[path].metadata)
        if choices and value not in choices:
            raise ConfigError(f"{path}: {value!r} is not one of {', '.join(choices)}")
        values[path] = value
    configure(cls, None, values)  # type: ignore[type-var]
    return values


def _wording(cls: type[BaseModel], err: Mapping[str, Any]) -> str:
    """A pydantic error as ``path: what is wrong`` in the toolkit's words."""
    loc = [str(p) for p in err.get("loc", ())]
    path, value, kind = ".".join(p for p in loc if not p.isdigit()), err.get("input"), str(err.get("type"))
    info = dict(fields_of(cls)).get(path)
    if info is not None and _kinds(info.annotation) == {tuple} and not kind.startswith(("greater", "less")):
        return f"{path}: expected {len(get_args(info.annotation))} numbers, got {value!r}"
    if value is None and kind != "value_error":
        return f"{path}: must be a {type_name(info) if info else 'value'}, got null"
    if kind == "extra_forbidden":
        return f"no option {path!r}"
    if kind in ("greater_than_equal", "less_than_equal", "greater_than", "less_than") and info is not None:
        return f"{path}: {value!r} is out of its range {range_text(info)}"
    if kind == "literal_error" and info is not None:
        return f"{path}: {value!r} is not {range_text(info)}"
    if kind.startswith("int_"):
        return f"{path}: expected an integer, got {value!r}"
    if kind.startswith("float_") or kind == "finite_number":
        return f"{path}: expected a finite number, got {value!r}"
    if kind.startswith("bool_"):
        return f"{path}: expected true or false, got {value!r}"
    if kind.startswith("string_"):
        return f"{path}: expected a text, got {value!r}"
    text = str(err.get("msg", "invalid"))
    return f"{path}: {text.removeprefix('Value error, ')}"


def groups(cls: type[BaseModel]) -> Iterator[str]:
    """The names of the nested groups of `cls` (top level)."""
    for name, info in cls.model_fields.items():
        kind = info.annotation
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            yield name
