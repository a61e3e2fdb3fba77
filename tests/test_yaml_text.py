"""Every YAML the toolkit reads takes numbers as YAML 1.2 does (`toolkit.world.yaml_text`): ``1e2`` is a
number in a map, a profile or an option, as ROS tools read it; PyYAML itself is left as it is."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from toolkit.world import load_map
from toolkit.world.yaml_text import load_yaml


@pytest.mark.parametrize(("text", "value"), [
    ("1e9", 1e9), ("8e-3", 0.008), ("-2.5E+3", -2500.0), ("1.5e2", 150.0), ("10", 10), ("1_000", 1000),
    ("0.5", 0.5), ("'1e9'", "1e9"), ("1e9x", "1e9x"), ("e9", "e9"), (".inf", float("inf")), ("true", True),
])
def test_numbers_as_yaml_1_2_reads_them(text: str, value: object) -> None:
    got = load_yaml(f"v: {text}")["v"]
    assert got == value and type(got) is type(value)


def test_pyyaml_itself_is_left_alone() -> None:
    assert yaml.safe_load("v: 1e9")["v"] == "1e9"  # the loader is the toolkit's own, not a patch of PyYAML


def test_a_map_written_with_exponents_is_the_same_map(tmp_path: Path) -> None:
    plain, expo = tmp_path / "plain.yaml", tmp_path / "expo.yaml"
    plain.write_text("name: box\nboundary: [[0, 0], [100, 0], [100, 50], [0, 50]]\nstart: [20, 20]\n")
    expo.write_text("name: box\nboundary: [[0, 0], [1e2, 0], [1e2, 5e1], [0, 5.0E1]]\nstart: [2e1, 20]\n")
    a, b = load_map(plain), load_map(expo)
    assert np.array_equal(a.walls, b.walls) and np.array_equal(a.start, b.start)
