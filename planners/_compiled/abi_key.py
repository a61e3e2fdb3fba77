"""What couples the compiled objective to the OMPL wheel: nanobind's registry key and libompl.so's digest.

Two nanobind extensions share their types (an ``ompl.base.OptimizationObjective`` subclass of ours, the
wheel's ``SpaceInformation`` as our constructor's argument) only when their registry keys agree, e.g.
``v17_system_libstdcpp_gxx_abi_1xxx_use_cxx11_abi_0`` (nanobind's internals version 17, libstdc++'s
pre-C++11 ABI); an extension with another key aborts the interpreter at import, so the loader compares
before importing. The key is a string in each extension's binary.

build.sh reads and records them through ``tools/compiled_objective.py key`` and ``record``.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

__all__ = ["file_digest", "registry_key"]

_KEY = re.compile(rb"v\d+(?:_dev\d+)?_(?:system|gcc_cygwin|mingw|msvc)_[a-z0-9_]+")


def registry_key(library: Path) -> str:
    """nanobind's registry key compiled into the extension `library` ("" when there is none)."""
    found = _KEY.search(Path(library).read_bytes())
    return found.group(0).decode() if found else ""


def file_digest(path: Path) -> str:
    """The SHA-256 of a file (hex)."""
    with open(path, "rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()
