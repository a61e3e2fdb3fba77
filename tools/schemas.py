"""Write the JSON Schemas of the files nxtnav reads and writes into ``docs/reference/schemas/``.

Usage: ``python tools/schemas.py`` (or ``python tools/schemas.py FOLDER``); ``--check`` writes nothing
and fails, naming the files, when the folder differs from the models (a test runs the same check).

Each schema comes from the typed model the file's reader and writer share: a recording's header and
event lines (`toolkit.recordings.format`), a row of a sweep set's ``sweeps.csv`` (`toolkit.real_sonar.sweeps.SweepRow`),
a map file (`toolkit.world.map_parsing.MapFile`), a sonar profile (`toolkit.real_sonar.profile_file.SonarProfileFile`),
an NXT robot profile (`toolkit.robots.nxt_profile.NxtProfile`) and the robot model a run's configuration holds
(`toolkit.world.robot_model.RobotModel`). File names start with the kind of file
(``recording-``, ``sweep-set``, ``map``, ``sonar-profile``, ``nxt-profile``, ``robot-model``), so other
schemas can share the folder: this tool writes and checks only its own files.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

FOLDER = Path(__file__).resolve().parent.parent / "docs" / "reference" / "schemas"
PREFIXES = ("recording-", "sweep-set", "map.", "sonar-profile.", "nxt-profile.", "robot-model.")
"""The names this tool owns in the folder."""


def _text(schema: dict[str, Any], title: str, description: str) -> str:
    """`schema` titled, as stable text (sorted keys, two-space indent, a final newline)."""
    schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema, "title": title,
              "description": description}
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def file_schemas() -> dict[str, str]:
    """The schema of each file kind, by file name, as the text written to the folder."""
    from toolkit.real_sonar.profile_file import SonarProfileFile
    from toolkit.real_sonar.sweeps import SweepRow
    from toolkit.recordings.format import FORMAT_NAME, FORMAT_VERSION, event_schema, header_schema
    from toolkit.robots.nxt_profile import NxtProfile
    from toolkit.world.map_parsing import MapFile
    from toolkit.world.robot_model import RobotModel
    from toolkit.world.typed import schema_of

    return {
        "recording-header.json": _text(header_schema(), f"{FORMAT_NAME} header (version {FORMAT_VERSION})",
                                       "The first line of a recording (nxtnav run --record)."),
        "recording-event.json": _text(event_schema(), f"{FORMAT_NAME} event (version {FORMAT_VERSION})",
                                      "Every line after the header: one of the event models, by its 'type'. "
                                      "Floats are numbers, the non-finite ones the strings inf, -inf, nan."),
        "sweep-set.json": _text(SweepRow.model_json_schema(), "nxtnav sweep set: a row of sweeps.csv",
                                "The columns of one sweep (every value is CSV text, read as the types below; "
                                "other columns are kept)."),
        "map.json": _text(MapFile.model_json_schema(), "nxtnav map file",
                          "A polygonal map (YAML, cm): boundary with obstacles, or regions; optional thin walls, "
                          "grid, start and target. The geometric rules (simple polygons, obstacles strictly inside "
                          "and apart, walls and presets in the free space) are checked by the reader."),
        "sonar-profile.json": _text(SonarProfileFile.model_json_schema(), "nxtnav sonar profile",
                                    "The nxt sonar's model (YAML) as nxtnav sonar fit writes it and --sonar-profile "
                                    "reads it."),
        "nxt-profile.json": _text(schema_of(NxtProfile), "nxtnav NXT robot profile",
                                  "Wiring and calibration of one LEGO NXT robot (YAML; --profile, nxtnav nxt "
                                  "calibrate). Every field is optional."),
        "robot-model.json": _text(schema_of(RobotModel), "nxtnav robot model",
                                  "The robot a run simulates or drives (the robot part of a run's configuration; "
                                  "--set robot.GROUP.FIELD=VALUE, --set sonar.FIELD=VALUE)."),
    }


def differences(folder: Path) -> list[str]:
    """The file names of `folder` this tool owns that differ from `file_schemas` (missing, stale, extra)."""
    want = file_schemas()
    have = {p.name for p in folder.glob("*.json") if p.name.startswith(PREFIXES)}
    return sorted(name for name in set(want) | have
                  if name not in want or not (folder / name).is_file() or (folder / name).read_text() != want[name])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=FOLDER, help="where the schemas go")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 when the folder differs")
    args = parser.parse_args(argv)
    stale = differences(args.folder)
    if args.check:
        if stale:
            print(f"schemas: {', '.join(stale)} differ from the models; run python tools/schemas.py", file=sys.stderr)
        return 1 if stale else 0
    args.folder.mkdir(parents=True, exist_ok=True)
    want = file_schemas()
    for name in stale:
        if name in want:
            (args.folder / name).write_text(want[name])
        else:
            (args.folder / name).unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
