"""Polygonal maps: loading and validating map files, free space, sampling.

A map file is YAML with the fields (units: cm)::

    name: map1                      # optional, defaults to the file name
    description: BotSim map 1       # optional
    boundary: [[0, 0], [60, 0], ...]            # >= 3 vertices, simple polygon, non-zero area
    obstacles: [[[20, 20], [30, 20], [30, 30]]] # optional: polygons strictly inside, not overlapping
    walls: [[[40, 0], [40, 30]]]    # optional: thin walls (zero thickness), each a polyline of >= 2 points
    start: [20, 20]                 # optional preset, must lie in free space
    target: [80, 80]                # optional preset, must lie in free space

A map with several disjoint free regions (an imported grid map, say) lists them instead of
``boundary`` and ``obstacles``::

    regions:                        # each a polygon with holes; holes may touch the boundary or each
      - boundary: [[0, 0], ...]     # other at single points (as in a grid map's double corners)
        holes: [[[2, 2], ...], ...]
      - boundary: [[50, 0], ...]
    grid: {cell_cm: 1.0, origin: [0, 0], width: 281, height: 209}   # optional: the cells it came from

A thin wall (a free-standing stub of cardboard or plywood) is a polyline ``[[x, y], [x, y], ...]``
whose consecutive points are its segments (``[[x1, y1], [x2, y2]]`` for one segment). Each segment
has non-zero length and lies in the closure of the free area (it may touch the boundary or run along
it, never leave it or enter an obstacle). Thin walls are walls like any other (`Map.walls` lists them
after the polygons' edges, so rays stop at them and the disc checkers keep clear of them), and a point
on one is not free: `Map.contains` and every checker refuse it, even for a point robot, so no motion
crosses or touches one. Both forms (``boundary`` and ``regions``) may have ``walls``.

Points where the free space's boundary touches itself (``Map.pinch_points``) close the passage:
no motion may pass through one.

Names such as ``map1`` resolve to the files in the shipped data's ``maps/``, ``maps/external/``,
``maps/real-nxt/`` and ``maps/jarvis/`` folders (`toolkit.world.bundled`: the repository's ``maps/``, installed as the
package ``toolkit.data``), and to files in the folders listed in the environment variable
``NXTNAV_MAPS`` (separated like ``PATH``). A file's name is its stem, except that the map of a sweep
set (`toolkit.real_sonar.sweeps`), which is always called ``arena.yaml``, goes by its ``name`` field
(``co333-arena`` for ``maps/real-nxt/arena.yaml``). Besides the YAML files above, a name may be a
Moving AI ``.map`` file or a ROS map_server YAML, which are imported (`toolkit.world.importers`).
"""


import os
from pathlib import Path
from typing import Any

from .bundled import data_path, data_root
from .errors import MapError
from .importers import import_map
from .map_model import THIN_WALL_SLIT_CM, GridSpec, Map, Region
from .map_parsing import MAP_FIELDS, map_from_dict
from .map_rings import COORDINATE_LIMIT_CM
from .yaml_text import YAMLError, load_yaml

__all__ = ["COORDINATE_LIMIT_CM", "MAP_FIELDS", "THIN_WALL_SLIT_CM", "GridSpec", "Map", "Region", "list_maps",
           "load_map", "map_from_dict", "map_search_path"]

_BUNDLED_FOLDERS = (".", "external", "real-nxt", "jarvis")
"""The folders of the shipped data that hold maps, relative to `toolkit.world.bundled.data_root`."""
_MAP_GLOBS = ("*.yaml", "*.yml", "*.map")
_SWEEP_SET_MAP = "arena.yaml"
"""File name of a sweep set's map: such a file is listed under its ``name`` field, not its stem."""


def map_search_path() -> list[Path]:
    """Folders searched for map names: ``$NXTNAV_MAPS`` entries first, then the shipped ``maps/``,
    ``maps/external/``, ``maps/real-nxt/`` and ``maps/jarvis/`` (wherever nxtnav is installed)."""
    extra = [Path(p) for p in os.environ.get("NXTNAV_MAPS", "").split(os.pathsep) if p]
    root = data_root()
    return [*extra, *(root / f for f in _BUNDLED_FOLDERS)]


def list_maps() -> dict[str, Path]:
    """Map names that resolve, mapped to their files (earlier search folders win)."""
    found: dict[str, Path] = {}
    for folder in map_search_path():
        if folder.is_dir():
            for f in sorted(f for pattern in _MAP_GLOBS for f in folder.glob(pattern)):
                found.setdefault(_listed_name(f), f)
    return dict(sorted(found.items()))


def _listed_name(path: Path) -> str:
    """The name a map file resolves by: its stem, or a sweep set's map's own ``name`` field (the stem
    when that field is missing or the file unreadable, so that `load_map` reports the problem)."""
    if path.name != _SWEEP_SET_MAP:
        return path.stem
    try:
        data = _read_yaml(path)
    except MapError:
        return path.stem
    name = data.get("name") if isinstance(data, dict) else None
    return name if isinstance(name, str) and name else path.stem


def _resolve(name_or_path: str | os.PathLike[str]) -> Path:
    p = data_path(name_or_path)
    if p.suffix in (".yaml", ".yml", ".map") or p.is_file() or os.sep in str(name_or_path):
        if not p.is_file():
            raise MapError(f"map file {str(p)!r} not found")
        return p
    known = list_maps()
    if str(name_or_path) in known:
        return known[str(name_or_path)]
    raise MapError(f"unknown map {str(name_or_path)!r}; known: {', '.join(known) or 'none'} (or give a path)")


def load_map(name_or_path: str | os.PathLike[str] | Map) -> Map:
    """Load and validate a map by name (``map1``) or path (``maps/map1.yaml``).

    A Moving AI ``.map`` file or a ROS map_server YAML (one with an ``image`` field) is imported with
    the defaults of `toolkit.world.importers.import_map` (1 cm per Moving AI cell; unknown ROS cells
    are obstacles); call that function for other options.

    Raises
    ------
    MapError
        With the file and the field, vertex or value at fault.
    """
    if isinstance(name_or_path, Map):
        return name_or_path
    path = _resolve(name_or_path)
    if path.suffix == ".map":
        return import_map(path)
    data = _read_yaml(path)
    if isinstance(data, dict) and "image" in data and "boundary" not in data and "regions" not in data:
        return import_map(path)
    return map_from_dict(data, source=path, default_name=path.stem)


def _read_yaml(path: Path) -> Any:
    """Parse a YAML file (the C parser when PyYAML has it) or raise a one-line `MapError`."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}: cannot read map file: {exc}") from None
    try:
        return load_yaml(text)
    except YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise MapError(f"{path}: not valid YAML{where}: {problem}") from None
