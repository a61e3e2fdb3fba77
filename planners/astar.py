"""Grid A*: the paper's baseline, on an 8-connected grid over the configuration space.

Grid nodes sit at ``(xmin + i * resolution, ymin + j * resolution)`` over the map's bounding box,
or, with ``resolution=None`` on a map imported from a grid, at the centres of the map's own cells.
A node is usable when the shared checker finds the robot there free, and a move between
neighbouring nodes when the checker finds the swept disc free; both are asked once per (map,
radius, grid) in one batch and kept, so later queries on the same map only search. Start and goal
join the grid through straight segments to the free nodes within ``connect_radius`` of them. The
returned path is the gridded one, unsmoothed, as in the paper's comparison: A* paths turn at many
grid nodes, which is exactly what the paper's min-turn planner avoids.

Without corner cutting (the default on a map's own cells, as the Moving AI benchmarks define it) a
diagonal move is allowed only when both straight moves beside it are, and a start or goal exactly
on a node joins the grid at that node alone; when both are on nodes, no direct start-goal join
bypasses the lattice either (two diagonal neighbours across a blocked corner are two moves apart,
not one diagonal). With a point robot on the map's cells this is the Moving AI rule set, and the
search reproduces the published octile optimal lengths exactly.

The search itself is compiled (`planners.astar_search`): flat arrays and an indexed binary heap,
the octile heuristic when the goal is a node joined through the lattice alone.

Objectives. ``length`` is the search above. ``robot-time`` and ``turns`` search the same lattice with
the heading the robot arrived with as part of the state (8 headings), every move charged its turn
(`planners.astar_lattice`): the least robot time over the lattice's paths, or the fewest turns (then
the shortest).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from toolkit.world import CollisionChecker, ConfigError

from .astar_lattice import lattice_search, warm_up_lattice
from .astar_search import MAX_STEPS, MOVES, Workspace, search, warm_up
from .base import Planner, PlanningProblem, PlanStatus, Solution
from .declarations import AStarOptions
from .metrics import drop_straight

__all__ = ["AStarPlanner"]

_ON_NODE = 1e-9  # cm: a start or goal this close to a node is on it
_SQRT2 = math.sqrt(2.0)


@dataclass(eq=False)
class _Lattice:
    checker: CollisionChecker
    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    free: NDArray[np.bool_]
    free_nodes: int
    moves: NDArray[np.uint8]
    step: float
    cutting: bool
    build_s: float
    workspace: Workspace

    def serves(self, problem: PlanningProblem) -> bool:
        """Whether this lattice was built for `problem`'s map, radius and kind of checker."""
        c = problem.checker
        return self.checker is c or (self.checker.map is problem.map and type(self.checker) is type(c)
                                     and self.checker.robot_radius == c.robot_radius)


@dataclass(frozen=True)
class _Join:
    """Where a start or goal meets the lattice: the nodes, the cost of each join (cm), and the node it
    lies on (-1 when it lies between nodes)."""

    nodes: NDArray[np.int64]
    costs: NDArray[np.float64]
    on_node: int


