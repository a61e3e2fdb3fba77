"""Expected sonar ranges from a precomputed `RangeTable`: a grid of positions x absolute directions built
once per map with `ray_cast`, cached in memory (and optionally on disk, `$NXTNAV_CACHE_DIR`), planned to
fit a memory budget; and `RangeLattice`, the FFT scan correlation over a lattice of poses."""

from __future__ import annotations

import hashlib
import logging
import math
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from toolkit.world import ConfigError, Map, ray_cast
from toolkit.world.arrays import FloatArray

__all__ = [
    "DEFAULT_RANGE_MEMORY_MB",
    "RANGE_MEMORY_ENV",
    "RESOLUTION_LADDER_CM",
    "RangeLattice",
    "RangeTable",
    "TablePlan",
    "cache_dir_from_env",
    "clear_range_table_cache",
    "lobe_minimum",
    "map_geometry_key",
    "plan_range_table",
    "range_lattice",
    "range_memory_budget",
    "range_table",
    "write_cache_file",
]

log = logging.getLogger(__name__)

TWO_PI = 2.0 * math.pi


def cache_dir_from_env() -> Path | None:
    """The disk cache folder of the map tables, ``$NXTNAV_CACHE_DIR``; None (memory only) when unset or empty."""
    env = os.environ.get("NXTNAV_CACHE_DIR")
    if env is not None:
        return Path(env) if env else None
    return None


def lobe_minimum(ranges: ArrayLike, beam_width_deg: float) -> NDArray[np.float32]:
    """Circular minimum over each row's directions within +-beam_width_deg/2 (rows: positions).

    A row holds the ranges along ``n`` evenly spaced directions from one position; the result is
    what a sonar with that lobe reads if every ray of the lobe echoes (specular loss is not modelled).
    """
    r = np.asarray(ranges, dtype=np.float32)
    n = r.shape[1]
    half = round(beam_width_deg / 2.0 / (360.0 / n))
    if half <= 0:
        return r
    import scipy.ndimage  # here, not at the top: it costs every process half a second at start

    return np.asarray(scipy.ndimage.minimum_filter1d(r, size=2 * half + 1, axis=1, mode="wrap"), dtype=np.float32)


RANGE_MEMORY_ENV = "NXTNAV_RANGE_MEMORY_MB"
DEFAULT_RANGE_MEMORY_MB = 1024.0
RESOLUTION_LADDER_CM = (1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0)
"""Cell sizes a bounded range model may fall back to, finest first (never coarser than 5 cm)."""
_NO_RANGE = np.iinfo(np.uint16).max
_BUILD_ROWS = 2048


def range_memory_budget(memory_mb: float | None = None) -> int:
    """The range model's memory budget in bytes: `memory_mb`, else ``$NXTNAV_RANGE_MEMORY_MB``, else 1024 MB.

    Raises
    ------
    LocalisationError
        When the budget is not a positive number (the message names the option and the variable).
    """
    source = "range_memory_mb"
    if memory_mb is None:
        env = os.environ.get(RANGE_MEMORY_ENV)
        memory_mb, source = (DEFAULT_RANGE_MEMORY_MB, "") if not env else (env, f"${RANGE_MEMORY_ENV}")  # type: ignore[assignment]
    try:
        mb = float(memory_mb)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        mb = float("nan")
    if not (math.isfinite(mb) and mb > 0):
        raise ConfigError(f"range model memory budget must be a positive number of MB, got {memory_mb!r} "
                          f"({source or 'range_memory_mb'}; CLI: --range-memory-mb or "
                          "--set ranges.range_memory_mb=MB)")
    return int(mb * 2**20)


@dataclass(frozen=True)
class TablePlan:
    """Cell size and storage chosen for a range table under a memory budget.

    ``dtype`` is float32 (exact ranges) or uint16 (ranges in steps of ``quantum_cm``; 65535 = no wall).
    """

    resolution_cm: float
    dtype: str
    quantum_cm: float
    estimated_bytes: int


