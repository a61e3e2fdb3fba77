"""`nxtnav planners check` and `nxtnav localisers check MODULE:CLASS`, run as a plug-in author runs them:
the real console script, in a folder outside the repository that holds the author's module. Each
problem is one line on stdout (exit 1); a bad MODULE:CLASS is one `nxtnav: error:` line (exit 2)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from conftest import nxtnav_exe

EXE = nxtnav_exe()

HEADER = '''from __future__ import annotations

import numpy as np

from planners import Planner, PlanStatus
from planners.base import Solution
from toolkit.world import Options, option
'''

UNDECLARED = HEADER + '''

class DetourPlanner(Planner):
    """Straight if free, else one random sideways detour: no declared options (the former guide's)."""

    name = "detour"

    def __init__(self, max_offset: float = 50.0, tries: int = 200) -> None:
        self.max_offset, self.tries = max_offset, tries

    def _solve(self, problem):
        a, b, check = problem.start, problem.goal, problem.checker
        if check.segment_free(a, b):
            return Solution(np.array([a, b]), PlanStatus.EXACT)
        d = b - a
        normal = np.array([-d[1], d[0]]) / np.hypot(*d)
        for offset in problem.rng.uniform(-self.max_offset, self.max_offset, self.tries):
            p = (a + b) / 2 + offset * normal
            if check.point_free(p) and check.segment_free(a, p) and check.segment_free(p, b):
                return Solution(np.array([a, p, b]), PlanStatus.EXACT)
        return Solution(None, PlanStatus.NO_PATH, detail="no detour found")
'''

CARELESS = HEADER + '''

class CarelessOptions(Options):
    wobble: float = option(1.0, "Random sideways wobble of the midpoint", unit="cm", ge=0.0)


class Careless(Planner):
    """Declares its options, but goes straight through the walls and draws from numpy's global stream."""

    name = "careless"
    options_model = CarelessOptions

    def __init__(self, options=None, **overrides) -> None:
        self.wobble = self.configure(options, overrides).wobble

    def _solve(self, problem):
        mid = (problem.start + problem.goal) / 2 + np.random.uniform(-self.wobble, self.wobble, 2)
        return Solution(np.array([problem.start, mid, problem.goal]), PlanStatus.EXACT)
'''

HALF_LOCALISER = '''from __future__ import annotations

import numpy as np

from localisation import Localiser, PoseEstimate
from toolkit.world import Options, Pose, option


class StubbornOptions(Options):
    sensor_sigma_cm: float = option(1.0, "Range sigma", unit="cm", ge=1e-6, robot=True)


class Stubborn(Localiser):
    """Believes the robot never moves: declares little and refuses the lobe without a reason."""

    name = "stubborn"
    options_model = StubbornOptions
    robot_options = {"motion": "ignores every motion, always", "sensor_sigma": ("sensor_sigma_cm",),
                     "lobe": "no"}

    def __init__(self, map, options=None, *, rng=None, **overrides) -> None:
        super().__init__(map, rng=rng)
        self.options = self.configure(options, overrides)
        self.pose = Pose(0.0, 0.0, 0.0)

    def reset(self, prior=None) -> None:
        self.pose = prior.mean if prior is not None else Pose(0.0, 0.0, 0.0)

    def predict(self, motion) -> None:
        pass

    def update(self, scan) -> None:
        pass

    def estimate(self) -> PoseEstimate:
        return PoseEstimate(self.pose, np.eye(3), True)
'''


def _check(kind: str, spec: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([EXE, kind, "check", spec], cwd=cwd, capture_output=True, text=True, timeout=300)


def test_the_former_guides_planner_is_told_to_declare_its_options(tmp_path: Path) -> None:
    (tmp_path / "detour.py").write_text(UNDECLARED)
    done = _check("planners", "detour:DetourPlanner", tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert lines and all(line.startswith("detour:DetourPlanner: ") for line in lines)
    assert any("declares no options" in line and "options_model" in line for line in lines)
    assert "the preset query of map2 failed: no path (no detour found)" in done.stdout  # one detour is not enough
    assert len(done.stderr.splitlines()) == 1 and "docs/howto/planner.md" in done.stderr
    assert "Traceback" not in done.stdout + done.stderr


def test_a_planner_through_walls_and_off_its_seed_gets_one_line_per_problem(tmp_path: Path) -> None:
    (tmp_path / "careless.py").write_text(CARELESS)
    done = _check("planners", "careless:Careless", tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    out = done.stdout
    for map_name in ("map1", "map2", "map3", "pillars"):
        assert f"of the path on {map_name} is not free for the collision checker" in out
        assert f"the path on {map_name} is" in out and "shorter than the shortest possible" in out
    assert "the same seed (7) gave two different paths" in out
    assert "a goal inside a wall" not in out  # the base class answers that one
    assert len(out.splitlines()) == 10  # ... and its model's defaults plan a different (random) path


def test_a_builtin_planner_passes(tmp_path: Path) -> None:
    done = _check("planners", "planners.min_turn:MinTurnPlanner", tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip() == "planners.min_turn:MinTurnPlanner: passes the planner checks"


def test_a_localiser_missing_declarations_and_reasons_is_told_each(tmp_path: Path) -> None:
    (tmp_path / "stubborn.py").write_text(HALF_LOCALISER)
    done = _check("localisers", "stubborn:Stubborn", tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    out = done.stdout
    assert "lacks 'converged_xy_cm'" in out and "lacks 'motion_inflation'" in out
    assert "missing: beam_mixture, clearance, max_range" in out
    assert "robot_options['lobe'] = 'no': say in a sentence why" in out
    assert "robot_options['motion'] is refused: every localiser takes the motion noise" in out
    assert "Traceback" not in out + done.stderr


def test_a_builtin_localiser_passes(tmp_path: Path) -> None:
    done = _check("localisers", "localisation.filterpy_variants:EkfLocaliser", tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "passes the localiser checks" in done.stdout


@pytest.mark.parametrize(("kind", "spec", "module", "needle"), [
    ("planners", "detour", None, "expected MODULE:CLASS"),
    ("planners", "no_such_module:Planner", None, "no module named 'no_such_module'"),
    ("planners", "broken:Thing", "raise RuntimeError('half written')\n",
     "importing broken raised RuntimeError: half written"),
    ("planners", "plain:Missing", "x = 1\n", "module plain has no 'Missing'"),
    ("planners", "plain:x", "x = 1\n", "x is not a planner class"),
    ("localisers", "plain:Point", "from toolkit.world import Pose as Point\n", "Point is not a localiser class"),
])
def test_a_bad_module_class_is_one_line_and_exit_2(kind: str, spec: str, module: str | None, needle: str,
                                                   tmp_path: Path) -> None:
    if module is not None:
        (tmp_path / f"{spec.split(':')[0]}.py").write_text(module)
    done = _check(kind, spec, tmp_path)
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == ""
    assert done.stderr.startswith("nxtnav: error: ") and len(done.stderr.splitlines()) == 1, done.stderr
    assert needle in done.stderr
