"""The parts every plug-in conformance check shares (`planners.conformance`, `localisation.conformance`).

A check collects problems as lines of text for the plug-in's author: `call_noting` runs one step and
turns an exception into such a line, and `class_problems` checks what every registered plug-in class
needs (a subclass of its base, a registered ``name``, its abstract methods implemented).
"""

from __future__ import annotations

import traceback
from typing import Any

from .registry import Registry

__all__ = ["call_noting", "class_problems"]


def call_noting(what: str, problems: list[str], fn: Any, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)``, or None with a problem line naming the exception and where it arose.

    >>> problems: list[str] = []
    >>> call_noting("dividing", problems, lambda: 1 / 0) is None and problems[0].startswith("dividing raised")
    True
    """
    try:
        return fn(*args, **kwargs)
    except Exception as exc:
        frame = traceback.extract_tb(exc.__traceback__)[-1]
        problems.append(f"{what} raised {type(exc).__name__}: {exc} ({frame.filename}:{frame.lineno})")
        return None


def class_problems(cls: Any, base: type, registry: Registry[Any], base_name: str) -> list[str]:
    """What keeps `cls` from being a plug-in of `registry`: not a subclass of `base` (named `base_name` in
    the message), no ``name`` set in its body, not registered under it, abstract methods left."""
    if not (isinstance(cls, type) and issubclass(cls, base)):
        return [f"{cls!r} is not a subclass of {base_name}"]
    problems = []
    name = cls.__dict__.get("name")
    if not isinstance(name, str) or not name:
        problems.append(f"{cls.__qualname__} sets no `name` (a class attribute: its registry name)")
    elif name not in registry or registry.get(name) is not cls:
        problems.append(f"{cls.__qualname__} is not registered as {name!r} (set `name` in the class body)")
    if getattr(cls, "__abstractmethods__", None):
        problems.append(f"{cls.__qualname__} does not implement {', '.join(sorted(cls.__abstractmethods__))}")
    return problems
