"""`make view-check`: a screenshot of a saved run in Rerun's web viewer (`toolkit.view.check`).

Usage: ``python tools/view_check.py RUN.rrd [OUT.png]``; OUT.png defaults to ``out/rerun-view.png``
(untracked). The README's picture is updated only when asked: ``make view-check
VIEW_PNG=docs/img/rerun-view.png``. No viewer process outlives the command.
"""

import argparse
import sys
from pathlib import Path

from toolkit.view.check import DEFAULT_PNG, screenshot
from toolkit.world import NxtnavError

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Screenshot a saved run (.rrd) in Rerun's web viewer.")
    parser.add_argument("rrd", type=Path, metavar="RUN.rrd", help="a run saved with nxtnav run --view-save")
    parser.add_argument("png", type=Path, metavar="OUT.png", nargs="?", default=DEFAULT_PNG,
                        help=f"the screenshot to write (default: {DEFAULT_PNG})")
    args = parser.parse_args()
    if not args.rrd.is_file():
        parser.error(f"{args.rrd}: no such file")
    try:
        screenshot(args.rrd, args.png)
    except (RuntimeError, NxtnavError) as exc:
        sys.exit(f"view-check: {exc}")
    print(f"wrote {args.png}")
