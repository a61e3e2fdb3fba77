"""`python -m toolkit.cli` runs the `nxtnav` command."""

from . import main

main()
