"""Write the parameter reference (`toolkit.parameter_docs`) to standard output, or its JSON Schemas (the
plug-ins', the mission's and the challenge's settings) into a folder.

Usage: ``python tools/parameter_docs.py > docs/parameters.md`` and ``python tools/parameter_docs.py
--schemas docs/reference/schemas`` (a test keeps the committed files equal to them).
"""

import argparse
import sys
from pathlib import Path

from toolkit.parameter_docs import SCHEMA_PATTERNS, option_schemas, parameters_markdown

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--schemas", metavar="FOLDER", type=Path,
                        help="write one JSON Schema per plug-in, mission.json and challenge.json into FOLDER "
                             "(its old planner-*.json, localiser-*.json, mission.json and challenge.json removed "
                             "first; other schemas are left alone)")
    args = parser.parse_args()
    if args.schemas is None:
        sys.stdout.write(parameters_markdown())
    else:
        args.schemas.mkdir(parents=True, exist_ok=True)
        for old in [path for pattern in SCHEMA_PATTERNS for path in args.schemas.glob(pattern)]:
            old.unlink()
        for name, text in option_schemas().items():
            (args.schemas / name).write_text(text)
