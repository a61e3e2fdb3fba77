"""Importers of grid maps made elsewhere: ROS map_server (YAML + PGM/PNG) and Moving AI ``.map``.

Both read the cells with kept libraries (PyYAML, Pillow) and return an `OccupancyGrid`;
`import_map` polygonises it exactly into a `Map` (see `toolkit.world.grids`).

ROS map_server
    The YAML names the image, ``resolution`` (m per pixel), ``origin`` ``[x, y, yaw]`` (m, rad: the
    pose of the lower-left pixel), ``negate``, ``occupied_thresh``, ``free_thresh`` and an optional
    ``mode`` (``trinary``, the default, ``scale`` or ``raw``). In ``trinary`` and ``scale`` modes a
    pixel of value ``v`` (the first channel; 0..255) has occupancy ``p = (255 - v) / 255``
    (``v / 255`` when ``negate``): occupied when ``p > occupied_thresh``, free when
    ``p < free_thresh``, unknown otherwise. In ``raw`` mode the value is the occupancy in percent:
    free at 0, occupied from 1 to 100 (as nav2 reads a costmap) and unknown otherwise. Unknown cells
    are obstacles unless ``unknown="free"``. Metres become centimetres; a non-zero yaw is refused
    (maps are axis-aligned here).
Moving AI
    ``type octile``, ``height H``, ``width W``, ``map``, then H rows of W characters, row 0 on top;
    ``.``, ``G`` and ``S`` are passable, ``@``, ``O``, ``T`` and ``W`` blocked. A cell is
    ``cell_cm`` cm (default 1, so lengths compare with the published ``.scen`` lengths).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .arrays import FloatArray
from .errors import MapError
from .grids import OccupancyGrid, grid_to_map
from .map_model import Map
from .yaml_text import YAMLError, load_yaml

__all__ = ["MOVINGAI_BLOCKED", "MOVINGAI_PASSABLE", "import_map", "read_movingai_map", "read_ros_map",
           "write_movingai_map"]

MOVINGAI_PASSABLE = frozenset(".GS")
MOVINGAI_BLOCKED = frozenset("@OTW")
_ROS_FIELDS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}

Unknown = Literal["occupied", "free"]


def read_movingai_map(path: str | os.PathLike[str], cell_cm: float = 1.0) -> OccupancyGrid:
    """Read a Moving AI octile ``.map`` file (see the module docstring)."""
    p = Path(path)
    _check_cell(cell_cm, p)
    try:
        lines = p.read_text(encoding="ascii").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{p}: cannot read Moving AI map: {exc}") from None
    header: dict[str, str] = {}
    k = 0
    while k < len(lines) and lines[k].strip() != "map":
        parts = lines[k].split()
        if len(parts) != 2:
            raise MapError(f"{p}: line {k + 1}: expected a header line 'key value' or 'map', got {lines[k]!r}")
        header[parts[0]] = parts[1]
        k += 1
    if k == len(lines):
        raise MapError(f"{p}: no 'map' line (a Moving AI map has the header type, height, width, then 'map')")
    if header.get("type") != "octile":
        raise MapError(f"{p}: header 'type' must be octile, got {header.get('type')!r}")
    h, w = (_positive_int(header.get(key), f"{p}: header '{key}'") for key in ("height", "width"))
    rows = lines[k + 1:k + 1 + h]
    if len(rows) < h:
        raise MapError(f"{p}: header says height {h} but only {len(rows)} rows follow")
    extra = [r for r in lines[k + 1 + h:] if r.strip()]
    if extra:
        raise MapError(f"{p}: line {k + 2 + h}: text after the {h} map rows")
    grid = np.zeros((h, w), dtype=bool)
    for r, row in enumerate(rows):
        if len(row) != w:
            raise MapError(f"{p}: line {k + 2 + r} (map row {r}): {len(row)} characters, the header says width {w}")
        chars = set(row)
        bad = chars - MOVINGAI_PASSABLE - MOVINGAI_BLOCKED
        if bad:
            col = min(row.index(ch) for ch in bad)
            raise MapError(f"{p}: line {k + 2 + r} (map row {r}), column {col}: unknown terrain {row[col]!r}")
        codes = np.frombuffer(row.encode("ascii"), dtype=np.uint8)
        grid[r] = np.isin(codes, np.frombuffer("".join(sorted(MOVINGAI_PASSABLE)).encode(), dtype=np.uint8))
    return OccupancyGrid(np.flipud(grid).copy(), float(cell_cm), (0.0, 0.0))


def write_movingai_map(grid: OccupancyGrid, path: str | os.PathLike[str]) -> None:
    """Write `grid` as a Moving AI octile ``.map`` (``.`` free, ``@`` blocked, top row first), atomically."""
    p = Path(path)
    rows = np.where(np.flipud(grid.free), ord("."), ord("@")).astype(np.uint8)
    h, w = rows.shape
    body = "\n".join(r.tobytes().decode("ascii") for r in rows)
    tmp = p.with_name(p.name + ".part")
    tmp.write_text(f"type octile\nheight {h}\nwidth {w}\nmap\n{body}\n", encoding="ascii")
    tmp.replace(p)


def _ros_image_values(p: Path, name: Any) -> FloatArray:
    """The pixel values (0..255, first channel) of the image `name` of the ROS map YAML `p` (a path
    relative to the YAML's folder, or absolute)."""
    from PIL import Image, UnidentifiedImageError

    if not isinstance(name, str) or not name:
        raise MapError(f"{p}: image must be a file name, got {name!r}")
    image = Path(name) if Path(name).is_absolute() else p.parent / name
    if not image.is_file():
        raise MapError(f"{p}: image {str(image)!r} not found")
    try:
        with Image.open(image) as im:
            im.load()
            pixels = np.asarray(im)
    except (OSError, UnidentifiedImageError, ValueError, SyntaxError) as exc:
        raise MapError(f"{image}: cannot read map image: {exc}") from None
    if pixels.ndim == 3:
        pixels = pixels[..., 0]
    if pixels.ndim != 2 or pixels.size == 0:
        raise MapError(f"{image}: expected a 2-D image, got shape {pixels.shape}")
    v = pixels.astype(np.float64)
    if pixels.dtype != np.uint8:  # 16-bit PGM: bring to 0..255
        v = v * 255.0 / float(np.iinfo(pixels.dtype).max) if np.issubdtype(pixels.dtype, np.integer) else v
    return v


def read_ros_map(path: str | os.PathLike[str], unknown: Unknown = "occupied") -> OccupancyGrid:
    """Read a ROS map_server map: its YAML and the image it names (see the module docstring)."""
    p = Path(path)
    if unknown not in ("occupied", "free"):
        raise MapError(f"unknown cells must be 'occupied' or 'free', got {unknown!r}")
    try:
        data = load_yaml(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, YAMLError) as exc:
        raise MapError(f"{p}: cannot read ROS map YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise MapError(f"{p}: expected a ROS map_server mapping (image, resolution, origin, ...)")
    extra = sorted(str(k) for k in data if k not in _ROS_FIELDS)
    if extra:
        raise MapError(f"{p}: unknown field(s) {', '.join(extra)}; a ROS map has {', '.join(sorted(_ROS_FIELDS))}")
    for key in ("image", "resolution", "origin", "occupied_thresh", "free_thresh"):
        if key not in data:
            raise MapError(f"{p}: missing field '{key}'")
    res = _real(data["resolution"], f"{p}: resolution")
    if res <= 0:
        raise MapError(f"{p}: resolution must be positive (m per pixel), got {res}")
    origin = data["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        raise MapError(f"{p}: origin must be [x, y, yaw], got {origin!r}")
    ox, oy, yaw = (_real(v, f"{p}: origin[{i}]") for i, v in enumerate(origin))
    if yaw != 0.0:
        raise MapError(f"{p}: origin yaw {yaw} is not 0; rotated maps are not supported")
    occ_t = _real(data["occupied_thresh"], f"{p}: occupied_thresh")
    free_t = _real(data["free_thresh"], f"{p}: free_thresh")
    if not 0.0 <= free_t <= occ_t <= 1.0:
        raise MapError(f"{p}: need 0 <= free_thresh <= occupied_thresh <= 1, got {free_t} and {occ_t}")
    negate = data.get("negate", 0)
    if negate not in (0, 1, True, False):
        raise MapError(f"{p}: negate must be 0 or 1, got {negate!r}")
    mode = data.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise MapError(f"{p}: mode must be trinary, scale or raw, got {mode!r}")
    v = _ros_image_values(p, data["image"])
    if mode == "raw":
        occupied = (v >= 1) & (v <= 100)
        free = v == 0
    else:
        occ = v / 255.0 if negate else (255.0 - v) / 255.0
        occupied = occ > occ_t
        free = occ < free_t
    unknown_cells = ~occupied & ~free
    cells = free | unknown_cells if unknown == "free" else free
    return OccupancyGrid(np.flipud(cells).copy(), 100.0 * res, (100.0 * ox, 100.0 * oy))


def import_map(path: str | os.PathLike[str], *, cell_cm: float | None = None, unknown: Unknown = "occupied",
               simplify_cm: float = 0.0, name: str | None = None) -> Map:
    """Import a Moving AI ``.map`` or a ROS map_server ``.yaml`` as an exact polygonal `Map`.

    Parameters
    ----------
    path : path
        The ``.map`` file, or the ROS map's YAML file.
    cell_cm : float, optional
        Moving AI cell size in cm (default 1). A ROS map's cell is its resolution; giving a different
        value is an error.
    unknown : {"occupied", "free"}
        What unknown ROS cells are.
    simplify_cm : float
        Simplify outlines by up to this many cm, growing obstacles only (0: exact).
    name : str, optional
        Map name (default: the file name without its suffix).
    """
    p = Path(path)
    if not p.is_file():
        raise MapError(f"map file {str(p)!r} not found")
    if not (math.isfinite(simplify_cm) and simplify_cm >= 0):
        raise MapError(f"simplify must be a non-negative number of cm, got {simplify_cm!r}")
    if p.suffix == ".map":
        grid = read_movingai_map(p, 1.0 if cell_cm is None else cell_cm)
        kind = "Moving AI map"
    else:
        grid = read_ros_map(p, unknown)
        kind = "ROS map_server map"
        if cell_cm is not None and not math.isclose(cell_cm, grid.cell_cm):
            raise MapError(f"{p}: a ROS map's cell is its resolution ({grid.cell_cm:g} cm); --cell-cm does not apply")
    desc = f"{kind} {p.name}, {grid.free.shape[1]} x {grid.free.shape[0]} cells of {grid.cell_cm:g} cm"
    if simplify_cm:
        desc += f", simplified by {simplify_cm:g} cm"
    try:
        m = grid_to_map(grid, name or p.stem.removesuffix(".map"), desc, simplify_cm)
    except MapError as exc:
        raise MapError(f"{p}: {exc}") from None
    return _with_source(m, p)


def _with_source(m: Map, source: Path) -> Map:
    object.__setattr__(m, "source", source)
    return m


def _check_cell(cell_cm: float, p: Path) -> None:
    if not (isinstance(cell_cm, int | float) and math.isfinite(cell_cm) and cell_cm > 0):
        raise MapError(f"{p}: cell size must be a positive number of cm, got {cell_cm!r}")


def _positive_int(value: Any, where: str) -> int:
    try:
        n = int(str(value))
    except ValueError:
        raise MapError(f"{where}: expected a positive integer, got {value!r}") from None
    if n <= 0:
        raise MapError(f"{where}: expected a positive integer, got {n}")
    return n


def _real(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapError(f"{where}: expected a finite number, got {value!r}")
    return float(value)

