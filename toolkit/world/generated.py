"""Generated maps for scaling tests and benchmarks.

`random_grid_map` lays a grid of ``cells x cells`` square cells and blocks, with probability
`density`, each cell of odd row and odd column: the blocks never touch one another or the
boundary, so every block is one square obstacle (four walls) and the map is valid by construction.
With 512 x 512 cells and the default density it has about 90,000 walls.

`random_occupancy` blocks every cell independently, as the random maps of the grid benchmarks do:
blocks touch, meet at corners (pinch points) and cut the free space into many regions. Written as a
Moving AI map (`write_movingai_map`), a 512 x 512 grid with 20 % blocked has about 140,000 edges.
"""

from __future__ import annotations

import numpy as np

from .errors import ConfigError
from .geometry import RngLike, as_rng
from .grids import OccupancyGrid
from .maps import Map, Region

__all__ = ["random_grid_map", "random_occupancy"]


def random_grid_map(cells: int = 512, cell_cm: float = 5.0, density: float = 0.35, rng: RngLike = 0) -> Map:
    """A square room of ``cells x cells`` cells of `cell_cm` cm with random one-cell square blocks.

    Parameters
    ----------
    cells : int
        Cells along each side (>= 3).
    cell_cm : float
        Side of a cell (cm).
    density : float
        Probability that each candidate cell (odd row, odd column) is blocked.
    rng : None, int or Generator

    Returns
    -------
    Map
        Named ``grid{cells}``; walls = 4 + 4 x blocks.

    Examples
    --------
    >>> m = random_grid_map(16, rng=1)
    >>> m.walls.shape[0] % 4, m.bounds
    (0, (0.0, 0.0, 80.0, 80.0))
    """
    if cells < 3:
        raise ConfigError(f"cells must be >= 3, got {cells}")
    if not 0.0 <= density <= 1.0:
        raise ConfigError(f"density must be in [0, 1], got {density}")
    gen = as_rng(rng)
    odd = np.arange(1, cells - 1, 2)
    ii, jj = np.meshgrid(odd, odd, indexing="ij")
    keep = gen.random(ii.shape) < density
    lo = np.column_stack([ii[keep], jj[keep]]).astype(float) * cell_cm
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]) * cell_cm
    side = cells * cell_cm
    return Map(
        name=f"grid{cells}",
        description=f"{cells} x {cells} cells of {cell_cm:g} cm, {int(keep.sum())} random blocks",
        regions=(Region(square / cell_cm * side, tuple(p + square for p in lo)),),
    )


def random_occupancy(width: int, height: int, density: float = 0.2, cell_cm: float = 1.0,
                     rng: RngLike = 0) -> OccupancyGrid:
    """A ``width x height`` grid whose cells are blocked independently with probability `density`.

    Examples
    --------
    >>> g = random_occupancy(8, 4, density=0.5, rng=3)
    >>> g.free.shape, g.free.dtype.name
    ((4, 8), 'bool')
    """
    if width < 1 or height < 1:
        raise ValueError(f"the grid needs at least one cell, got {width} x {height}")
    if not 0.0 <= density <= 1.0:
        raise ValueError(f"density must be in [0, 1], got {density}")
    return OccupancyGrid(as_rng(rng).random((height, width)) >= density, float(cell_cm))
