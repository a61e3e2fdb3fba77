"""YAML with YAML 1.2's numbers: the one reader of every YAML file and command-line value of the toolkit.

PyYAML follows YAML 1.1, where a float needs a dot: ``1e9`` and ``8e-3`` are read as texts, so a map,
a profile or an option written that way was refused with "expected a number". ROS tools (yaml-cpp)
and YAML 1.2 read them as numbers; so does `load_yaml`. Everything else is PyYAML's safe loading (the
C parser when PyYAML has it).

>>> load_yaml("a: 1e9\\nb: 8e-3\\nc: 10\\nd: 1.5\\ne: 1e9x")
{'a': 1000000000.0, 'b': 0.008, 'c': 10, 'd': 1.5, 'e': '1e9x'}
"""

from __future__ import annotations

import re
from typing import Any

import yaml

__all__ = ["YAMLError", "load_yaml"]

YAMLError = yaml.YAMLError


class _Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """PyYAML's safe loader that also reads an exponent without a dot as a float."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_yaml(text: str) -> Any:
    """`text` as YAML (safe: plain data only), numbers as YAML 1.2 reads them; raises `YAMLError`."""
    return yaml.load(text, Loader=_Loader)
