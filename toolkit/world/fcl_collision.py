"""The same disc checks on python-fcl: the reference backend the indexed checker is tested against.

The walls (`Map.walls`: polygon edges and thin walls alike) become one FCL BVH of vertical rectangles
(two triangles each) spanning z in [-H, H]. The robot is a sphere of its radius centred at z = 0:
its distance to a vertical wall rectangle equals the planar distance from the robot centre to the
wall segment, so sphere-vs-mesh is the exact disc test.
A straight motion is the disc swept along the segment: an FCL capsule of the robot radius lying in
the z = 0 plane along the segment, checked with one discrete collide (exact, no tunnelling, and no
`continuousCollide`, which crashes on BVH meshes in python-fcl). Inside-ness is shapely's
point-in-polygon test; a segment whose centre line leaves the free area at one of 9 probes is
blocked without an FCL query.

`make_checker(map, radius, backend="fcl")` gives this checker; the default indexed checker
(`toolkit.world.collision`) answers the same (the tests compare both on random points and segments
of every bundled and imported map) and scales to maps of 10^5 walls, where python-fcl's per-query
overhead dominates.
"""

from __future__ import annotations

import math
from typing import Any

import fcl
import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .collision import CollisionChecker, segment_arrays
from .maps import Map

__all__ = ["FclCollisionChecker"]

_HALF_HEIGHT = 50.0
_SEGMENT_PROBES = np.linspace(0.0, 1.0, 9)


def _wall_mesh(walls: NDArray[np.float64]) -> fcl.BVHModel:
    n = len(walls)
    verts = np.empty((4 * n, 3))
    verts[0::4] = np.column_stack([walls[:, 0], walls[:, 1], np.full(n, -_HALF_HEIGHT)])
    verts[1::4] = np.column_stack([walls[:, 2], walls[:, 3], np.full(n, -_HALF_HEIGHT)])
    verts[2::4] = np.column_stack([walls[:, 2], walls[:, 3], np.full(n, _HALF_HEIGHT)])
    verts[3::4] = np.column_stack([walls[:, 0], walls[:, 1], np.full(n, _HALF_HEIGHT)])
    b = 4 * np.arange(n)[:, None]
    tris = np.vstack([np.hstack([b, b + 1, b + 2]), np.hstack([b, b + 2, b + 3])]).astype(np.int32)
    model = fcl.BVHModel()
    model.beginModel(len(verts), len(tris))
    model.addSubModel(verts, tris)
    model.endModel()
    return model


class FclCollisionChecker(CollisionChecker):
    """Exact collision checks of a disc robot on python-fcl (same interface and answers as `CollisionChecker`).

    Examples
    --------
    >>> from toolkit.world import load_map
    >>> cc = FclCollisionChecker(load_map("map1"), 8.0)
    >>> cc.point_free([20, 20]), cc.segment_free([20, 20], [80, 20])
    (True, False)
    """

    def __init__(self, map: Map, robot_radius: float) -> None:
        super().__init__(map, robot_radius)
        self._walls = fcl.CollisionObject(_wall_mesh(map.walls), fcl.Transform())
        self._sphere = fcl.CollisionObject(fcl.Sphere(self.robot_radius), fcl.Transform())
        self._request = fcl.CollisionRequest()
        self._dist_request = fcl.DistanceRequest()

    def _sphere_hits(self, x: float, y: float) -> bool:
        self._sphere.setTranslation(np.array([x, y, 0.0]))
        return fcl.collide(self._sphere, self._walls, self._request, fcl.CollisionResult()) > 0

    def _capsule_hits(self, ax: float, ay: float, bx: float, by: float) -> bool:
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        if length < 1e-12:
            return self._sphere_hits(ax, ay)
        c, s = dx / length, dy / length
        # rotation taking the capsule's axis (z) onto the segment direction (c, s, 0)
        rot = np.array([[0.0, -s, c], [0.0, c, s], [-1.0, 0.0, 0.0]])
        tf = fcl.Transform(rot, np.array([(ax + bx) / 2.0, (ay + by) / 2.0, 0.0]))
        capsule = fcl.CollisionObject(fcl.Capsule(self.robot_radius, length), tf)
        return fcl.collide(capsule, self._walls, self._request, fcl.CollisionResult()) > 0

    def point_free(self, xy: ArrayLike) -> Any:
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        inside = self._inside(pts)
        out = np.zeros(len(pts), dtype=bool)
        for i in np.flatnonzero(inside):
            out[i] = not self._sphere_hits(pts[i, 0], pts[i, 1])
        self.point_checks += len(pts)
        return bool(out[0]) if p.ndim == 1 else out

    def segments_free(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        pa, pb = segment_arrays(a, b)
        t = _SEGMENT_PROBES[:, None, None]
        probes = (pa[None] + t * (pb - pa)[None]).reshape(-1, 2)
        inside = self._inside(probes).reshape(len(_SEGMENT_PROBES), -1).all(axis=0)
        out = np.zeros(len(pa), dtype=bool)
        for i in np.flatnonzero(inside):
            out[i] = not self._capsule_hits(pa[i, 0], pa[i, 1], pb[i, 0], pb[i, 1])
        self.segment_checks += len(pa)
        return out

    def clearance(self, xy: ArrayLike) -> Any:
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        inside = self._inside(pts)
        out = np.full(len(pts), -np.inf)
        for i in np.flatnonzero(inside):
            if self._sphere_hits(pts[i, 0], pts[i, 1]):
                out[i] = float(shapely.distance(shapely.Point(pts[i]), self.map.wall_lines)) - self.robot_radius
            else:
                out[i] = fcl.distance(self._sphere, self._walls, self._dist_request, fcl.DistanceResult())
        self.point_checks += len(pts)
        return float(out[0]) if p.ndim == 1 else out
