"""Write the command-line reference (`toolkit.cli.reference`) to standard output.

Usage: ``python tools/cli_docs.py > docs/reference/cli.md`` (a test keeps the file equal to it).
"""

import sys

from toolkit.cli.reference import cli_markdown

if __name__ == "__main__":
    sys.stdout.write(cli_markdown())
