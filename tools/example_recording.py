"""Re-record the suite's example recording, `tests/data/recording_map1_nxt.jsonl`, as format version 1.

The example is a map1 mission with the NXT sonar model and `amcl` live (seed 6). It is the suite's
version-1 file: the tests read it as an older version and replay it bit for bit, so it must be recorded
again whenever a localiser's numerics change on purpose. nxtnav writes the current format version; a
version-1 file is the same lines without what later versions added, so this script records the mission
with ``nxtnav run ... --record`` and writes it back with the header's version set to 1, the ``plan``
lines and the estimates' ``particles`` (both version 3) left out. The result is read back as version 1
and replayed: the live localiser must reproduce its estimates bit for bit, or nothing is written.

    python tools/example_recording.py [--out tests/data/recording_map1_nxt.jsonl]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "tests" / "data" / "recording_map1_nxt.jsonl"
COMMAND = ["run", "--map", "map1", "--seed", "6", "--sonar", "nxt", "--localiser", "amcl"]
"""The mission recorded (`nxtnav run` arguments, before ``--record``)."""


def as_version_1(lines: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The recording's lines without what format versions 2 and 3 added (a sim recording uses none of
    version 2's: a null heading or clock, a label), the header saying version 1."""
    out = []
    for line in lines:
        if line["type"] == "plan":
            continue
        line = dict(line)
        if line["type"] == "header":
            line["version"] = 1
        elif line["type"] == "estimate":
            line.pop("particles", None)
        out.append(line)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=EXAMPLE, help="where to write it (default: the suite's)")
    args = parser.parse_args(argv)
    from toolkit.cli import main as nxtnav
    from toolkit.recordings.replay import read_recording, replay

    with tempfile.TemporaryDirectory() as tmp:
        recorded, written = Path(tmp) / "run.jsonl", Path(tmp) / "v1.jsonl"
        try:
            nxtnav([*COMMAND, "--record", str(recorded)])
        except SystemExit as exc:  # the command's exit after the run
            if exc.code not in (0, None):
                return int(exc.code) if isinstance(exc.code, int) else 1
        lines = [json.loads(text) for text in recorded.read_text().splitlines() if text.strip()]
        written.write_text("".join(json.dumps(line, separators=(",", ":")) + "\n" for line in as_version_1(lines)))
        rec = read_recording(written)
        live = rec.localiser
        if rec.header["version"] != 1 or live is None or replay(rec, [live.name]).reproduced != {live.name: True}:
            print("example_recording: the version-1 copy does not replay bit for bit; nothing written",
                  file=sys.stderr)
            return 1
        args.out.write_bytes(written.read_bytes())
    print(f"wrote {args.out} ({args.out.stat().st_size // 1000} kB, format version 1)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