class AStarPlanner(Planner):
    """8-connected grid A* on the configuration space.

    Parameters
    ----------
    options : AStarOptions, optional
        The options (`planners.declarations.AStarOptions`; None: the defaults): the grid `resolution`
        (cm; None puts the nodes at the centres of the map's own cells, for a map imported from a grid),
        the `connect_radius` (cm) within which start and goal join free grid nodes (None: two spacings),
        and `corner_cutting` (whether a diagonal move may pass a blocked neighbour's corner; None:
        allowed on a spaced grid, forbidden on the map's own cells), and the `objective` it
        minimises (length, robot-time or turns; module notes).
    **overrides
        Options on top of `options` by name (``resolution=1.0``).

    Notes
    -----
    The result is the shortest path over the grid graph plus the start and goal connections (the
    heuristics are admissible and consistent). ``info`` reports ``expanded`` nodes, ``grid_nodes``,
    ``free_nodes`` and ``grid_build_s`` (0 when cached; it includes compiling the search).
    """

    name = "astar"
    options_model = AStarOptions
    grid_map_options: ClassVar[Mapping[str, Any]] = {"resolution": None}
    objectives = ("length", "robot-time", "turns")

    def __init__(self, options: AStarOptions | None = None, **overrides: Any) -> None:
        o: AStarOptions = self.configure(options, overrides)
        self.options = o
        self.resolution, self._connect, self.corner_cutting = o.resolution, o.connect_radius, o.corner_cutting
        self._set_objective(o.objective)
        self._lat: _Lattice | None = None  # one map at a time: a lattice can be large

    def spacing(self, problem: PlanningProblem) -> float:
        """Node spacing (cm) for `problem`'s map."""
        if self.resolution is not None:
            return self.resolution
        if problem.map.grid is None:
            raise ConfigError(f"astar with resolution=None needs a map imported from a grid; {problem.map.name!r} "
                             "is polygonal (give a resolution in cm)")
        return problem.map.grid.cell_cm

    @property
    def connect_radius(self) -> float:
        """Start/goal connection radius (cm) for the configured resolution (2 cm when it is None)."""
        return self._connect if self._connect is not None else 2.0 * (self.resolution or 1.0)

    def grid(self, problem: PlanningProblem) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The grid's x and y coordinates (cm) for `problem`'s map."""
        if self.resolution is None:
            centres = problem.map.grid.centres() if problem.map.grid is not None else None
            if centres is None:
                self.spacing(problem)  # raises the explanation
                raise AssertionError
            return centres[0, :, 0].astype(np.float64), centres[:, 0, 1].astype(np.float64)
        xmin, ymin, xmax, ymax = problem.map.bounds
        res = self.resolution
        xs = np.asarray(xmin + res * np.arange(math.floor((xmax - xmin) / res) + 1), dtype=np.float64)
        ys = np.asarray(ymin + res * np.arange(math.floor((ymax - ymin) / res) + 1), dtype=np.float64)
        return xs, ys

    def _lattice(self, problem: PlanningProblem) -> tuple[_Lattice, bool]:
        if self._lat is not None and self._lat.serves(problem):
            return self._lat, True
        self._lat = None
        t0 = time.perf_counter()
        checker = problem.checker
        xs, ys = self.grid(problem)
        nx, ny = len(xs), len(ys)
        if _SQRT2 * nx * ny + nx + ny + 16 > MAX_STEPS:  # the longest path the search's keys hold
            raise ConfigError(f"astar: a grid of {nx} x {ny} nodes on map {problem.map.name!r} is beyond the "
                              f"search's reach ({MAX_STEPS:.3g} steps); choose a coarser resolution")
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts = np.column_stack([gx.ravel(), gy.ravel()])  # node index = i * ny + j
        free = np.asarray(checker.point_free(pts), dtype=bool).reshape(nx, ny)
        # every move between free neighbours, checked once in a batch per direction
        ok: dict[tuple[int, int], NDArray[np.bool_]] = {}
        ii, jj = np.nonzero(free)
        for di, dj in MOVES:
            a = np.zeros((nx, ny), dtype=bool)
            ti, tj = ii + di, jj + dj
            inside = (ti >= 0) & (ti < nx) & (tj >= 0) & (tj < ny)
            si, sj, ti, tj = ii[inside], jj[inside], ti[inside], tj[inside]
            both = free[ti, tj]
            si, sj, ti, tj = si[both], sj[both], ti[both], tj[both]
            a[si, sj] = checker.segments_free(np.column_stack([xs[si], ys[sj]]), np.column_stack([xs[ti], ys[tj]]))
            ok[(di, dj)] = a
        cutting = self.corner_cutting if self.corner_cutting is not None else self.resolution is not None
        if not cutting:
            for di, dj in MOVES[4:]:
                ok[(di, dj)] &= ok[(di, 0)] & ok[(0, dj)]  # both straight moves beside the diagonal, same node
        moves = np.zeros(nx * ny, dtype=np.uint8)
        for d, move in enumerate(MOVES):
            moves |= ok[move].ravel().astype(np.uint8) << np.uint8(d)
        step = float(xs[1] - xs[0]) if nx > 1 else float(ys[1] - ys[0]) if ny > 1 else 1.0
        ws = Workspace(nx * ny)
        warm_up(moves, xs, ys, step, ws)  # compiling belongs to the preparation, not to a query
        if self.objective != "length":
            warm_up_lattice()
        self._lat = _Lattice(checker, xs, ys, free.ravel(), int(free.sum()), moves, step, cutting,
                             time.perf_counter() - t0, ws)
        return self._lat, False

    def _join(self, lat: _Lattice, p: NDArray[np.float64], radius: float, checker: CollisionChecker,
              to_goal: bool) -> _Join:
        """The free nodes `p` joins by a free straight segment within `radius` (its own node alone when it
        lies on one and corners may not be cut)."""
        xs, ys, ny = lat.xs, lat.ys, len(lat.ys)
        i, j = round((p[0] - xs[0]) / lat.step), round((p[1] - ys[0]) / lat.step)
        on_node = -1
        if 0 <= i < len(xs) and 0 <= j < ny and math.hypot(xs[i] - p[0], ys[j] - p[1]) <= _ON_NODE:
            on_node = i * ny + j
            if not lat.cutting:  # that node alone: no shortcut off the grid
                keep = np.array([on_node] if lat.free[on_node] else [], dtype=np.int64)
                return _Join(keep, np.zeros(len(keep)), on_node)
        i0, i1 = np.searchsorted(xs, [p[0] - radius, p[0] + radius])
        j0, j1 = np.searchsorted(ys, [p[1] - radius, p[1] + radius])
        grid_i, grid_j = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), indexing="ij")
        ii, jj = grid_i.ravel(), grid_j.ravel()
        k = ii * ny + jj
        d = np.hypot(xs[ii] - p[0], ys[jj] - p[1])
        near = lat.free[k] & (d <= radius)
        k, d, ii, jj = k[near], d[near], ii[near], jj[near]
        ends = np.column_stack([xs[ii], ys[jj]])
        here = np.repeat(p[None], len(k), axis=0)
        ok = checker.segments_free(ends, here) if to_goal else checker.segments_free(here, ends)
        return _Join(k[ok].astype(np.int64), d[ok], on_node)

    def _solve(self, problem: PlanningProblem) -> Solution:
        checker = problem.checker
        lat, cached = self._lattice(problem)
        deadline = time.perf_counter() + problem.time_limit
        info = {"grid_nodes": len(lat.free), "free_nodes": lat.free_nodes, "expanded": 0,
                "grid_build_s": 0.0 if cached else lat.build_s}
        radius = self._connect if self._connect is not None else 2.0 * self.spacing(problem)
        start, goal = problem.start, problem.goal
        s, g = self._join(lat, start, radius, checker, False), self._join(lat, goal, radius, checker, True)
        if not len(s.nodes) or not len(g.nodes):
            which = "start" if not len(s.nodes) else "goal"
            return Solution(None, PlanStatus.NO_PATH, info, f"{which} cannot reach the grid")
        through_lattice = not lat.cutting and s.on_node >= 0 and g.on_node >= 0
        direct = math.inf
        dist = float(np.hypot(*(goal - start)))
        if not through_lattice and dist <= radius and checker.segment_free(start, goal):
            direct = dist
        if self.objective != "length":
            return self._solve_headings(problem, lat, (s, g), direct, info)
        octile = not lat.cutting and g.on_node >= 0
        out = search(lat.moves, lat.xs, lat.ys, lat.step, lat.workspace, (float(goal[0]), float(goal[1])),
                     s.nodes, s.costs, g.nodes, g.costs, direct, octile=octile, deadline=deadline)
        info["expanded"] = out.expanded
        if out.nodes is None:
            if out.timed_out:
                return Solution(None, PlanStatus.TIMEOUT, info)
            return Solution(None, PlanStatus.NO_PATH, info, "no path on the grid")
        ny = len(lat.ys)
        pts = np.column_stack([lat.xs[out.nodes // ny], lat.ys[out.nodes % ny]])
        if len(pts) and np.array_equal(pts[0], start):
            pts = pts[1:]  # the start's own node
        if len(pts) and np.array_equal(pts[-1], goal):
            pts = pts[:-1]
        return Solution(np.vstack([start[None], pts, goal[None]]), PlanStatus.EXACT, info)

    def _solve_headings(self, problem: PlanningProblem, lat: _Lattice, joins: tuple[_Join, _Join], direct: float,
                        info: dict[str, Any]) -> Solution:
        """The least robot time (or fewest turns) over the lattice with headings (`planners.astar_lattice`)."""
        start, goal = problem.start, problem.goal
        if self.objective == "robot-time":
            t = problem.timing
            weights = (1.0 / t.drive_speed_cm_s, 1.0 / math.radians(t.turn_rate_deg_s), t.stop_turn_s)
        else:
            xmin, ymin, xmax, ymax = problem.map.bounds
            weights = (1.0 / (20.0 * ((xmax - xmin) + (ymax - ymin))), 0.0, 1.0)
        s, g = joins
        cost, nodes, expanded = lattice_search(lat.moves, lat.xs, lat.ys, lat.step, start, (s.nodes, s.costs),
                                               goal, (g.nodes, g.costs), direct, weights)
        info["expanded"] = expanded
        if not math.isfinite(cost):
            return Solution(None, PlanStatus.NO_PATH, info, "no path on the grid")
        ny = len(lat.ys)
        pts = np.column_stack([lat.xs[nodes // ny], lat.ys[nodes % ny]])
        return Solution(drop_straight(np.vstack([start[None], pts, goal[None]])), PlanStatus.EXACT, info)
