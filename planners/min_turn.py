"""The paper's sampling planner (Liu et al., Algorithm 1): fewest intermediate points, then shortest.

Algorithm 1 of the paper scatters `N` random points in the configuration space and tries to join
start and goal through 0, 1, 2, ... of them with straight segments; among the collision-free
polylines with the fewest intermediate points it keeps the shortest. Fewer intermediate points mean
fewer turns, and fewer turns mean less accumulated heading error on a real differential-drive robot.

This implementation gives exactly that answer for the sampled points without enumerating the
``N! / (N - k)!`` ordered selections in Python, and checks every segment at most once (memoised):

- 0 points: one segment check.
- 1 point: every start->sample and sample->goal segment in one batch (each is needed anyway to prove
  that no one-point path exists); the shortest free one wins.
- 2 and 3 points: the candidate polylines whose first and last segments are free, sorted by length
  (numpy); the unknown middle segments of the next few candidates are checked in one batch; the
  first candidate whose segments are all free is the answer.
- 4 points and more: a lazy hop-constrained shortest path. With the points as nodes of a complete
  graph weighted by Euclidean length, the shortest polyline through exactly ``k`` points is a
  shortest walk with ``k + 1`` edges, found by a ``k + 1``-layer dynamic programme (numpy,
  O(k N^2)) that assumes unknown segments free; the unknown segments of its best walk are checked,
  blocked ones removed, and it runs again until its best walk is all free (the answer) or none is
  left (no path with ``k`` points). Walks that repeat a point are never chosen: such a walk contains
  a shorter one with fewer points, already found blocked.
- Levels are skipped when a breadth-first search over the segments not known to be blocked shows
  that start and goal are more hops apart; a round ends when they are disconnected.

When no path with up to `max_intermediate` points exists among the samples, the planner draws new
samples and tries again until the budget ends, then returns a failed result.

Budget. By default (``deterministic=True``) the budget is counted in rounds of samples, not seconds:
``ceil(rounds_per_s * time_limit)`` rounds (50 per second of budget, about what one core manages on
the bundled pillars map while others share the machine), each finished whole. The same seed then
gives the same result on any machine, under any load and with either collision backend, as OMPL's
planners do here (`planners.ompl_planners`). A wall-clock cap of ten times the budget (at least 30 s)
still ends a round on a machine far slower than that; ``info["stopped_by"]`` says what ended the
call (``solution``, ``rounds`` or ``time``: only the last is not reproducible).
``deterministic=False`` gives the wall-clock budget back (rounds are then cut at the deadline).

Objectives. ``turns`` (the default) is the paper's rule above: fewest points, then shortest.
``robot-time`` keeps the fewest points (its defining rule) and orders the polylines with that many by
their robot time instead of their length (`toolkit.world.robot_times_s`, the problem's timing): exactly
for 1, 2 and 3 points; from 4 points on, the lazy dynamic programme still walks them by length (a
turn's cost depends on two edges, which its edge weights cannot hold).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from toolkit.world import CollisionChecker, RobotTiming, robot_times_s
from toolkit.world.arrays import FloatArray

from .base import Planner, PlanningProblem, PlanStatus, Solution
from .declarations import MinTurnOptions

__all__ = ["MinTurnPlanner", "fewest_points_path", "hop_shortest_path"]


_UNKNOWN, _FREE, _BLOCKED = 0, 1, -1
_WINDOW = 512  # candidates examined at a time
_BATCH = 8  # candidates whose unknown segments are checked in one batch
_MAX_ENUMERATED = 200_000  # largest three-point candidate set sorted in full
_TIME_CAP = 10.0  # deterministic budget: wall-clock cap, in multiples of the time limit ...
_TIME_CAP_MIN_S = 30.0  # ... and at least this long


def hop_shortest_path(cost: FloatArray, source: int, target: int, hops: int) -> tuple[float, list[int]]:
    """Shortest walk from `source` to `target` with exactly `hops` edges.

    Parameters
    ----------
    cost : (n, n) ndarray
        Edge costs; ``inf`` where there is no edge.
    source, target : int
        Node indices.
    hops : int
        Number of edges (>= 1).

    Returns
    -------
    (float, list of int)
        The cost (``inf`` when there is no such walk) and the node sequence (empty when none).

    Examples
    --------
    >>> c = np.array([[np.inf, 5.0, 1.0], [5.0, np.inf, 1.0], [1.0, 1.0, np.inf]])
    >>> hop_shortest_path(c, 0, 1, 2)
    (2.0, [0, 2, 1])
    """
    n = cost.shape[0]
    dist = np.full(n, np.inf)
    dist[source] = 0.0
    parents = np.empty((hops, n), dtype=np.intp)
    for h in range(hops):
        total = dist[:, None] + cost
        parents[h] = np.argmin(total, axis=0)
        dist = total[parents[h], np.arange(n)]
    best = float(dist[target])
    if not math.isfinite(best):
        return math.inf, []
    seq = [target]
    for h in range(hops - 1, -1, -1):
        seq.append(int(parents[h, seq[-1]]))
    seq.reverse()
    return best, seq


class MinTurnPlanner(Planner):
    """The paper's min-turn sampling planner (Algorithm 1), exact for its samples and fast.

    Parameters
    ----------
    options : MinTurnOptions, optional
        The options (`planners.declarations.MinTurnOptions`; None: the defaults): `n_samples` random
        configuration-space points per round (the paper's 30); `max_intermediate` points tried per round
        before drawing new samples (None: up to all the samples, as in the paper's loop ``i = 1 .. N``);
        `max_rounds` of samples even if budget remains; with `deterministic` the budget is counted in
        rounds (`rounds_per_s` per second of the time limit), so the result does not depend on the
        machine's speed.
    **overrides
        Options on top of `options` by name (``n_samples=60``).

    Notes
    -----
    Samples are drawn uniformly from the free area at least one robot radius from every wall
    (``Map.sample_free``) and each is confirmed with the checker's point check. The answer is
    "the shortest collision-free polyline among those with the fewest intermediate sample points",
    exactly, for the samples of the round that found it. ``info`` reports ``intermediate`` (points
    used), ``rounds``, ``lazy_iterations`` and ``segments_checked``.
    """

    name = "min-turn"
    options_model = MinTurnOptions
    objectives = ("turns", "robot-time")

    def __init__(self, options: MinTurnOptions | None = None, **overrides: Any) -> None:
        o: MinTurnOptions = self.configure(options, overrides)
        self.options = o
        self.n_samples, self.max_intermediate, self.max_rounds = o.n_samples, o.max_intermediate, o.max_rounds
        self.deterministic, self.rounds_per_s = o.deterministic, o.rounds_per_s
        self._set_objective(o.objective)

    def _limits(self, time_limit: float) -> tuple[int | None, float]:
        """Most rounds (None: no count) and the wall-clock seconds the call may take."""
        if not self.deterministic:
            return self.max_rounds, time_limit
        rounds = max(1, math.ceil(self.rounds_per_s * time_limit))
        if self.max_rounds is not None:
            rounds = min(rounds, self.max_rounds)
        return rounds, max(_TIME_CAP * time_limit, _TIME_CAP_MIN_S)

    def _sample(self, problem: PlanningProblem, deadline: float) -> FloatArray:
        """`n_samples` points uniform over the free area, one radius from the walls, confirmed by the checker.

        Rejection sampling in the map's bounding box (shapely's vectorised distance test, then the
        checker's point check); it stops at the deadline with the points it has.
        """
        m, rng, r = problem.map, problem.rng, problem.robot_radius
        xmin, ymin, xmax, ymax = m.bounds
        found: list[FloatArray] = []
        have = 0
        while have < self.n_samples and time.perf_counter() < deadline:
            cand = rng.uniform([xmin, ymin], [xmax, ymax], size=(8 * self.n_samples, 2))
            keep = cand[np.asarray(m.is_free(cand, r), dtype=bool)]
            found.append(keep)
            have += len(keep)
        if not found:
            return np.empty((0, 2))
        pts = np.vstack(found)[: self.n_samples]
        return pts[np.asarray(problem.checker.point_free(pts), dtype=bool)]

    def _solve(self, problem: PlanningProblem) -> Solution:
        checker = problem.checker
        limit, seconds = self._limits(problem.time_limit)
        deadline = time.perf_counter() + seconds
        start, goal = problem.start, problem.goal
        info: dict[str, Any] = {"rounds": 0, "lazy_iterations": 0, "segments_checked": 1, "stopped_by": "solution"}
        if checker.segment_free(start, goal):
            info.update(intermediate=0, rounds=1)
            return Solution(np.array([start, goal]), PlanStatus.EXACT, info)
        rounds, late = 0, False
        while not late and (limit is None or rounds < limit):
            rounds += 1
            info["rounds"] = rounds
            samples = self._sample(problem, deadline)
            found = fewest_points_path(checker, start, goal, samples, self.max_intermediate, deadline,
                                       info, direct_known_blocked=True,
                                       timing=problem.timing if self.objective == "robot-time" else None)
            if found is not None:
                return Solution(found, PlanStatus.EXACT, info)
            late = time.perf_counter() >= deadline  # the clock ended (or cut) this round
        info["stopped_by"] = "time" if late else "rounds"
        if not late and self.max_rounds is not None and rounds >= self.max_rounds:
            return Solution(None, PlanStatus.NO_PATH, info, "no path in max_rounds")
        return Solution(None, PlanStatus.TIMEOUT, info)


def fewest_points_path(
    checker: CollisionChecker,
    start: ArrayLike,
    goal: ArrayLike,
    samples: ArrayLike,
    max_intermediate: int | None = None,
    deadline: float = math.inf,
    info: dict[str, Any] | None = None,
    *,
    direct_known_blocked: bool = False,
    timing: RobotTiming | None = None,
) -> FloatArray | None:
    """The shortest collision-free polyline start -> samples -> goal with the fewest sample points.

    Parameters
    ----------
    checker : CollisionChecker
        Decides which segments are free (each segment is checked at most once).
    start, goal : (2,) array_like
        End points in cm (assumed collision-free).
    samples : (m, 2) array_like
        Candidate intermediate points in cm (assumed collision-free).
    max_intermediate : int or None
        Most intermediate points to use (None: up to all of them).
    deadline : float
        `time.perf_counter()` value after which the search gives up (returns None).
    info : dict, optional
        Counters ``lazy_iterations`` and ``segments_checked`` are added to it; ``intermediate`` is
        set to the number of points used.
    direct_known_blocked : bool
        The caller already knows that the straight segment start -> goal is blocked.
    timing : RobotTiming or None
        Order the polylines with the fewest points by this robot's time rather than by length (see
        the module notes).

    Returns
    -------
    (k, 2) ndarray or None
        The polyline (start and goal included), or None when no polyline through at most
        `max_intermediate` of the samples is collision-free (or the deadline passed).
    """
    stats = info if info is not None else {}
    stats.setdefault("lazy_iterations", 0)
    stats.setdefault("segments_checked", 0)
    a, b = np.asarray(start, dtype=float).reshape(2), np.asarray(goal, dtype=float).reshape(2)
    if not direct_known_blocked:
        stats["segments_checked"] += 1
        if checker.segment_free(a, b):
            stats["intermediate"] = 0
            return np.array([a, b])
    pts = np.asarray(samples, dtype=float).reshape(-1, 2)
    limit = len(pts) if max_intermediate is None else min(int(max_intermediate), len(pts))
    if limit < 1:
        return None
    return _round(checker, np.vstack([a, b, pts]), limit, deadline, stats, timing)


def _min_hops(status: NDArray[np.int8]) -> int:
    """Fewest edges from node 0 to node 1 over edges not known to be blocked (a large number if none)."""
    adj = status != _BLOCKED
    adj[:, 0] = False
    adj[1, :] = False
    seen = np.zeros(len(status), dtype=bool)
    seen[0] = True
    frontier = seen.copy()
    hops = 0
    while frontier.any():
        hops += 1
        frontier = np.any(adj[frontier], axis=0) & ~seen
        if frontier[1]:
            return hops
        seen |= frontier
    return len(status) + 1


def _two_point_candidates(length: FloatArray, first: NDArray[np.intp], last: NDArray[np.intp]) -> NDArray[np.intp]:
    """Paths start -> a -> c -> goal (a seen from the start, c from the goal), shortest first, as their
    one unknown edge (a, c): shape (m, 1, 2)."""
    cost = length[0, first][:, None] + length[np.ix_(first, last)] + length[last, 1][None, :]
    ia, ic = np.nonzero(np.isfinite(cost) & (first[:, None] != last[None, :]))
    order = np.argsort(cost[ia, ic], kind="stable")
    a, c = first[ia[order]], last[ic[order]]
    return np.stack([np.stack([a, c], axis=1)], axis=1)


def _three_point_candidates(length: FloatArray, status: NDArray[np.int8], first: NDArray[np.intp],
                            samples: NDArray[np.intp], last: NDArray[np.intp]) -> NDArray[np.intp]:
    """Paths start -> a -> b -> c -> goal over distinct samples whose edges are not known to be
    blocked, shortest first, as their two unknown edges ((a, b), (b, c)): shape (m, 2, 2)."""
    cost = (length[0, first][:, None, None] + length[np.ix_(first, samples)][:, :, None]
            + length[np.ix_(samples, last)][None, :, :] + length[last, 1][None, None, :])
    fa, fb, fc = np.ix_(first, samples, last)
    valid = (fa != fb) & (fb != fc) & (fa != fc)
    valid &= (status[fa, fb] != _BLOCKED) & (status[fb, fc] != _BLOCKED)
    ia, ib, ic = np.nonzero(valid)
    order = np.argsort(cost[ia, ib, ic], kind="stable")
    a, b, c = first[ia[order]], samples[ib[order]], last[ic[order]]
    return np.stack([np.stack([a, b], axis=1), np.stack([b, c], axis=1)], axis=1)


def _round(checker: CollisionChecker, nodes: FloatArray, max_intermediate: int, deadline: float,
           info: dict[str, Any], timing: RobotTiming | None = None) -> FloatArray | None:
    """Search one set of samples; nodes[0] is the start, nodes[1] the goal (the direct edge is blocked).

    Level 1 checks every start->sample and sample->goal segment at once (a one-point path needs
    both, and every one of them is needed to prove that no one-point path exists). Levels 2 and 3
    walk the candidate polylines in order of length (numpy-sorted, only those whose first and
    last segments are free) and check the unknown segments of the next few candidates in one
    batch; the first candidate whose segments are all free is the answer. Deeper levels (or huge
    candidate sets) use the lazy hop-constrained shortest path of `hop_shortest_path`.
    """
    n = len(nodes)
    diff = nodes[:, None, :] - nodes[None, :, :]
    length = np.hypot(diff[..., 0], diff[..., 1])
    status = np.zeros((n, n), dtype=np.int8)
    np.fill_diagonal(status, _BLOCKED)
    status[0, 1] = status[1, 0] = _BLOCKED
    if n <= 2:
        return None
    samples = np.arange(2, n)
    ok_start = checker.segments_free(np.repeat(nodes[:1], n - 2, axis=0), nodes[2:])
    ok_goal = checker.segments_free(nodes[2:], np.repeat(nodes[1:2], n - 2, axis=0))
    info["segments_checked"] += 2 * (n - 2)
    _set(status, np.zeros(n - 2, dtype=np.intp), samples, ok_start)
    _set(status, samples, np.ones(n - 2, dtype=np.intp), ok_goal)
    both = ok_start & ok_goal
    if np.any(both):
        score = length[0, 2:] + length[2:, 1]
        if timing is not None:
            score = robot_times_s(np.stack([np.repeat(nodes[:1], n - 2, axis=0), nodes[2:],
                                            np.repeat(nodes[1:2], n - 2, axis=0)], axis=1), timing)
        p = samples[np.argmin(np.where(both, score, np.inf))]
        info["intermediate"] = 1
        return nodes[[0, p, 1]]
    first = samples[ok_start]
    last = samples[ok_goal]
    if len(first) == 0 or len(last) == 0:
        return None  # no sample is visible from the start (or the goal): no path at any level
    k = 1
    while k < max_intermediate:
        # no path has fewer segments than the fewest hops over edges not known to be blocked
        k = max(k + 1, _min_hops(status) - 1)
        if k > max_intermediate:
            return None
        if k == 2:
            cand = _by_time(nodes, _two_point_candidates(length, first, last), timing)
            seq = _walk(checker, nodes, status, cand, deadline, info)
            if seq is not None:
                info["intermediate"] = 2
                return nodes[[0, seq[0, 0], seq[0, 1], 1]]
        elif k == 3 and len(first) * len(samples) * len(last) <= _MAX_ENUMERATED:
            cand = _by_time(nodes, _three_point_candidates(length, status, first, samples, last), timing)
            seq = _walk(checker, nodes, status, cand, deadline, info)
            if seq is not None:
                info["intermediate"] = 3
                return nodes[[0, seq[0, 0], seq[0, 1], seq[1, 1], 1]]
        else:
            found = _lazy_dp(checker, nodes, length, status, k, deadline, info)
            if found is not None:
                info["intermediate"] = k
                return nodes[found]
        if time.perf_counter() >= deadline:
            return None
    return None


def _by_time(nodes: FloatArray, cand: NDArray[np.intp], timing: RobotTiming | None) -> NDArray[np.intp]:
    """Candidates (m, e, 2) of `_two_point_candidates` or `_three_point_candidates` in order of robot time
    (unchanged without a `timing`)."""
    if timing is None or len(cand) == 0:
        return cand
    inner = np.concatenate([cand[:, :1, 0], cand[:, :, 1]], axis=1)  # the intermediate points, in order
    m = len(cand)
    seq = np.concatenate([np.zeros((m, 1), dtype=np.intp), inner, np.ones((m, 1), dtype=np.intp)], axis=1)
    return cand[np.argsort(robot_times_s(nodes[seq], timing), kind="stable")]


def _set(status: NDArray[np.int8], ia: NDArray[np.intp], ib: NDArray[np.intp], ok: NDArray[np.bool_]) -> None:
    val = np.where(ok, _FREE, _BLOCKED).astype(np.int8)
    status[ia, ib] = val
    status[ib, ia] = val


def _walk(checker: CollisionChecker, nodes: FloatArray, status: NDArray[np.int8], cand: NDArray[np.intp],
          deadline: float, info: dict[str, Any]) -> NDArray[np.intp] | None:
    """First candidate (in the given order) whose edges are all free; cand is (m, e, 2) node pairs."""
    pos = 0
    while pos < len(cand):
        win = cand[pos:pos + _WINDOW]
        while True:
            if time.perf_counter() >= deadline:
                return None
            info["lazy_iterations"] += 1
            st = status[win[..., 0], win[..., 1]]
            alive = np.flatnonzero(~np.any(st == _BLOCKED, axis=1))
            if len(alive) == 0:
                break
            if np.all(st[alive[0]] == _FREE):
                return win[alive[0]]
            head = alive[:_BATCH]
            edges = win[head][st[head] == _UNKNOWN]
            n = len(status)
            code = np.unique(np.minimum(edges[:, 0], edges[:, 1]) * n + np.maximum(edges[:, 0], edges[:, 1]))
            edges = np.stack([code // n, code % n], axis=1)
            ok = checker.segments_free(nodes[edges[:, 0]], nodes[edges[:, 1]])
            info["segments_checked"] += len(edges)
            _set(status, edges[:, 0], edges[:, 1], ok)
        pos += _WINDOW
    return None


def _lazy_dp(checker: CollisionChecker, nodes: FloatArray, length: FloatArray, status: NDArray[np.int8], k: int,
             deadline: float, info: dict[str, Any]) -> list[int] | None:
    """Shortest path with exactly k intermediate points by the lazy hop-constrained shortest path."""
    cost = np.where(status == _BLOCKED, np.inf, length)
    cost[:, 0] = np.inf  # never re-enter the start
    cost[1, :] = np.inf  # never leave the goal
    while time.perf_counter() < deadline:
        info["lazy_iterations"] += 1
        _, seq = hop_shortest_path(cost, 0, 1, k + 1)
        if not seq:
            return None
        pairs = np.array([seq[:-1], seq[1:]]).T
        unknown = pairs[status[pairs[:, 0], pairs[:, 1]] == _UNKNOWN]
        if len(unknown) == 0:
            return seq
        ok = checker.segments_free(nodes[unknown[:, 0]], nodes[unknown[:, 1]])
        info["segments_checked"] += len(unknown)
        _set(status, unknown[:, 0], unknown[:, 1], ok)
        bad = unknown[~ok]
        cost[bad[:, 0], bad[:, 1]] = np.inf
        cost[bad[:, 1], bad[:, 0]] = np.inf
    return None
