"""Reference planners: ``shortest`` (visibility graph) and ``min-link`` (fewest segments, then shortest).

They are the yardsticks the benchmark divides by (length / shortest, turns / min-link). Both build
their graphs on a polygonal approximation of the configuration space and validate every edge with
the shared checker, so every path they return is collision-free for the true robot disc.

The polygonal configuration space
---------------------------------
The exact configuration space of a disc of radius ``r`` is the free area minus the walls grown by
``r``: its boundary has straight parts and circular arcs of radius ``r`` around the corners that
stick into the free area. Shapely's negative buffer approximates those arcs by chords *inside* the
arc, i.e. partly in collision. Here each wall segment is instead grown by a regular ``n``-gon that
*circumscribes* the circle of radius ``r + eps`` (circumradius ``R = (r + eps) / cos(pi / n)``), so
every boundary point of the approximation is at least ``r + eps`` from every wall, and

    C(R) ⊆ approximation ⊆ C(r)

where ``C(x)`` is the exact configuration space of a disc of radius ``x``. With the defaults
(``n = 64``, ``eps = 1e-4`` cm) and ``r = 8`` cm, ``R - r ≈ 0.0098`` cm.

What is exact and what is approximate
-------------------------------------
``shortest``: the visibility graph over start, goal and the reflex vertices of the approximation
(edges kept only when tangent at both ends, then checked by the checker) gives the exact shortest
path for the polygonal approximation, so its length ``L`` satisfies ``L* <= L <= L*(R)``, where
``L*`` is the true shortest length for the disc of radius ``r`` and ``L*(R)`` that for radius ``R``.
To first order ``L*(R) - L* = (R - r) * Θ`` with ``Θ`` the total turning angle of the path (the
length of a taut path around arcs grows by the turned angle per unit of radius). ``info`` reports
the bound ``length_tolerance_cm = (R - r) * (Θ + 2 pi)`` (the ``2 pi`` covers the change of ``Θ``
between radii); any collision-free path is at least ``L - length_tolerance_cm`` long. The
approximation can also close a passage whose width lies between ``2 r`` and ``2 R`` (a window of
0.02 cm with the defaults); ``shortest`` then reports no path or a longer one.

``min-link``: the fewest segments over the graph whose nodes are start, goal, the corners of the
approximation (vertices turning by more than 10 degrees), points along its boundary every
``boundary_spacing`` cm and an interior grid every ``grid_spacing`` cm, every pair checked with the
checker; among the graph's paths with that many segments, the shortest; then its bends are moved to
shorten it (`shorten_bends`, a pattern search validated by the checker; the number of segments
stays). Exact: the answer for that graph, and the true minimum whenever it is 1 segment (a direct
check). Approximate: a true minimum-link path may bend at points that are not nodes, so the segment
count is an *upper bound* on the true minimum, and the length an upper bound on the shortest
minimum-link length.

Both ignore the time limit: they are yardsticks, not timed competitors.

Graphs over the map's nodes are cached per (map, radius, checker backend) in the planner instance, so only the
start and goal edges are checked for later queries on the same map (the reported collision checks
are then the query's share only).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import polygon as shapely_polygon
from shapely.geometry.base import BaseGeometry

from toolkit.world import CollisionChecker, Map, PointCollisionChecker
from toolkit.world.arrays import FloatArray

from .base import Planner, PlanningProblem, PlanStatus, Solution
from .declarations import MinLinkOptions, ReferenceOptions, ShortestOptions
from .metrics import turn_angle
from .min_turn import hop_shortest_path

if TYPE_CHECKING:
    from .visibility_search import VisibilityGraph

__all__ = [
    "MinLinkPlanner",
    "ShortestPathPlanner",
    "circumradius",
    "cspace_polygon",
    "polygon_vertices",
    "shorten_bends",
]


def circumradius(radius: float, n_sides: int = 64, eps: float = 1e-4) -> float:
    """Circumradius (cm) of the regular `n_sides`-gon whose edges are tangent to a circle of ``radius + eps``."""
    return (float(radius) + eps) / math.cos(math.pi / n_sides)


def cspace_polygon(map: Map, radius: float, n_sides: int = 64, eps: float = 1e-4) -> BaseGeometry:
    """Polygonal configuration space inside the exact one: free area minus walls grown by a circumscribed n-gon.

    Every boundary point of the result is at least ``radius + eps`` cm from every wall. The result
    is a Polygon or MultiPolygon (empty when the disc fits nowhere), oriented with exteriors
    counter-clockwise and holes clockwise. For a point robot (radius 0) the free area itself, which
    it may touch, minus the thin walls (`Map.thin_walls`, which it may not touch) grown by ``eps``.
    """
    if radius == 0 and not map.thin_walls:  # a point robot: the free area itself, exactly
        return shapely.MultiPolygon([shapely_polygon.orient(p, 1.0) for p in shapely.get_parts(map.polygon)])
    big = circumradius(radius, n_sides, eps)
    ang = (np.arange(n_sides) + 0.5) * (2.0 * math.pi / n_sides)
    ngon = big * np.column_stack([np.cos(ang), np.sin(ang)])
    walls = map.walls if radius > 0 else map.thin_segments
    pts = np.concatenate([walls[:, None, :2] + ngon[None], walls[:, None, 2:] + ngon[None]], axis=1)
    hulls = shapely.convex_hull(shapely.multipoints(pts))
    blocked = shapely.union_all(hulls)
    free = shapely.difference(map.polygon, blocked)
    parts = [g for g in getattr(free, "geoms", [free]) if isinstance(g, shapely.Polygon) and g.area > 1e-9]
    return shapely.MultiPolygon([shapely_polygon.orient(p, 1.0) for p in parts])


def polygon_vertices(cspace: BaseGeometry, parts: bool = False) -> Any:
    """Vertices of an oriented (multi)polygon, whether each is reflex, and each vertex's two neighbours.

    Free space lies to the left of every ring (exteriors counter-clockwise, holes clockwise), so a
    vertex is reflex (the free angle exceeds 180 degrees) where its ring turns right.

    Returns
    -------
    (v, reflex, prev, next) or, with ``parts=True``, (v, reflex, prev, next, part)
        (m, 2) vertices, (m,) reflex flags, (m, 2) previous and (m, 2) next vertices, and the (m,)
        index of the polygon each vertex belongs to.
    """
    vs, rs, ps, ns, ks = [], [], [], [], []
    for k, poly in enumerate(getattr(cspace, "geoms", [cspace])):
        for ring in (poly.exterior, *poly.interiors):
            c = np.asarray(ring.coords)[:-1]
            if len(c) < 3:
                continue
            prv, nxt = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
            a, b = c - prv, nxt - c
            cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
            vs.append(c)
            rs.append(cross < 0)
            ps.append(prv)
            ns.append(nxt)
            ks.append(np.full(len(c), k))
    if not vs:
        empty = (np.empty((0, 2)), np.empty(0, dtype=bool), np.empty((0, 2)), np.empty((0, 2)))
        return (*empty, np.empty(0, dtype=np.intp)) if parts else empty
    out = (np.vstack(vs), np.concatenate(rs), np.vstack(ps), np.vstack(ns))
    return (*out, np.concatenate(ks)) if parts else out


def _cross(u: FloatArray, v: FloatArray) -> FloatArray:
    return np.asarray(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0])


def _tangent(v: FloatArray, prv: FloatArray, nxt: FloatArray, w: FloatArray) -> NDArray[np.bool_]:
    """Whether the lines v -> w leave both ring neighbours of v on one side (rows broadcast)."""
    d = w - v
    a = _cross(d, prv - v)
    b = _cross(d, nxt - v)
    tol = 1e-9 * (np.hypot(d[..., 0], d[..., 1]) + 1.0)
    return np.asarray((a * b >= -tol) | (np.abs(a) <= tol) | (np.abs(b) <= tol))


@dataclass
class _Graph:
    """Nodes of a map for one radius and which node pairs the checker found free."""

    map: Map
    radius: float
    nodes: FloatArray
    visible: NDArray[np.bool_]  # (m, m) symmetric, checked with the checker
    extra: dict[str, Any]


def _pairwise_visibility(checker: CollisionChecker, nodes: FloatArray, allowed: NDArray[np.bool_]) -> NDArray[np.bool_]:
    m = len(nodes)
    iu, ju = np.triu_indices(m, k=1)
    keep = allowed[iu, ju]
    iu, ju = iu[keep], ju[keep]
    ok = checker.segments_free(nodes[iu], nodes[ju]) if len(iu) else np.empty(0, dtype=bool)
    vis = np.zeros((m, m), dtype=bool)
    vis[iu[ok], ju[ok]] = True
    vis |= vis.T
    return vis


_CORNER_DEG = 10.0  # vertices turning more than this are min-link nodes
_DIRECTIONS = np.array([[math.cos(a), math.sin(a)] for a in np.arange(8) * math.pi / 4])


def shorten_bends(checker: CollisionChecker, path: FloatArray, step: float = 5.0, min_step: float = 1e-3) -> FloatArray:
    """Shorten a polyline by moving its interior points, keeping its end points and number of segments.

    Pattern search: each interior point tries moves of `step` cm in 8 directions and takes the one
    that shortens its two segments most while the checker finds both free; the step halves when no
    point can move, down to `min_step`. The result is collision-free (checked) and never longer.
    """
    p = np.array(path, dtype=float)
    if len(p) < 3:
        return p
    s = float(step)
    while s >= min_step:
        moved = False
        for i in range(1, len(p) - 1):
            a, b = p[i - 1], p[i + 1]
            here = float(np.hypot(*(p[i] - a)) + np.hypot(*(p[i] - b)))
            cand = p[i] + s * _DIRECTIONS
            gain = here - (np.hypot(*(cand - a).T) + np.hypot(*(cand - b).T))
            for j in np.argsort(-gain):
                if gain[j] <= 1e-12:
                    break
                if checker.segment_free(a, cand[j]) and checker.segment_free(cand[j], b):
                    p[i] = cand[j]
                    moved = True
                    break
        if not moved:
            s /= 2.0
    return p


class _ReferencePlanner(Planner):
    """Shared machinery: the polygonal configuration space and a per-(map, radius, backend) graph cache."""

    def __init__(self, options: ReferenceOptions | None = None, **overrides: Any) -> None:
        o: ReferenceOptions = self.configure(options, overrides)
        self.options = o
        self.n_sides, self.eps = o.n_sides, o.eps
        self._set_objective(o.objective)
        self._cache: dict[tuple[int, float, str], _Graph] = {}

    @staticmethod
    def _key(problem: PlanningProblem) -> tuple[int, float, str]:
        """A graph's edges were checked by one kind of checker: it serves that map, radius and backend."""
        return id(problem.map), problem.robot_radius, problem.checker.backend

    def _graph(self, problem: PlanningProblem) -> _Graph:
        key = self._key(problem)
        g = self._cache.get(key)
        if g is None or g.map is not problem.map:
            g = self._build(problem)
            self._cache[key] = g
        return g

    def _build(self, problem: PlanningProblem) -> _Graph:
        raise NotImplementedError

    def _query_edges(self, checker: CollisionChecker, g: _Graph, start: FloatArray, goal: FloatArray,
                     mask_start: NDArray[np.bool_] | None = None,
                     mask_goal: NDArray[np.bool_] | None = None) -> tuple[NDArray[np.bool_], NDArray[np.bool_], bool]:
        m = len(g.nodes)
        s_idx = np.flatnonzero(mask_start) if mask_start is not None else np.arange(m)
        g_idx = np.flatnonzero(mask_goal) if mask_goal is not None else np.arange(m)
        s_ok = np.zeros(m, dtype=bool)
        g_ok = np.zeros(m, dtype=bool)
        if len(s_idx):
            s_ok[s_idx] = checker.segments_free(np.repeat(start[None], len(s_idx), axis=0), g.nodes[s_idx])
        if len(g_idx):
            g_ok[g_idx] = checker.segments_free(g.nodes[g_idx], np.repeat(goal[None], len(g_idx), axis=0))
        direct = bool(checker.segment_free(start, goal))
        return s_ok, g_ok, direct

    def _length_tolerance(self, problem: PlanningProblem, path: FloatArray) -> float:
        if problem.robot_radius == 0 and not problem.map.thin_walls:
            return 0.0  # the point robot's graph is exact
        big = circumradius(problem.robot_radius, self.n_sides, self.eps)
        return (big - problem.robot_radius) * (turn_angle(path) + 2.0 * math.pi)