def plan_range_table(map: Map, n_angles: int, budget_bytes: int, resolution_cm: float = 1.0,
                     with_lattice_step: int | None = None) -> TablePlan:
    """The finest table (then float32 before uint16) whose estimated memory fits `budget_bytes`.

    The estimate is the free area over the cell area times `n_angles` entries, plus, with
    `with_lattice_step`, the FFT spectra of the global-start lattice (`RangeLattice`).

    Raises
    ------
    LocalisationError
        When even 5 cm cells of uint16 do not fit (naming the budget option).
    """
    xmin, ymin, xmax, ymax = map.bounds
    quantum = math.hypot(xmax - xmin, ymax - ymin) / (_NO_RANGE - 1)
    area = map.area
    est = 0
    for res in [r for r in RESOLUTION_LADDER_CM if r >= resolution_cm] or [resolution_cm]:
        cells = area / res**2 * 1.03 + 1
        lattice = 0.0
        if with_lattice_step:
            lattice = cells / with_lattice_step**2 * 2 * (n_angles // 2 + 1) * 16
        for dtype, size in (("float32", 4), ("uint16", 2)):
            est = int(cells * n_angles * size + lattice)
            if est <= budget_bytes:
                return TablePlan(res, dtype, quantum if dtype == "uint16" else 0.0, est)
    raise ConfigError(
        f"map {map.name!r}: its range model needs about {est / 2**20:.0f} MB even with "
        f"{max(RESOLUTION_LADDER_CM[-1], resolution_cm):g} cm cells, more than the budget of "
        f"{budget_bytes / 2**20:.3g} MB; "
        f"raise range_memory_mb (CLI: --range-memory-mb or --set range_memory_mb=MB; or ${RANGE_MEMORY_ENV})")


class RangeTable:
    """Precomputed expected ranges on a grid of positions x absolute directions for one map.

    The grid covers the map's bounds with square cells of `resolution_cm`; for every cell whose centre
    lies inside the free area the range along each of `n_angles` absolute directions (``k * 2 pi /
    n_angles``) is ray cast once from the cell centre. Lookups are nearest-cell, nearest-direction:
    with 1 cm cells and 1-degree directions the table's error is a few millimetres except at range
    discontinuities (corners), and the final refinement of a filter can switch to `exact_ranges`.

    With ``beam_width_deg > 0`` each entry is the smallest range within the lobe around its direction
    (`lobe_minimum`): a wide sonar such as the NXT's reports the nearest echo in its lobe. With a
    `critical_incidence_deg` as well, rays meeting their wall further than that from its normal
    do not echo (specular loss), as in `toolkit.world.NxtSonar`; ``inf`` where nothing echoes.

    The table is stored as float32 or, to halve its memory, as uint16 in steps of `quantum_cm`
    (65535 = no wall); it is built in blocks of cells, so building needs no more memory than the
    table itself. `range_table` chooses the cell size and storage that fit a memory budget.

    Build it with `range_table` (cached per map and resolution), not directly.

    Parameters
    ----------
    map : Map
    resolution_cm : float
        Cell size (cm).
    n_angles : int
        Directions per cell.
    ranges : (n_inside, n_angles) ndarray, optional
        Precomputed stored table (from the disk cache), of `dtype`.
    beam_width_deg : float
        Full lobe width (0: a thin ray).
    critical_incidence_deg : float, optional
        Specular loss beyond this incidence (only with a lobe).
    dtype : {"float32", "uint16"}
        Storage of the ranges.
    quantum_cm : float
        Step of the uint16 storage (cm); ignored for float32.
    max_range_cm : float, optional
        Walls farther than this are not seen (``inf``): a range-limited sensor such as the NXT's
        255 cm; rays stop there, which makes building fast on large open maps.
    """

    def __init__(self, map: Map, resolution_cm: float = 1.0, n_angles: int = 360,
                 ranges: NDArray[Any] | None = None, beam_width_deg: float = 0.0,
                 critical_incidence_deg: float | None = None, dtype: str = "float32", quantum_cm: float = 0.0,
                 max_range_cm: float | None = None) -> None:
        if not (resolution_cm > 0 and math.isfinite(resolution_cm)):
            raise ConfigError(f"resolution_cm must be a positive number, got {resolution_cm!r}")
        if n_angles < 4:
            raise ConfigError(f"n_angles must be >= 4, got {n_angles}")
        if dtype not in ("float32", "uint16") or (dtype == "uint16" and not quantum_cm > 0):
            raise ConfigError(f"dtype must be float32 or uint16 with a positive quantum, got {dtype!r}, {quantum_cm!r}")
        self.map_name = map.name
        self.resolution_cm = float(resolution_cm)
        self.n_angles = int(n_angles)
        self.dtype = dtype
        self.quantum_cm = float(quantum_cm) if dtype == "uint16" else 0.0
        xmin, ymin, xmax, ymax = map.bounds
        self.origin = np.array([xmin, ymin])
        self.shape = (math.ceil((xmax - xmin) / resolution_cm), math.ceil((ymax - ymin) / resolution_cm))
        nx, ny = self.shape
        ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        centres = self.origin + (np.column_stack([ix.ravel(), iy.ravel()]) + 0.5) * resolution_cm
        inside = np.asarray(map.contains(centres), dtype=bool)
        self.cell_row = np.full(nx * ny, -1, dtype=np.int64)
        self.cell_row[inside] = np.arange(int(inside.sum()))
        self.centres = centres[inside]
        self.clearance = np.full(nx * ny, -1.0, dtype=np.float32)
        self.clearance[inside] = np.asarray(map.wall_distance(self.centres), dtype=np.float32)
        self.critical_incidence_deg = critical_incidence_deg if beam_width_deg > 0 else None
        self.beam_width_deg = float(beam_width_deg)
        self.max_range_cm = None if max_range_cm is None else float(max_range_cm)
        if ranges is None:
            ranges = self._build(map)
        if ranges.shape != (self.centres.shape[0], self.n_angles) or ranges.dtype != np.dtype(dtype):
            raise ConfigError(f"range table {ranges.shape} {ranges.dtype} does not match the grid / {dtype}")
        self.ranges = np.ascontiguousarray(ranges)
        self._flat = self.ranges.ravel()
        self._k = self.n_angles / TWO_PI

    def _build(self, map: Map) -> NDArray[Any]:
        """Cast the table block by block, storing each block at once."""
        out = np.empty((self.centres.shape[0], self.n_angles), dtype=self.dtype)
        directions = np.arange(self.n_angles) * (TWO_PI / self.n_angles)
        cos_crit = math.cos(math.radians(self.critical_incidence_deg or 0.0))
        reach = math.inf if self.max_range_cm is None else self.max_range_cm
        for s in range(0, len(out), _BUILD_ROWS):
            rows = slice(s, s + _BUILD_ROWS)
            if self.critical_incidence_deg is not None:
                # a ray meeting its wall further than the critical angle from the normal reflects away
                r, hit = ray_cast(map.walls, self.centres[rows], directions, return_wall=True, max_range=reach)
                w = map.walls[np.maximum(hit, 0)]
                ex, ey = w[..., 2] - w[..., 0], w[..., 3] - w[..., 1]
                cos_inc = np.abs(np.cos(directions)[None, :] * ey - np.sin(directions)[None, :] * ex) / np.hypot(ex, ey)
                r = np.where((hit >= 0) & (cos_inc >= cos_crit), r, np.inf)
            else:
                r = ray_cast(map.walls, self.centres[rows], directions, max_range=reach)
            if self.beam_width_deg > 0:
                r = lobe_minimum(r, self.beam_width_deg)
            out[rows] = self._encode(np.asarray(r))
        return out

    def _encode(self, r: NDArray[Any]) -> NDArray[Any]:
        if self.dtype == "float32":
            return r.astype(np.float32)
        q = np.rint(np.where(np.isfinite(r), r, 0.0) / self.quantum_cm)
        return np.where(np.isfinite(r) & (q < _NO_RANGE), q, _NO_RANGE).astype(np.uint16)

    def _decode_values(self, v: NDArray[Any]) -> NDArray[np.float32]:
        if self.dtype == "float32":
            return np.asarray(v)
        out = v.astype(np.float32) * np.float32(self.quantum_cm)
        out[v == _NO_RANGE] = np.inf
        return out

    def decode(self, rows: ArrayLike) -> NDArray[np.float32]:
        """The stored ranges (cm, float32; inf: no wall) of table rows `rows`, shape (len(rows), n_angles)."""
        return self._decode_values(self.ranges[np.asarray(rows, dtype=np.int64)])

    @property
    def nbytes(self) -> int:
        """Memory of the stored ranges (bytes)."""
        return int(self.ranges.nbytes)

    def cells(self, xy: ArrayLike) -> NDArray[np.int64]:
        """Row of the table for each position (N, 2); -1 outside the grid or the free area."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        g = np.floor((p - self.origin) / self.resolution_cm).astype(np.int64)
        nx, ny = self.shape
        ok = (g[:, 0] >= 0) & (g[:, 0] < nx) & (g[:, 1] >= 0) & (g[:, 1] < ny)
        flat = np.where(ok, g[:, 0] * ny + g[:, 1], 0)
        return np.where(ok, self.cell_row[flat], -1)

    def free(self, xy: ArrayLike, clearance: float = 0.0) -> NDArray[np.bool_]:
        """Whether each position's cell is inside the free area with at least `clearance` cm to the walls."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        g = np.floor((p - self.origin) / self.resolution_cm).astype(np.int64)
        nx, ny = self.shape
        ok = (g[:, 0] >= 0) & (g[:, 0] < nx) & (g[:, 1] >= 0) & (g[:, 1] < ny)
        flat = np.where(ok, g[:, 0] * ny + g[:, 1], 0)
        return ok & (self.clearance[flat] >= max(clearance, 0.0))

    def lookup(self, poses: ArrayLike, rel_angles: ArrayLike) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """Expected ranges (N, B) for poses (N, 3) and sensor angles (B,) relative to the heading.

        Nearest direction; nearest cell for 1 cm tables, and for coarser ones (a map under a memory
        budget) bilinear between the four surrounding cell centres where all four are free and see a
        wall (the nearest cell elsewhere), so that an estimate does not snap to the cell centres.

        Returns the ranges (float32, cm) and a (N,) mask of poses inside the table (others read 0).
        """
        p = np.asarray(poses, dtype=float).reshape(-1, 3)
        rows = self.cells(p[:, :2])
        inside = rows >= 0
        rows = np.where(inside, rows, 0)
        head = np.rint(p[:, 2] * self._k).astype(np.int64)
        rel = np.rint(np.asarray(rel_angles, dtype=float).ravel() * self._k).astype(np.int64)
        direction = (head[:, None] + rel[None, :]) % self.n_angles
        near = self._decode_values(self._flat[direction + (rows * self.n_angles)[:, None]])
        if self.resolution_cm <= 1.0:
            return near, inside
        u = (p[:, :2] - self.origin) / self.resolution_cm - 0.5
        g = np.floor(u).astype(np.int64)
        f = u - g
        nx, ny = self.shape
        total = np.zeros(near.shape, dtype=np.float32)
        ok = np.ones(len(p), dtype=bool)
        for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
            gi, gj = g[:, 0] + di, g[:, 1] + dj
            valid = (gi >= 0) & (gi < nx) & (gj >= 0) & (gj < ny)
            r = np.where(valid, self.cell_row[np.where(valid, gi * ny + gj, 0)], -1)
            ok &= r >= 0
            w = ((f[:, 0] if di else 1.0 - f[:, 0]) * (f[:, 1] if dj else 1.0 - f[:, 1])).astype(np.float32)
            at = direction + (np.maximum(r, 0) * self.n_angles)[:, None]
            total += w[:, None] * self._decode_values(self._flat[at])
        blend = ok[:, None] & np.isfinite(total)
        return np.where(blend, total, near).astype(np.float32), inside


def quantise_ranges(ranges: ArrayLike, step_cm: float, top: int) -> NDArray[np.int64]:
    """Ranges (cm) in whole steps of `step_cm`, rounded; inf and anything above `top` steps give `top`."""
    e = np.asarray(ranges, dtype=np.float32)
    with np.errstate(invalid="ignore"):
        i = np.rint(np.where(np.isfinite(e), e, np.float32(1e9)) / np.float32(step_cm))
    return np.minimum(i, top).astype(np.int64)


class RangeLattice:
    """Exhaustive scoring of a lattice of poses (every `step` cells x every table direction) by FFT.

    For a scan with beams at table directions ``a_j`` (relative) and readings ``m_j``, the sum of
    squared residuals of the pose (cell c, heading h) is
    ``sum_j (E[c, h + a_j] - m_j)^2 = (E^2 * I)(h) - 2 (E * M)(h) + sum_j m_j^2`` where ``*`` is the
    circular cross-correlation over directions, ``I`` counts beams per direction and ``M`` sums their
    readings. The spectra of ``E`` and ``E^2`` are computed once per lattice, so scoring every
    heading of every lattice cell costs one complex product and one inverse real FFT per scan.

    Parameters
    ----------
    table : RangeTable
    step : int
        Lattice spacing in table cells (2 with a 1 cm table: a 2 cm lattice).
    clearance_cm : float
        Only cells at least this far from every wall.
    """

    def __init__(self, table: RangeTable, step: int = 2, clearance_cm: float = 0.0) -> None:
        if step < 1:
            raise ConfigError(f"lattice step must be >= 1 cell, got {step}")
        nx, ny = table.shape
        ix, iy = np.meshgrid(np.arange(0, nx, step), np.arange(0, ny, step), indexing="ij")
        flat = (ix * ny + iy).ravel()
        rows = table.cell_row[flat]
        ok = (rows >= 0) & (table.clearance[flat] >= clearance_cm)
        self.table = table
        self.step = int(step)
        self.rows = rows[ok]
        self.xy = table.origin + (np.column_stack([ix.ravel()[ok], iy.ravel()[ok]]) + 0.5) * table.resolution_cm
        e = np.minimum(table.decode(self.rows).astype(np.float64), 1e4)
        self._fe = np.fft.rfft(e, axis=1)
        self._fe2 = np.fft.rfft(e * e, axis=1)
        self._quantised: dict[float, NDArray[np.uint16]] = {}

    def __len__(self) -> int:
        return int(self.rows.size)

    def quantised(self, step_cm: float) -> NDArray[np.uint16]:
        """The lattice cells' expected ranges (P, n_angles) in steps of `step_cm`, rounded (inf and
        anything beyond the uint16 range: 65535); computed once per step."""
        q = self._quantised.get(step_cm)
        if q is None:
            q = np.ascontiguousarray(quantise_ranges(self.table.decode(self.rows), step_cm, 65535).astype(np.uint16))
            self._quantised[step_cm] = q
        return q

    def ssd(self, rel_angles: ArrayLike, measured: ArrayLike) -> FloatArray:
        """Sum of squared residuals (cm^2) of every lattice cell x every heading: (P, n_angles)."""
        n = self.table.n_angles
        k = n / TWO_PI
        a = np.mod(np.rint(np.asarray(rel_angles, dtype=float).ravel() * k).astype(np.int64), n)
        m = np.asarray(measured, dtype=float).ravel()
        count = np.bincount(a, minlength=n).astype(float)
        total = np.bincount(a, weights=m, minlength=n)
        fi = np.conj(np.fft.rfft(count))
        fm = np.conj(np.fft.rfft(total))
        out = np.fft.irfft(self._fe2 * fi[None, :] - 2.0 * self._fe * fm[None, :], n=n, axis=1)
        out += float(np.sum(m * m))
        return np.asarray(np.maximum(out, 0.0))


_LATTICES: dict[tuple[int, int, float], RangeLattice] = {}


def range_lattice(table: RangeTable, step: int = 2, clearance_cm: float = 0.0) -> RangeLattice:
    """The `RangeLattice` of a table (cached per table, step and clearance)."""
    key = (id(table), int(step), float(clearance_cm))
    with _TABLES_LOCK:
        lat = _LATTICES.get(key)
        if lat is None or lat.table is not table:
            lat = RangeLattice(table, step, clearance_cm)
            _LATTICES[key] = lat
        return lat


_TABLES: dict[tuple[Any, ...], RangeTable] = {}
_TABLES_LOCK = threading.Lock()


def write_cache_file(path: Path, save: Callable[[Path], object], what: str) -> None:
    """`save` a table into the disk cache at `path`: into a file of this process first, then moved into
    place (processes share the folder); a failure is a warning, since the table is still in memory."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.stem}.{os.getpid()}.tmp{path.suffix}")
        save(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        log.warning("could not write %s cache %s: %s", what, path, exc)


def map_geometry_key(map: Map) -> str:
    """A short hash of `map`'s walls and bounds: the name of its tables in the disk cache."""
    h = hashlib.sha1(np.ascontiguousarray(map.walls, dtype=np.float64).tobytes())
    h.update(np.asarray(map.bounds, dtype=np.float64).tobytes())
    return h.hexdigest()[:16]


def range_table(map: Map, resolution_cm: float = 1.0, n_angles: int = 360,
                cache_dir: str | os.PathLike[str] | None = None, beam_width_deg: float = 0.0,
                critical_incidence_deg: float | None = None, memory_mb: float | None = None,
                lattice_step: int | None = None, max_range_cm: float | None = None) -> RangeTable:
    """The `RangeTable` of `map` within a memory budget, built once per process (per map geometry and plan).

    Parameters
    ----------
    map : Map
    resolution_cm : float
        Finest cell size (cm); a coarser one from `RESOLUTION_LADDER_CM` is used when the budget asks.
    n_angles : int
        Directions per cell.
    cache_dir : path, optional
        Folder for a disk cache of the table (``.npy``); default ``$NXTNAV_CACHE_DIR`` when set,
        otherwise memory only. Building takes about 0.2 s for map1.
    beam_width_deg, critical_incidence_deg : float
        Lobe width and specular loss (see `RangeTable`).
    memory_mb : float, optional
        Budget for the table (and, with `lattice_step`, the global-start lattice) in MB; default
        ``$NXTNAV_RANGE_MEMORY_MB`` or 1024 (see `range_memory_budget`).
    lattice_step : int, optional
        Count the spectra of a `RangeLattice` of this step in the budget.
    max_range_cm : float, optional
        The sensor's range limit (see `RangeTable`).

    Raises
    ------
    LocalisationError
        When the budget is not positive or the map's model cannot fit it (see `plan_range_table`).
    """
    plan = plan_range_table(map, n_angles, range_memory_budget(memory_mb), resolution_cm, lattice_step)
    lobe = float(beam_width_deg) if beam_width_deg > 0 else 0.0
    crit = critical_incidence_deg if lobe > 0 else None
    key = (map_geometry_key(map), plan.resolution_cm, int(n_angles), plan.dtype, lobe, crit, max_range_cm)
    with _TABLES_LOCK:
        table = _TABLES.get(key)
        if table is not None:
            return table
        folder = Path(cache_dir) if cache_dir is not None else cache_dir_from_env()
        ranges = None
        path = None
        if folder is not None:
            lobe_tag = (f"_lobe{lobe:g}_{crit}" if lobe > 0 else "") + (f"_max{max_range_cm:g}" if max_range_cm else "")
            path = folder / f"range_table_{key[0]}_{plan.resolution_cm:g}cm_{n_angles}_{plan.dtype}{lobe_tag}.npy"
            if path.is_file():
                try:
                    ranges = np.load(path)
                except (OSError, ValueError) as exc:
                    log.warning("ignoring unreadable range table cache %s: %s", path, exc)
        try:
            table = RangeTable(map, plan.resolution_cm, n_angles, ranges, lobe, crit, plan.dtype, plan.quantum_cm,
                               max_range_cm)
        except ValueError as exc:
            if ranges is None:
                raise
            # a cache file of another grid (written by an older version, or copied between maps)
            log.warning("range table cache %s does not fit map %s (%s); rebuilding it (cache folder: "
                        "$NXTNAV_CACHE_DIR or the localiser's cache_dir)", path, map.name, exc)
            ranges = None
            table = RangeTable(map, plan.resolution_cm, n_angles, None, lobe, crit, plan.dtype, plan.quantum_cm,
                               max_range_cm)
        if path is not None and ranges is None:
            write_cache_file(path, lambda tmp: np.save(tmp, table.ranges), "range table")
        _TABLES[key] = table
        log.debug("range table for %s: %d cells of %g cm x %d directions, %s (%.1f MB)", map.name,
                  table.ranges.shape[0], plan.resolution_cm, n_angles, plan.dtype, table.nbytes / 1e6)
        return table


def clear_range_table_cache() -> None:
    """Forget the tables built in this process."""
    with _TABLES_LOCK:
        _TABLES.clear()
        _LATTICES.clear()
