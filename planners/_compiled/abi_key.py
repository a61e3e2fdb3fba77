"""What couples the compiled objective to the OMPL wheel: nanobind's registry key and libompl.so's digest.

Two nanobind extensions share their types (an ``ompl.base.OptimizationObjective`` subclass of ours, the
wheel's ``SpaceInformation`` as our constructor's argument) only when their registry keys agree, e.g.
``v17_system_libstdcpp_gxx_abi_1xxx_use_cxx11_abi_0`` (nanobind's internals version 17, libstdc++'s
pre-C++11 ABI); an extension with another key aborts the interpreter at import, so the loader compares
before importing. The key is a string in each extension's binary.

Run by build.sh: ``python abi_key.py LIBRARY`` prints a library's key; ``python abi_key.py --record JSON
VERSION KEY LIBOMPL`` writes the build's record.
"""

from __future__ import annotations

import hashlib
import json
import re
import sys
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


def _main(argv: list[str]) -> int:
    if argv[:1] == ["--record"] and len(argv) == 5:
        out, version, key, libompl = argv[1:]
        record = {"ompl": version, "registry_key": key, "libompl_sha256": file_digest(Path(libompl))}
        Path(out).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        return 0
    if len(argv) == 1:
        key = registry_key(Path(argv[0]))
        print(key)
        return 0 if key else 1
    print("usage: abi_key.py LIBRARY | abi_key.py --record JSON VERSION KEY LIBOMPL", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(_main(sys.argv[1:]))