def _tangent_pairs(v: FloatArray, prv: FloatArray, nxt: FloatArray, part: NDArray[np.intp],
                   chunk: int = 256) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Pairs ``i < j`` of vertices in the same part whose joining line is tangent at both ends (chunked)."""
    m = len(v)
    rows: list[NDArray[np.intp]] = []
    cols: list[NDArray[np.intp]] = []
    for lo in range(0, m, chunk):
        hi = min(m, lo + chunk)
        i = np.arange(lo, hi)[:, None]
        j = np.arange(lo + 1, m)[None, :]
        ok = (j > i) & (part[i] == part[j])
        ok &= _tangent(v[i], prv[i], nxt[i], v[j]) & _tangent(v[j], prv[j], nxt[j], v[i])
        ii, jj = np.nonzero(ok)
        rows.append(ii + lo)
        cols.append(jj + lo + 1)
    if not rows:
        return np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp)
    return np.concatenate(rows), np.concatenate(cols)


def _exact_grid(problem: PlanningProblem) -> NDArray[np.bool_] | None:
    """The free cells of a point robot's grid map whose free space is exactly those cells, else None
    (also when thin walls cut the cells, which the cell sweeps cannot see)."""
    checker = problem.checker
    if (problem.robot_radius != 0 or not isinstance(checker, PointCollisionChecker) or not checker.use_grid
            or problem.map.thin_walls):
        return None
    return checker.cells


def _grid_graph(map: Map, free: NDArray[np.bool_], cs: BaseGeometry) -> tuple[Any, ...]:
    """The reflex corners of a grid map as a lazily scanned graph, with each corner's ring neighbours and part."""
    from toolkit.world.grid_visibility import GridVisibility  # compiled: loaded when first needed

    from .visibility_search import VisibilityGraph

    g = map.grid
    assert g is not None
    gv = GridVisibility.of(free)
    c = float(g.cell_cm)
    vg = VisibilityGraph.from_grid(gv, np.asarray(g.origin, dtype=float), c)
    v, quad = vg.nodes, gv.quadrants
    prv = v + c * np.column_stack([quad[:, 0], np.zeros(len(quad))])
    nxt = v + c * np.column_stack([np.zeros(len(quad)), quad[:, 1]])
    # a corner's part is that of the free cell diagonally opposite its blocked one (4-connected labels)
    import scipy.ndimage  # here, not at the top: it costs every process half a second at start

    labels, n_labels = scipy.ndimage.label(free)
    corners = gv.corners
    cell_i = corners[:, 0] - (quad[:, 0] > 0)
    cell_j = corners[:, 1] - (quad[:, 1] > 0)
    rep = np.zeros((n_labels + 1, 2))
    jj, ii = np.nonzero(labels)
    rep[labels[jj, ii]] = np.column_stack([ii, jj]) + 0.5  # some cell of each label (the last one listed)
    rep_cm = np.asarray(g.origin, dtype=float) + c * rep[1:]
    pt, pa = shapely.STRtree(shapely.get_parts(cs)).query(shapely.points(rep_cm), predicate="intersects")
    part_of_label = np.full(n_labels + 1, -1, dtype=np.intp)
    part_of_label[pt + 1] = pa
    return vg, prv, nxt, part_of_label[labels[cell_j, cell_i]]


