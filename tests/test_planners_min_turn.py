"""The min-turn search against brute force: fewest intermediate points, then the shortest polyline."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from planners import PlanStatus
from planners.min_turn import MinTurnPlanner, fewest_points_path, hop_shortest_path
from toolkit.world import CollisionChecker, load_map


def brute_force(checker: CollisionChecker, start: np.ndarray, goal: np.ndarray, samples: np.ndarray,
                max_k: int) -> tuple[int, float] | None:
    """Enumerate every ordered selection of k samples, k = 0, 1, ...; first k with a free polyline wins."""
    for k in range(max_k + 1):
        best = math.inf
        for combo in itertools.permutations(range(len(samples)), k):
            path = np.vstack([start, samples[list(combo)], goal]) if k else np.vstack([start, goal])
            length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
            if length < best and checker.path_free(path):
                best = length
        if math.isfinite(best):
            return k, best
    return None


@pytest.mark.parametrize(("map_name", "seed"), [("map2", 0), ("map2", 1), ("map3", 2), ("map3", 3), ("pillars", 4),
                                                ("pillars", 5), ("map1", 6)])
def test_fewest_points_path_matches_brute_force(map_name: str, seed: int) -> None:
    m = load_map(map_name)
    checker = CollisionChecker(m, 8.0)
    rng = np.random.default_rng(seed)
    samples = m.sample_free(8, clearance=8.0, rng=rng)
    samples = samples[checker.point_free(samples)]
    max_k = 4
    expected = brute_force(checker, m.start, m.target, samples, max_k)
    info: dict[str, int] = {}
    got = fewest_points_path(checker, m.start, m.target, samples, max_k, info=info)
    if expected is None:
        assert got is None
        return
    assert got is not None
    k, length = expected
    assert len(got) - 2 == k == info["intermediate"]
    assert float(np.sum(np.hypot(*np.diff(got, axis=0).T))) == pytest.approx(length, rel=1e-12)
    assert checker.path_free(got)
    # each segment is checked at most once: never more checks than distinct segments
    n = len(samples) + 2
    assert info["segments_checked"] <= n * (n - 1) // 2


def test_deeper_levels_match_brute_force() -> None:
    """Pillars needs 4+ points (the lazy dynamic programme): min-link's bends plus random distractors."""
    from planners import PlanningProblem
    from planners.reference import MinLinkPlanner

    m = load_map("pillars")
    checker = CollisionChecker(m, 8.0)
    bends = MinLinkPlanner().plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0)).path[1:-1]
    assert len(bends) >= 4
    for seed in range(2):
        extra = m.sample_free(2, clearance=8.0, rng=seed)
        samples = np.vstack([bends, extra[checker.point_free(extra)]])
        samples = samples[np.random.default_rng(seed).permutation(len(samples))]
        expected = brute_force(checker, m.start, m.target, samples, len(bends))
        info: dict[str, int] = {}
        got = fewest_points_path(checker, m.start, m.target, samples, None, info=info)
        assert expected is not None and got is not None
        assert expected[0] >= 4
        assert len(got) - 2 == expected[0] == info["intermediate"]
        assert float(np.sum(np.hypot(*np.diff(got, axis=0).T))) == pytest.approx(expected[1], rel=1e-12)
        assert checker.path_free(got)


def test_hop_shortest_path_matches_enumeration() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        n = 6
        cost = rng.uniform(1, 10, size=(n, n))
        cost[rng.uniform(size=(n, n)) < 0.4] = np.inf
        np.fill_diagonal(cost, np.inf)
        for hops in (1, 2, 3):
            best = math.inf
            for mid in itertools.product(range(n), repeat=hops - 1):
                seq = [0, *mid, 1]
                best = min(best, sum(cost[a, b] for a, b in itertools.pairwise(seq)))
            got, seq = hop_shortest_path(cost, 0, 1, hops)
            assert got == pytest.approx(best) if math.isfinite(best) else math.isinf(got)
            if seq:
                assert len(seq) == hops + 1 and seq[0] == 0 and seq[-1] == 1
                assert sum(cost[a, b] for a, b in itertools.pairwise(seq)) == pytest.approx(got)


def test_direct_path_when_visible() -> None:
    m = load_map("map1")
    checker = CollisionChecker(m, 8.0)
    from planners import PlanningProblem

    res = MinTurnPlanner().plan(PlanningProblem(m, checker, [20, 20], [40, 80], 1.0, 0))
    assert res.success and len(res.path) == 2 and res.info["intermediate"] == 0


def test_options_are_validated() -> None:
    with pytest.raises(ValueError, match="n_samples"):
        MinTurnPlanner(n_samples=0)
    with pytest.raises(ValueError, match="max_intermediate"):
        MinTurnPlanner(max_intermediate=0)


def test_max_rounds_limits_retries() -> None:
    from planners import PlanningProblem

    m = load_map("pillars")
    checker = CollisionChecker(m, 8.0)
    res = MinTurnPlanner(n_samples=3, max_intermediate=1, max_rounds=4).plan(
        PlanningProblem(m, checker, m.start, m.target, 10.0, 0))
    assert not res.success and res.status is PlanStatus.NO_PATH and res.detail == "no path in max_rounds"
    assert res.info["rounds"] == 4
    assert res.message == "no path (no path in max_rounds)"
    doc = res.to_dict()
    assert doc["status"] == "no path" and doc["detail"] == "no path in max_rounds"


def test_the_budget_is_counted_in_rounds() -> None:
    """Deterministic by default: 50 rounds per second of budget, however fast the machine is."""
    from planners import PlanningProblem

    m = load_map("pillars")
    checker = CollisionChecker(m, 8.0)
    problem = PlanningProblem(m, checker, m.start, m.target, 0.1, 0)
    res = MinTurnPlanner(n_samples=3, max_intermediate=1).plan(problem)
    assert res.status is PlanStatus.TIMEOUT and res.info["rounds"] == 5 and res.info["stopped_by"] == "rounds"
    again = MinTurnPlanner(n_samples=3, max_intermediate=1, rounds_per_s=20.0).plan(
        PlanningProblem(m, checker, m.start, m.target, 0.1, 0))
    assert again.info["rounds"] == 2
    clock = MinTurnPlanner(n_samples=3, max_intermediate=1, deterministic=False).plan(
        PlanningProblem(m, checker, m.start, m.target, 0.05, 0))
    assert clock.status is PlanStatus.TIMEOUT and clock.info["stopped_by"] == "time"
    with pytest.raises(ValueError, match="rounds_per_s"):
        MinTurnPlanner(rounds_per_s=0.0)
