"""The data that ships with nxtnav: maps, sweep sets, sonar profiles and their notices.

In the repository the data lives in the top-level folder ``maps/``; an installed nxtnav carries the
same files as the package ``toolkit.data``, so they are found through ``importlib.resources`` in a
clone (an editable install) and in a wheel alike. Commands that read a data file take the paths the
documentation shows (``maps/real-nxt``, ``maps/external/arena2.map.scen``) from any folder:
`data_path` looks a relative path under ``maps/`` up in the shipped data when no such file is where
the command runs.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path, PurePath

from .errors import NxtnavError

__all__ = ["DATA_FOLDER", "DATA_PACKAGE", "NOTICES_FILE", "DataNotice", "data_notices", "data_path", "data_root"]

DATA_PACKAGE = "toolkit.data"
"""The package that holds the shipped data once installed."""
DATA_FOLDER = "maps"
"""The same data's folder in the repository, and the first part of the paths the documentation shows."""
NOTICES_FILE = "NOTICES.md"
"""The list of the shipped files made elsewhere, at the top of the data folder."""


def data_root() -> Path:
    """The folder of the shipped data (the repository's ``maps/``; ``toolkit/data`` in a wheel).

    Raises
    ------
    NxtnavError
        When the package is missing (a source tree used without installing it) or installed in a
        form whose files are not on disk (a zip archive).
    """
    try:
        root = resources.files(DATA_PACKAGE)
    except ModuleNotFoundError:
        raise NxtnavError(f"the shipped data (package {DATA_PACKAGE}) is not installed: install nxtnav "
                          "(pip install nxtnav, or make install in a clone)") from None
    if not isinstance(root, Path) or not root.is_dir():
        raise NxtnavError(f"the shipped data ({root}) is not a folder on disk; install nxtnav unpacked "
                          "(pip install), not as a zip archive")
    return root


def data_path(path: str | os.PathLike[str]) -> Path:
    """A data file or folder as a person names it: the path itself when it exists; otherwise a
    relative path whose first part is ``maps`` names the shipped copy, when there is one.

    Any other path comes back unchanged, so that the command reading it reports it missing.

    >>> data_path("maps/map1.yaml").name
    'map1.yaml'
    >>> data_path("maps/real-nxt/sweeps.csv").is_file()
    True
    >>> str(data_path("elsewhere/none.csv"))
    'elsewhere/none.csv'
    """
    p = Path(path)
    if p.exists() or p.is_absolute():
        return p
    parts = PurePath(p).parts
    if len(parts) < 1 or parts[0] != DATA_FOLDER:
        return p
    shipped = data_root().joinpath(*parts[1:])
    return shipped if shipped.exists() else p


@dataclass(frozen=True)
class DataNotice:
    """One row of the data's ``NOTICES.md``: files made elsewhere, where from, and under what licence.

    Paths are relative to the data folder (`data_root`).
    """

    folder: str
    files: str
    source: str
    licence: str
    notices: tuple[str, ...]
    """The licence texts and notices that travel with the files."""


def data_notices(root: Path | None = None) -> list[DataNotice]:
    """The rows of ``NOTICES.md`` in `root` (default `data_root`), in the file's order.

    >>> any(n.licence == "Apache-2.0" for n in data_notices())
    True
    """
    path = (root or data_root()) / NOTICES_FILE
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or not cells[0].startswith("`"):
            continue  # prose, the header or its rule
        folder, files, source, licence, notices = cells
        rows.append(DataNotice(folder.strip("`"), files, source, licence,
                               tuple(re.findall(r"`([^`]+)`", notices))))
    return rows
