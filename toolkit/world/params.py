"""Declared parameters of plug-ins (planners and localisers), as OMPL declares its planners' parameters.

A plug-in class lists its options once, as `Param` declarations in a `Params` (its ``params``
attribute): name, type, default, range or choices, unit and a one-line description. The command line
validates ``--set NAME.KEY=VALUE`` against them (`Params.parse`, `Params.check`), ``nxtnav planners show``
and ``nxtnav localisers show`` print them, and the parameter tables of the docs are made from them
(`Params.markdown`), so no code reads a constructor's signature.

Options a localiser takes from the robot model (`toolkit.world.RobotModel`: motion noise, the sonar's
sigma, lobe and range limit, the robot's radius) are declared too, marked ``robot=True``: the run sets
them from the one model every localiser is given, and ``--set`` may still override them by name.

>>> p = Params(Param("n", int, 10, "samples", low=1))
>>> p.parse("n", "20")
20
>>> p.parse("n", "0")
Traceback (most recent call last):
...
toolkit.world.errors.ConfigError: n: 0 is out of its range [1, inf)
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from .errors import ConfigError
from .yaml_text import YAMLError, load_yaml

__all__ = ["Param", "Params"]

_TYPE_NAMES = {bool: "bool", int: "int", float: "float", str: "str", object: "model"}


@dataclass(frozen=True)
class Param:
    """One declared option.

    Parameters
    ----------
    name : str
    kind : {bool, int, float, str, object}
        The value's type (ints widen to floats for a float); ``object``: a model object only the robot
        model sets (``robot=True``; not settable from the command line).
    default : Any
        The value when the option is not set (None only with `optional`).
    description : str
        One line.
    unit : str
        ``cm``, ``deg``, ``s``, ... or empty.
    low, high : float, optional
        Inclusive bounds of a number.
    choices : tuple of str
        The allowed texts of a str option (empty: any text).
    optional : bool
        None (``--set KEY=null``) is allowed: "off" or "automatic", as the description says.
    size : int
        More than 0: the value is a tuple of this many numbers of `kind`, each within the bounds
        (``--set KEY=[0.1,0.1,0.001]``).
    robot : bool
        Set from the robot model for each run (see the module docstring).
    """

    name: str
    kind: type
    default: Any
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    optional: bool = False
    robot: bool = False
    size: int = 0

    def __post_init__(self) -> None:
        if self.kind not in _TYPE_NAMES:
            raise TypeError(f"{self.name}: kind must be bool, int, float, str or object, got {self.kind!r}")
        if self.kind is object and not self.robot:
            raise TypeError(f"{self.name}: an object option must be set from the robot model (robot=True)")
        if not (self.default is None and self.optional):
            self.check(self.default)

    @property
    def type_name(self) -> str:
        kind = f"{self.size} x {_TYPE_NAMES[self.kind]}" if self.size else _TYPE_NAMES[self.kind]
        return kind + (" or null" if self.optional else "")

    @property
    def range_text(self) -> str:
        """``[1, inf)``, ``one of a, b`` or empty."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        if self.low is None and self.high is None:
            return ""
        lo = "(-inf" if self.low is None else f"[{self.low:g}"
        hi = "inf)" if self.high is None else f"{self.high:g}]"
        return f"{lo}, {hi}"

    def check(self, value: Any) -> Any:
        """`value` as this option's type, or `ConfigError` naming the option, the value and what it must be."""
        if value is None:
            if self.optional:
                return None
            raise ConfigError(f"{self.name}: must be a {self.type_name}, got null")
        if self.size:
            if not isinstance(value, list | tuple) or len(value) != self.size:
                raise ConfigError(f"{self.name}: expected {self.size} numbers, got {value!r}")
            return tuple(self._scalar(v) for v in value)
        return self._scalar(value)

    def _scalar(self, value: Any) -> Any:
        if self.kind is object:
            return value
        if self.kind is bool:
            if isinstance(value, bool):
                return value
            raise ConfigError(f"{self.name}: expected true or false, got {value!r}")
        if self.kind is str:
            if not isinstance(value, str):
                raise ConfigError(f"{self.name}: expected a text, got {value!r}")
            if self.choices and value not in self.choices:
                raise ConfigError(f"{self.name}: {value!r} is not {self.range_text}")
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{self.name}: expected {'an integer' if self.kind is int else 'a finite number'}, "
                              f"got {value!r}")
        if self.kind is int:
            if isinstance(value, float):
                if not value.is_integer():
                    raise ConfigError(f"{self.name}: expected an integer, got {value!r}")
                value = int(value)
        elif not math.isfinite(value):
            raise ConfigError(f"{self.name}: expected a finite number, got {value!r}")
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            raise ConfigError(f"{self.name}: {value!r} is out of its range {self.range_text}")
        return self.kind(value)

    def parse(self, text: str) -> Any:
        """A command-line text (YAML: ``3``, ``0.5``, ``true``, ``null``, ``beam``) as this option's value."""
        if self.kind is object:
            raise ConfigError(f"{self.name}: set from the robot model (a sonar profile), not from the command line")
        try:
            value = load_yaml(text) if text.strip() else text
        except YAMLError:
            value = text
        if self.kind is str and value is not None and not isinstance(value, str):
            value = text.strip()
        return self.check(value)


@dataclass(frozen=True)
class Params:
    """A plug-in's declared options, in the order they are shown."""

    items: tuple[Param, ...] = field(default_factory=tuple)

    def __init__(self, *items: Param) -> None:
        names = [p.name for p in items]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise TypeError(f"parameters declared twice: {', '.join(sorted(dup))}")
        object.__setattr__(self, "items", tuple(items))

    def __iter__(self) -> Iterator[Param]:
        return iter(self.items)

    def __len__(self) -> int:
        return len(self.items)

    def __contains__(self, name: object) -> bool:
        return any(p.name == name for p in self.items)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.items]

    def get(self, name: str) -> Param:
        """The declaration of `name`; `ConfigError` listing the declared names when there is none."""
        for p in self.items:
            if p.name == name:
                return p
        raise ConfigError(f"no option {name!r}; declared: {', '.join(self.names) or 'none'}")

    def defaults(self) -> dict[str, Any]:
        return {p.name: p.default for p in self.items}

    def parse(self, name: str, text: str) -> Any:
        return self.get(name).parse(text)

    def check(self, options: Mapping[str, Any]) -> dict[str, Any]:
        """`options` checked against the declarations (an unknown name or a bad value: `ConfigError`)."""
        return {k: self.get(k).check(v) for k, v in options.items()}

    def extend(self, *items: Param, without: tuple[str, ...] = ()) -> Params:
        """These declarations less `without`, then `items` (a subclass's options after its base's)."""
        return Params(*(p for p in self.items if p.name not in without), *items)

    def markdown(self) -> str:
        """The declarations as a Markdown table (the docs' parameter tables)."""
        rows = ["| option | type | default | range | unit | description |", "|---|---|---|---|---|---|"]
        for p in self.items:
            desc = p.description + (" *(from the robot model)*" if p.robot else "")
            rows.append(f"| `{p.name}` | {p.type_name} | {_show(p.default)} | {p.range_text} | {p.unit} | {desc} |")
        return "\n".join(rows)


def _show(value: Any) -> str:
    if isinstance(value, tuple):
        return "(" + ", ".join(_show(v) for v in value) + ")"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    return f"`{value}`" if isinstance(value, str) else f"{value:g}" if isinstance(value, float) else str(value)
