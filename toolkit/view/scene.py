"""Draw a run in Rerun: `RerunScene` logs the items of a `toolkit.recordings.timeline.Timeline` to a recording stream.

Entities (all under ``world``, in map coordinates, cm):

* ``world/map/walls`` and ``world/map/cspace``: the walls and the free space of the robot disc (static);
* ``world/truth``: the true robot disc and heading; ``world/truth/path`` the way it went;
* ``world/estimate``: the estimate's heading arrow; ``world/estimate/covariance`` its 2-sigma ellipse;
* ``world/particles``: the recorded particles, coloured by weight (viridis: light is heavy);
* ``world/sweep``: the last sweep's echoes (points) and rays, from the pose it was taken at;
* ``world/plan``: the path being driven.

Rerun's 2-D view draws y downward; ``world`` carries a transform that mirrors y, so the map shows
with y up as in the rest of the toolkit while every logged value stays in map coordinates. The time
line ``robot_time`` is the robot's clock.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
import shapely

from ..recordings.timeline import EstimateItem, Item, OdometryItem, PlanItem, RunInfo, SweepItem, TruthItem
from ..world import Pose

__all__ = ["ENTITIES", "RerunScene", "ellipse"]

ENTITIES = ("world/map/walls", "world/map/cspace", "world/truth", "world/truth/heading", "world/truth/path",
            "world/estimate",
            "world/estimate/covariance", "world/particles", "world/sweep/echoes", "world/sweep/rays", "world/plan")
"""Every entity a run with truth, particles, sweeps and a plan logs."""

_WALL = (40, 40, 40)
_CSPACE = (120, 160, 220)
_TRUTH = (30, 150, 60)
_ESTIMATE = (220, 60, 40)
_PLAN = (240, 160, 20)
_ECHO = (200, 40, 160)


def ellipse(mean: Any, cov: Any, sigmas: float = 2.0, n: int = 48) -> np.ndarray:
    """(n + 1, 2) points of the `sigmas` ellipse of a 2-D Gaussian (closed)."""
    vals, vecs = np.linalg.eigh(np.asarray(cov, dtype=float)[:2, :2])
    radii = sigmas * np.sqrt(np.clip(vals, 0.0, None))
    a = np.linspace(0.0, 2.0 * math.pi, n + 1)
    return np.asarray(mean, dtype=float)[:2] + (np.column_stack([np.cos(a), np.sin(a)]) * radii) @ vecs.T


def _rings(geom: Any) -> list[np.ndarray]:
    """Every ring (exterior and holes) of a (multi)polygon as closed (k, 2) arrays."""
    out: list[np.ndarray] = []
    for poly in getattr(geom, "geoms", [geom]):
        if poly.is_empty or not isinstance(poly, shapely.Polygon):
            continue
        out.extend(np.asarray(r.coords)[:, :2] for r in (poly.exterior, *poly.interiors))
    return out


class RerunScene:
    """Logs a run to `stream` (a `rerun.RecordingStream`): `start` once with the run's `RunInfo`, then `log`."""

    def __init__(self, stream: rr.RecordingStream) -> None:
        self.stream = stream
        self.info: RunInfo | None = None
        self._truth_path: list[tuple[float, float]] = []
        self._pose: Pose | None = None  # where the robot is believed (truth when known, else the estimate)

    def start(self, info: RunInfo) -> None:
        """The layout, the y-up transform, the walls and the c-space (static)."""
        self.info = info
        s = self.stream
        s.send_blueprint(rrb.Blueprint(rrb.Spatial2DView(origin="/", name=info.label), collapse_panels=True))
        s.log("world", rr.Transform3D(mat3x3=[[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]), static=True)
        walls = np.asarray(info.map.walls, dtype=float).reshape(-1, 2, 2)
        s.log("world/map/walls", rr.LineStrips2D(walls, colors=_WALL, radii=0.4), static=True)
        cspace = _rings(info.map.free_space(info.robot_radius_cm))
        s.log("world/map/cspace", rr.LineStrips2D(cspace, colors=_CSPACE, radii=0.2), static=True)

    def log(self, item: Item) -> None:
        """Log one item at its robot time."""
        s = self.stream
        s.set_time("robot_time", duration=float(item.t))
        if isinstance(item, TruthItem):
            self._truth(item)
        elif isinstance(item, SweepItem):
            if item.truth is not None:
                self._truth(TruthItem(item.t, item.truth, item.heading_known))
            self._sweep(item)
        elif isinstance(item, EstimateItem):
            self._estimate(item)
        elif isinstance(item, PlanItem):
            s.log("world/plan", rr.LineStrips2D([item.path], colors=_PLAN, radii=0.5))
        elif isinstance(item, OdometryItem):
            pass  # the odometry frame is not drawn: the truth and the estimate say where the robot is

    def _truth(self, item: TruthItem) -> None:
        assert self.info is not None
        p = item.pose
        self._pose = p
        r = self.info.robot_radius_cm
        disc = ellipse(p.xy, np.diag([r * r, r * r]), sigmas=1.0)
        s = self.stream
        s.log("world/truth", rr.LineStrips2D([disc], colors=_TRUTH, radii=0.3))
        if item.heading_known:
            s.log("world/truth/heading", rr.Arrows2D(origins=[p.xy], vectors=[r * np.array([math.cos(p.theta),
                                                                                            math.sin(p.theta)])],
                                                     colors=_TRUTH, radii=0.4))
        self._truth_path.append((p.x, p.y))
        if len(self._truth_path) > 1:
            s.log("world/truth/path", rr.LineStrips2D([self._truth_path], colors=_TRUTH, radii=0.15))

    def _estimate(self, item: EstimateItem) -> None:
        s = self.stream
        e = item.estimate
        p = e.pose
        s.log("world/estimate", rr.Arrows2D(origins=[p.xy], vectors=[6.0 * np.array([math.cos(p.theta),
                                                                                    math.sin(p.theta)])],
                                           colors=_ESTIMATE, radii=0.5))
        cov = np.asarray(e.cov, dtype=float)
        if np.all(np.isfinite(cov[:2, :2])):
            s.log("world/estimate/covariance", rr.LineStrips2D([ellipse(p.xy, cov)], colors=_ESTIMATE, radii=0.25))
        if item.particles is not None and item.weights is not None and item.particles.shape[0]:
            import matplotlib

            w = item.weights / max(float(item.weights.max()), 1e-300)
            colours = (matplotlib.colormaps["viridis"](w)[:, :3] * 255).astype(np.uint8)
            s.log("world/particles", rr.Points2D(item.particles[:, :2], colors=colours, radii=0.6))
        if self._pose is None:
            self._pose = p

    def _sweep(self, item: SweepItem) -> None:
        assert self.info is not None
        pose = item.truth if item.truth is not None and item.heading_known else self._pose
        if pose is None:
            return
        scan = item.scan
        ang = pose.theta + np.asarray(scan.angles, dtype=float)
        d = np.column_stack([np.cos(ang), np.sin(ang)])
        ok = np.asarray(scan.valid, dtype=bool) & np.isfinite(scan.ranges)
        reach = np.where(ok, np.asarray(scan.ranges, dtype=float), 0.0) + self.info.sensor_offset_cm
        hits = pose.xy + d * reach[:, None]
        s = self.stream
        s.log("world/sweep/echoes", rr.Points2D(hits[ok], colors=_ECHO, radii=0.7))
        rays = np.stack([np.repeat(pose.xy[None, :], int(ok.sum()), axis=0), hits[ok]], axis=1)
        s.log("world/sweep/rays", rr.LineStrips2D(list(rays), colors=(*_ECHO, 40), radii=0.05))
