"""Write the parameter reference (`toolkit.parameter_docs`) to standard output, or the plug-ins' JSON
Schemas into a folder.

Usage: ``python tools/parameter_docs.py > docs/parameters.md`` and ``python tools/parameter_docs.py
--schemas docs/reference/schemas`` (a test keeps the committed files equal to them).
"""

import argparse
import sys
from pathlib import Path

from toolkit.parameter_docs import option_schemas, parameters_markdown

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--schemas", metavar="FOLDER", type=Path,
                        help="write one JSON Schema per plug-in into FOLDER (its old planner-*.json and "
                             "localiser-*.json removed first; other schemas are left alone)")
    args = parser.parse_args()
    if args.schemas is None:
        sys.stdout.write(parameters_markdown())
    else:
        args.schemas.mkdir(parents=True, exist_ok=True)
        for old in [*args.schemas.glob("planner-*.json"), *args.schemas.glob("localiser-*.json")]:
            old.unlink()
        for name, text in option_schemas().items():
            (args.schemas / name).write_text(text)