class ShortestPathPlanner(_ReferencePlanner):
    """Shortest path for the disc: visibility graph over the polygonal configuration space's reflex vertices.

    Parameters
    ----------
    options : ShortestOptions, optional
        The options (`planners.declarations.ShortestOptions`; None: the defaults): `n_sides` of the
        circumscribed polygon that stands in for the robot disc when growing the walls, and `eps`, an
        extra clearance (cm) so that boundary edges pass the checker despite rounding.
    **overrides
        Options on top of `options` by name (``n_sides=16``).

    Notes
    -----
    See the module docstring for the guarantee: ``L* <= length <= L* + info["length_tolerance_cm"]``
    (to first order), where ``L*`` is the true shortest length. For a point robot (radius 0) the
    configuration space is the free area itself and the result is exact (tolerance 0): paths may run
    along walls and round corners but never through a pinch point of the map. Thin walls
    (`Map.thin_walls`) may not be touched, so for them the point grows by ``eps`` like a disc, and
    the tolerance is that of a disc of radius 0 (a few ``eps``). For a disc a thin wall is a wall
    like any other: its end points become arcs, and their polygon's vertices visibility nodes.

    The graph is kept per (map, radius) and searched by A* (`planners.visibility_search`). Its
    edges join reflex vertices whose joining line is tangent at both ends. On a point robot's grid
    map (``map.grid``, free space exactly the free cells) they are found lazily and exactly by row
    sweeps from each corner the search reaches (`toolkit.world.grid_visibility`), so maps of 10^5
    edges need no all-pairs preprocessing; elsewhere every tangent pair in the same connected part
    is checked once when the graph is built (chunked, vectorised). ``info`` reports
    ``graph_nodes``, ``graph_arcs`` (adjacency entries known so far), ``graph_scanned_nodes`` (grid
    corners swept so far) and ``graph_build_s`` (0 when the graph came from the cache).
    """

    name = "shortest"
    options_model: ClassVar[type[ReferenceOptions]] = ShortestOptions
    large_map_options: ClassVar[Mapping[str, Any] | None] = {"n_sides": 16}  # length tolerance stays < ~1 cm

    def _build(self, problem: PlanningProblem) -> _Graph:
        from .visibility_search import VisibilityGraph  # compiled: loaded when first needed

        t0 = time.perf_counter()
        cs = cspace_polygon(problem.map, problem.robot_radius, self.n_sides, self.eps)
        free = _exact_grid(problem)
        if free is not None:
            vg, prv, nxt, part = _grid_graph(problem.map, free, cs)
            candidates = 0
        else:
            v, prv, nxt, part, iu, ju, candidates = self._polygon_graph(problem, cs)
            vg = VisibilityGraph.from_edges(v, iu, ju)
        extra = {"prev": prv, "next": nxt, "part": part, "cspace": cs, "search": vg, "candidates": candidates,
                 "build_s": time.perf_counter() - t0}
        return _Graph(problem.map, problem.robot_radius, vg.nodes, np.zeros((0, 0), dtype=bool), extra)

    def _polygon_graph(self, problem: PlanningProblem, cs: BaseGeometry) -> tuple[Any, ...]:
        """Reflex vertices and the checked tangent pairs between them (all pairs tested: O(m^2))."""
        v, reflex, prv, nxt, part = polygon_vertices(cs, parts=True)
        keep = reflex
        if problem.robot_radius == 0 and len(problem.map.pinch_points):
            # a pinch point is never a bend of a shortest path (passing it is forbidden)
            keep = keep & ~(v[:, None, :] == problem.map.pinch_points[None]).all(axis=2).any(axis=1)
        v, prv, nxt, part = v[keep], prv[keep], nxt[keep], part[keep]
        iu, ju = _tangent_pairs(v, prv, nxt, part)
        ok = np.zeros(len(iu), dtype=bool)
        step = 1 << 16
        for lo in range(0, len(iu), step):
            ok[lo:lo + step] = problem.checker.segments_free(v[iu[lo:lo + step]], v[ju[lo:lo + step]])
        return v, prv, nxt, part, iu[ok], ju[ok], len(ok)

    def _solve(self, problem: PlanningProblem) -> Solution:
        checker = problem.checker
        cached = self._key(problem) in self._cache
        g = self._graph(problem)
        start, goal = problem.start, problem.goal
        prv, nxt, part = g.extra["prev"], g.extra["next"], g.extra["part"]
        m = len(g.nodes)
        info: dict[str, Any] = {"graph_nodes": m, "graph_build_s": 0.0 if cached else g.extra["build_s"]}
        if checker.segment_free(start, goal):
            path = np.array([start, goal])
            info["length_tolerance_cm"] = self._length_tolerance(problem, path)
            return Solution(path, PlanStatus.EXACT, info)
        parts = shapely.get_parts(g.extra["cspace"])
        which = [np.flatnonzero(shapely.intersects_xy(parts, *p)) for p in (start, goal)]
        same = np.intersect1d(which[0], which[1])
        if not len(same):  # different parts of the configuration space
            return Solution(None, PlanStatus.NO_PATH, info)
        vg: VisibilityGraph = g.extra["search"]
        si, gi = vg.seen_from(start), vg.seen_from(goal)  # lattice points of a grid: swept, exactly
        in_part = np.isin(part, same)
        if si is None:
            s_cand = np.flatnonzero(in_part & _tangent(g.nodes, prv, nxt, np.broadcast_to(start, g.nodes.shape)))
            si = s_cand[checker.segments_free(np.repeat(start[None], len(s_cand), axis=0), g.nodes[s_cand])]
        if gi is None:
            g_cand = np.flatnonzero(in_part & _tangent(g.nodes, prv, nxt, np.broadcast_to(goal, g.nodes.shape)))
            gi = g_cand[checker.segments_free(g.nodes[g_cand], np.repeat(goal[None], len(g_cand), axis=0))]
        goal_seen = np.zeros(m, dtype=bool)
        goal_seen[gi] = True
        length, seq = vg.search(start, goal, si, goal_seen)
        info["graph_arcs"] = vg.arcs
        info["graph_scanned_nodes"] = vg.scanned
        if not math.isfinite(length):
            return Solution(None, PlanStatus.NO_PATH, info)
        path = np.vstack([start, g.nodes[seq], goal])
        info["length_tolerance_cm"] = self._length_tolerance(problem, path)
        return Solution(path, PlanStatus.EXACT, info)


