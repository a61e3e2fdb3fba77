"""Write the parameter reference (`toolkit.parameter_docs`) to standard output.

Usage: ``python tools/parameter_docs.py > docs/parameters.md`` (a test keeps the file equal to it).
"""

import sys

from toolkit.parameter_docs import parameters_markdown

if __name__ == "__main__":
    sys.stdout.write(parameters_markdown())
