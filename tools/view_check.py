"""`make view-check`: a screenshot of a saved run in Rerun's web viewer (`toolkit.view.check`).

Usage: ``python tools/view_check.py RUN.rrd OUT.png``
"""

import sys
from pathlib import Path

from toolkit.view.check import screenshot

if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python tools/view_check.py RUN.rrd OUT.png")
    screenshot(Path(sys.argv[1]), Path(sys.argv[2]))
    sys.stdout.write(f"wrote {sys.argv[2]}\n")
