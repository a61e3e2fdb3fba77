"""The indexed disc checker against python-fcl: the same answers on random points and segments."""

from __future__ import annotations

import numpy as np
import pytest

from toolkit.world import CollisionChecker, MapError, load_map, make_checker
from toolkit.world.fcl_collision import FclCollisionChecker


@pytest.mark.parametrize(("name", "radius"), [("map1", 8.0), ("map2", 8.0), ("map3", 8.0), ("pillars", 8.0),
                                              ("turtlebot3_world", 8.0), ("arena2", 2.0), ("co333-arena", 8.0)])
def test_index_and_fcl_agree(name: str, radius: float) -> None:
    m = load_map(name)
    index, ref = make_checker(m, radius), make_checker(m, radius, backend="fcl")
    assert type(index) is CollisionChecker and isinstance(ref, FclCollisionChecker)
    rng = np.random.default_rng(3)
    xmin, ymin, xmax, ymax = m.bounds
    a = np.vstack([rng.uniform([xmin, ymin], [xmax, ymax], (2500, 2)), m.sample_free(2500, radius, rng)])
    b = a + rng.normal(0.0, 0.05 * max(xmax - xmin, ymax - ymin), a.shape)
    truth = ref.segments_free(a, b)
    assert 0.05 < truth.mean() < 0.95, "both outcomes are exercised"
    assert int((index.segments_free(a, b) != truth).sum()) == 0
    assert int((index.point_free(a) != ref.point_free(a)).sum()) == 0
    np.testing.assert_allclose(index.clearance(a[:300]), ref.clearance(a[:300]), atol=1e-6)


def test_unknown_backend_is_refused() -> None:
    with pytest.raises(MapError, match="unknown collision backend 'ode'; known: index, fcl"):
        make_checker(load_map("map1"), 8.0, backend="ode")