class MinLinkPlanner(_ReferencePlanner):
    """Fewest straight segments (then shortest) over a dense visibility graph of the configuration space.

    Parameters
    ----------
    options : MinLinkOptions, optional
        The options (`planners.declarations.MinLinkOptions`; None: the defaults): the spacing (cm) of the
        nodes along the boundary of the polygonal configuration space (`boundary_spacing`) and of an
        interior grid (`grid_spacing`; None: no interior nodes), `refine` (shorten the graph's path by
        moving its bends, `shorten_bends`, keeping the number of links), and `n_sides` and `eps` as for
        `ShortestPathPlanner`.
    **overrides
        Options on top of `options` by name.

    Notes
    -----
    The number of segments is an upper bound on the true minimum (see the module docstring);
    ``info["links"]`` is the number of segments, ``info["graph_nodes"]`` the node count and
    ``info["graph_length_cm"]`` the length before `refine`.
    """

    name = "min-link"
    options_model = MinLinkOptions
    objectives = ("turns",)
    large_map_options = None  # its dense graph grows with the map's area squared

    def __init__(self, options: MinLinkOptions | None = None, **overrides: Any) -> None:
        super().__init__(options, **overrides)
        o: MinLinkOptions = self.options  # type: ignore[assignment]
        self.refine, self.boundary_spacing, self.grid_spacing = o.refine, o.boundary_spacing, o.grid_spacing

    def _build(self, problem: PlanningProblem) -> _Graph:
        cs = cspace_polygon(problem.map, problem.robot_radius, self.n_sides, self.eps)
        v, _, prv, nxt = polygon_vertices(cs)
        # corners of the polygonal space; the short edges approximating arcs add nothing over boundary points
        a, b = v - prv, nxt - v
        turn = np.abs(np.arctan2(_cross(a, b), np.einsum("ij,ij->i", a, b)))
        pts = [v[turn > math.radians(_CORNER_DEG)]]
        for poly in getattr(cs, "geoms", [cs]):
            for ring in (poly.exterior, *poly.interiors):
                k = max(math.ceil(ring.length / self.boundary_spacing), 3)
                pts.append(shapely.get_coordinates(
                    shapely.line_interpolate_point(ring, np.linspace(0.0, 1.0, k, endpoint=False), normalized=True)))
        if self.grid_spacing is not None and not cs.is_empty:
            xmin, ymin, xmax, ymax = cs.bounds
            s = self.grid_spacing
            gx, gy = np.meshgrid(np.arange(xmin + s / 2, xmax, s), np.arange(ymin + s / 2, ymax, s), indexing="ij")
            grid = np.column_stack([gx.ravel(), gy.ravel()])
            pts.append(grid[shapely.contains_xy(cs, grid[:, 0], grid[:, 1])])
        nodes = np.asarray(np.unique(np.round(np.vstack(pts), 9), axis=0), dtype=np.float64)
        nodes = nodes[np.asarray(problem.checker.point_free(nodes), dtype=bool)] if len(nodes) else nodes
        vis = _pairwise_visibility(problem.checker, nodes, np.ones((len(nodes), len(nodes)), dtype=bool))
        return _Graph(problem.map, problem.robot_radius, nodes, vis, {})

    def _solve(self, problem: PlanningProblem) -> Solution:
        checker = problem.checker
        g = self._graph(problem)
        start, goal = problem.start, problem.goal
        m = len(g.nodes)
        info: dict[str, Any] = {"graph_nodes": m}
        s_ok, g_ok, direct = self._query_edges(checker, g, start, goal)
        if direct:
            info["links"] = 1
            return Solution(np.array([start, goal]), PlanStatus.EXACT, info)
        # fewest hops by breadth-first search over the (fully checked) visibility graph
        n = m + 2
        adj = np.zeros((n, n), dtype=bool)
        adj[:m, :m] = g.visible
        adj[m, :m] = s_ok
        adj[:m, m + 1] = g_ok
        seen = np.zeros(n, dtype=bool)
        seen[m] = True
        frontier = seen.copy()
        hops = 0
        while frontier.any() and not seen[m + 1]:
            hops += 1
            frontier = np.any(adj[frontier], axis=0) & ~seen
            seen |= frontier
        if not seen[m + 1]:
            return Solution(None, PlanStatus.NO_PATH, info)
        allp = np.vstack([g.nodes, start, goal])
        diff = allp[:, None, :] - allp[None, :, :]
        cost = np.where(adj, np.hypot(diff[..., 0], diff[..., 1]), np.inf)
        _, seq = hop_shortest_path(cost, m, m + 1, hops)
        info["links"] = hops
        path = allp[seq]
        info["graph_length_cm"] = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
        if self.refine:
            path = shorten_bends(checker, path, self.boundary_spacing)
        return Solution(path, PlanStatus.EXACT, info)
