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

>>> from typing import Literal
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
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

from pydantic import BaseModel, ConfigDict, Field, field_validator
from pydantic.fields import FieldInfo
from pydantic_core import PydanticCustomError

from .errors import ConfigError
from .typed import Choices, Typed, build, choices_of, fields_of, kinds_of, parse_value, range_text, type_name

__all__ = [
    "Choices",
    "Configurable",
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


class Options(Typed):
    """Base of a plug-in's option model (and of its groups): a number is never a truth value and a truth
    value never a number, as ``--set KEY=true`` means one of them."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    @field_validator("*", mode="before")
    @classmethod
    def _no_truth_for_numbers(cls, value: Any, info: Any) -> Any:
        kinds = kinds_of(cls.model_fields[info.field_name].annotation)
        if isinstance(value, bool) and bool not in kinds and kinds & {int, float}:
            raise PydanticCustomError("int_type" if int in kinds else "float_type", "a number, not a truth value")
        if not isinstance(value, bool) and value is not None and kinds == {bool}:
            raise PydanticCustomError("bool_type", "a truth value, not {value}", {"value": value})
        return value


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


def describe(cls: type, prefix: str = "", exclude: Collection[str] = ()) -> list[OptionInfo]:
    """Every option of `cls` (an `Options` or any `Typed` model or `typed_dataclass`; groups expanded, dotted
    names after `prefix`), in declaration order; the dotted names of `exclude` (without `prefix`) left out."""
    return [OptionInfo(prefix + name, type_name(info), info.get_default(call_default_factory=True), range_text(info),
                       str(_extra(info).get("unit", "")), info.description or "", bool(_extra(info).get("robot")))
            for name, info in fields_of(cls) if name not in exclude]


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


def markdown(cls: type, prefix: str = "", exclude: Collection[str] = ()) -> str:
    """The options of `cls` as a Markdown table (the docs' parameter tables), named as `describe` names them."""
    rows = ["| option | type | default | range | unit | description |", "|---|---|---|---|---|---|"]
    for o in describe(cls, prefix, exclude):
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
    return build(cls, tree, where)


class Configurable:
    """Base of a plug-in class (a planner, a localiser) whose options are one `Options` model, its
    ``options_model`` (None: the plug-in declares none)."""

    options_model: ClassVar[type[Options] | None] = None

    @classmethod
    def configure(cls, options: Any = None, overrides: Mapping[str, Any] | None = None) -> Any:
        """`options` (an instance of ``options_model``; None: its defaults) with `overrides` on top (dotted
        paths, or the name of one field), validated (`configure`)."""
        if cls.options_model is None:
            raise ConfigError(f"{cls.__qualname__} declares no options_model")
        return configure(cls.options_model, options, overrides)


def parse_sets(cls: type[BaseModel], texts: Mapping[str, str]) -> dict[str, Any]:
    """``--set`` texts by dotted path as values (read as YAML; a text option keeps the text as given),
    checked against `cls`: an unknown path, a grouped option named bare or a bad value is a `ConfigError`."""
    paths = dict(fields_of(cls))
    values: dict[str, Any] = {}
    for key, text in texts.items():
        path = resolve(cls, key, bare=False)
        value = parse_value(text)
        if kinds_of(paths[path].annotation) & {str} and value is not None and not isinstance(value, str):
            value = text.strip()
        choices = choices_of(None, paths[path].metadata)
        if choices and value not in choices:
            raise ConfigError(f"{path}: {value!r} is not one of {', '.join(choices)}")
        values[path] = value
    configure(cls, None, values)  # type: ignore[type-var]
    return values


def groups(cls: type[BaseModel]) -> Iterator[str]:
    """The names of the nested groups of `cls` (top level)."""
    for name, info in cls.model_fields.items():
        kind = info.annotation
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            yield name
