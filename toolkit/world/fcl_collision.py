"""The same disc checks on python-fcl: the reference backend the indexed checker is tested against.

The walls (`Map.walls`: polygon edges and thin walls alike) become one FCL BVH of vertical rectangles
(two triangles each) spanning z in [-H, H]. The robot is a sphere of its radius centred at z = 0:
its distance to a vertical wall rectangle equals the planar distance from the robot centre to the
wall segment, so sphere-vs-mesh is the exact disc test.
A straight motion is the disc swept along the segment: an FCL capsule of the robot radius lying in
the z = 0 plane along the segment, checked with discrete collides (no tunnelling, and no
`continuousCollide`, which crashes on BVH meshes in python-fcl). Inside-ness is shapely's
point-in-polygon test; a segment whose centre line leaves the free area at one of 9 probes is
blocked without an FCL query.

FCL's narrow phase (GJK) decides contact within a tolerance: a motion that dips 5e-8 cm into a
wall's reach can come back free. So each check asks FCL twice, with the radius grown and shrunk by
a band of ``1e-6`` times the map's extent (at least 1e-6 cm): free with the grown radius is free,
in contact with the shrunk one is in contact, and the rare check in between (a disc touching a
wall to within the band, as on grid nodes exactly one radius from a wall) is decided by the exact
planar distance (`toolkit.world.edge_index`, the indexed checker's). ``exact_decisions`` counts
those. `clearance` is the exact planar distance too: FCL's distance query is accurate to about
1e-7 cm, which shows in the tenth digit of a result file.

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
from numpy.typing import ArrayLike, NDArray

from .collision import CollisionChecker, segment_arrays
from .maps import Map

__all__ = ["FclCollisionChecker"]

_HALF_HEIGHT = 50.0
_SEGMENT_PROBES = np.linspace(0.0, 1.0, 9)
_BAND = 1e-6  # FCL's undecided band around contact, relative to the map's extent (see the module docstring)


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

    Attributes
    ----------
    band_cm : float
        Half-width of the band around contact that FCL leaves to the exact planar test (cm).
    exact_decisions : int
        Checks decided by the exact planar test (FCL found them within the band).

    Examples
    --------
    >>> from toolkit.world import load_map
    >>> cc = FclCollisionChecker(load_map("map1"), 8.0)
    >>> cc.point_free([20, 20]), cc.segment_free([20, 20], [80, 20])
    (True, False)
    """

    backend = "fcl"

    def __init__(self, map: Map, robot_radius: float) -> None:
        super().__init__(map, robot_radius)
        xmin, ymin, xmax, ymax = map.bounds
        self.band_cm = _BAND * max(1.0, xmax - xmin, ymax - ymin, abs(xmin), abs(ymin), abs(xmax), abs(ymax))
        self.exact_decisions = 0
        self._walls = fcl.CollisionObject(_wall_mesh(map.walls), fcl.Transform())
        outer, inner = self.robot_radius + self.band_cm, self.robot_radius - self.band_cm
        self._radii = (outer, inner) if inner > 0 else (outer,)
        self._spheres = [fcl.CollisionObject(fcl.Sphere(r), fcl.Transform()) for r in self._radii]
        self._request = fcl.CollisionRequest()

    def _hits(self, obj: fcl.CollisionObject) -> bool:
        return fcl.collide(obj, self._walls, self._request, fcl.CollisionResult()) > 0

    def _sphere_contact(self, x: float, y: float) -> bool | None:
        """FCL's answer for the disc at (x, y): True (contact), False (free) or None (within the band)."""
        for sphere in self._spheres:
            sphere.setTranslation(np.array([x, y, 0.0]))
        if not self._hits(self._spheres[0]):
            return False
        return True if len(self._spheres) > 1 and self._hits(self._spheres[1]) else None

    def _capsule_contact(self, ax: float, ay: float, bx: float, by: float) -> bool | None:
        """FCL's answer for the disc swept from a to b, as `_sphere_contact`."""
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        if length < 1e-12:
            return self._sphere_contact(ax, ay)
        c, s = dx / length, dy / length
        # rotation taking the capsule's axis (z) onto the segment direction (c, s, 0)
        rot = np.array([[0.0, -s, c], [0.0, c, s], [-1.0, 0.0, 0.0]])
        tf = fcl.Transform(rot, np.array([(ax + bx) / 2.0, (ay + by) / 2.0, 0.0]))
        if not self._hits(fcl.CollisionObject(fcl.Capsule(self._radii[0], length), tf)):
            return False
        if len(self._radii) > 1 and self._hits(fcl.CollisionObject(fcl.Capsule(self._radii[1], length), tf)):
            return True
        return None

    def _decide(self, pa: NDArray[np.float64], pb: NDArray[np.float64], candidates: NDArray[np.intp],
                contact: list[bool | None]) -> NDArray[np.bool_]:
        """Free flags of the `candidates` (inside the map) from FCL's answers, the band decided exactly."""
        out = np.array([c is False for c in contact], dtype=bool)
        band = np.array([c is None for c in contact], dtype=bool)
        if band.any():
            k = candidates[band]
            out[band] = self.index.capsules_clear(pa[k], pb[k], self.robot_radius)
            self.exact_decisions += int(band.sum())
        return out

    def point_free(self, xy: ArrayLike) -> Any:
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        out = np.zeros(len(pts), dtype=bool)
        idx = np.flatnonzero(self._inside(pts))
        out[idx] = self._decide(pts, pts, idx, [self._sphere_contact(pts[i, 0], pts[i, 1]) for i in idx])
        self.point_checks += len(pts)
        return bool(out[0]) if p.ndim == 1 else out

    def segments_free(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        pa, pb = segment_arrays(a, b)
        t = _SEGMENT_PROBES[:, None, None]
        probes = (pa[None] + t * (pb - pa)[None]).reshape(-1, 2)
        inside = self._inside(probes).reshape(len(_SEGMENT_PROBES), -1).all(axis=0)
        out = np.zeros(len(pa), dtype=bool)
        idx = np.flatnonzero(inside)
        out[idx] = self._decide(pa, pb, idx, [self._capsule_contact(pa[i, 0], pa[i, 1], pb[i, 0], pb[i, 1])
                                              for i in idx])
        self.segment_checks += len(pa)
        return out
