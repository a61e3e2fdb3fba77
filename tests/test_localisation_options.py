"""One robot model, told to every localiser alike (`localisation.robot_options`), and the options model
of every localiser (`toolkit.world.Options`) against what its constructor does."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from localisation import LOCALISERS, Motion, Prior, make_localiser
from localisation.base import HeadingPrior, Localiser, PoseEstimate
from localisation.conformance import tracking_run
from localisation.laser_options import laser_localiser_options, laser_options_added, laser_options_for
from localisation.robot_options import THIN_RAY, localiser_options
from toolkit.world import (
    FACETS,
    ConfigError,
    LaserScanner,
    NxtSonar,
    Pose,
    RegistryError,
    RobotModel,
    Scan,
    configure,
    load_map,
)
from toolkit.world.params import robot_paths

MAP1 = load_map("map1")
MODELS = [RobotModel.build("ideal"), RobotModel.build("ideal", sensor_noise=2.5, noise_model="absolute",
                                                      motion_noise=0.7, turn_noise=0.02, radius_cm=6.0),
          RobotModel.build("nxt"), RobotModel.build(NxtSonar(noise_sd=4.0, beam_width_deg=20.0), readings="real"),
          RobotModel.build("nxt", radius_cm=10.0, noise_model="absolute")]


def _told(name: str, robot: RobotModel) -> dict[str, dict[str, Any]]:
    """Per facet, the canonical values the localiser's options carry (mapped back through its mapping)."""
    opts = localiser_options(name, robot)
    mapping = LOCALISERS.get(name).robot_options
    assert mapping is not None
    out = {}
    for facet, values in robot.facets().items():
        how = mapping[facet]
        if not isinstance(how, str):
            out[facet] = {canon: opts[own] for canon, own in zip(values, how, strict=True) if own is not None}
    return out


@pytest.mark.parametrize("robot", MODELS, ids=lambda r: r.describe())
def test_every_localiser_is_told_the_same_robot(robot: RobotModel) -> None:
    facets = robot.facets()
    for name in LOCALISERS.names():
        told = _told(name, robot)
        assert told["motion"] == facets["motion"]  # every localiser models motion
        assert told["sensor_sigma"] == facets["sensor_sigma"]  # ... and a range sigma
        for facet in ("lobe", "max_range", "beam_mixture", "clearance"):
            if facet in told:  # every value a localiser uses (grid casts no lobe rays)
                assert told[facet] == {k: v for k, v in facets[facet].items() if k in told[facet]}, (name, facet)
                assert len(told[facet]) == len(facets[facet]) or name == "grid", (name, facet)
    # the particle filters and amcl model everything, so their sigma, lobe and range limit agree value for value
    full = [n for n in LOCALISERS.names() if n not in ("ekf", "ukf", "grid")]
    assert len({repr(_told(n, robot)) for n in full}) == 1


def test_the_nxt_model_carries_its_own_numbers() -> None:
    robot = RobotModel.build(NxtSonar(beam_width_deg=20.0, critical_incidence_deg=50.0, beam_rays=9),
                             radius_cm=7.0)
    amcl, pf = localiser_options("amcl", robot), localiser_options("paper-pf", robot)
    assert amcl["sensor.sigma_hit"] == pf["sensor.sensor_sigma_cm"] == 3.0
    assert amcl["lobe.lobe_rays"] == pf["ranges.beam_rays"] == 9
    assert amcl["lobe.beam_width_deg"] == pf["ranges.beam_width_deg"] == 20.0
    assert amcl["sensor.laser_max_range"] == pf["ranges.max_range_cm"] == 255.0
    assert amcl["global_start.clearance_cm"] == pf["global_start.clearance_cm"] == 7.0
    assert amcl["sensor.sonar_model"] == pf["sensor.sonar_model"] == robot.sonar.simulated()
    assert localiser_options("paper-pf", robot.with_readings("real"))["sensor.sonar_model"] is robot.sonar
    thin = localiser_options("paper-pf", robot, leave_out=THIN_RAY)
    assert "ranges.beam_width_deg" not in thin and "sensor.sonar_model" not in thin


@pytest.mark.parametrize("name", LOCALISERS.names())
def test_every_facet_is_mapped_or_refused_with_a_reason(name: str) -> None:
    mapping = LOCALISERS.get(name).robot_options
    assert mapping is not None and set(mapping) == set(FACETS)
    model = LOCALISERS.get(name).options_model
    assert model is not None
    robot = robot_paths(model)
    for how in mapping.values():
        if isinstance(how, str):
            assert len(how) > 20  # a sentence, not a placeholder
        else:
            assert all(own in robot for own in how if own is not None)  # None: a value not used


def test_an_unmapped_facet_is_a_config_error(monkeypatch: pytest.MonkeyPatch) -> None:
    cls = LOCALISERS.get("ekf")
    monkeypatch.setattr(cls, "robot_options", {k: v for k, v in (cls.robot_options or {}).items() if k != "lobe"})
    with pytest.raises(ConfigError, match="ekf does not say how it takes the robot model's lobe"):
        localiser_options("ekf", RobotModel.build("nxt"))
    assert localiser_options("ekf", RobotModel.build("ideal"))  # the ideal sonar has no lobe to map


def _run(name: str, options: dict[str, Any]) -> np.ndarray:
    """A short tracking run on map1 from a known prior: the final estimate's mean and covariance (the run
    the plug-in check makes, `localisation.conformance.tracking_run`)."""
    return tracking_run(LOCALISERS.get(name), options)[0]


@pytest.mark.parametrize("name", LOCALISERS.names())
def test_options_as_a_model_or_as_overrides_are_one_localiser(name: str) -> None:
    cls = LOCALISERS.get(name)
    model = cls.options_model
    assert model is not None
    np.testing.assert_array_equal(_run(name, {}), tracking_run(cls, {}, model())[0])
    given = configure(model, None, {"converged_xy_cm": 2.5, "motion_inflation": 2.0})
    np.testing.assert_array_equal(tracking_run(cls, {}, given)[0],
                                  _run(name, {"convergence.converged_xy_cm": 2.5, "motion.motion_inflation": 2.0}))


@pytest.mark.parametrize("name", LOCALISERS.names())
def test_a_changed_option_reaches_the_constructor(name: str) -> None:
    model = LOCALISERS.get(name).options_model
    assert model is not None
    with pytest.raises(ConfigError, match=r"convergence\.converged_xy_cm: -1\.0 is out of its range \[0, inf\)"):
        configure(model, None, {"converged_xy_cm": -1.0})
    assert not np.array_equal(_run(name, {}), _run(name, {"motion.motion_inflation": 4.0}))


def test_replace_keeps_a_model_frozen() -> None:
    robot = RobotModel.build("nxt")
    with pytest.raises(AttributeError):
        robot.readings = "real"  # type: ignore[misc]
    assert replace(robot, readings="real").readings == "real"


# -- laser options, registered per localiser class ---------------------------------------------------------
class _DeadReckoning(Localiser):
    """A localiser of one's own that no laser options know (the belief follows the odometry alone)."""

    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        self._pose = Pose(0.0, 0.0, 0.0)

    def predict(self, motion: Motion) -> None:
        pass

    def update(self, scan: Scan) -> None:
        pass

    def estimate(self) -> PoseEstimate:
        return PoseEstimate(self._pose, np.eye(3), False, 0)


def test_every_bundled_localiser_has_its_familys_laser_options() -> None:
    laser = LaserScanner(noise_sd=2.0, max_range_cm=800.0)
    for name in LOCALISERS.names():
        options = laser_localiser_options(name, laser)
        assert options, name
        make_localiser(name, load_map("map1"), rng=0, **options)  # each option one its constructor takes
    assert laser_localiser_options("pf-residual", laser) == laser_localiser_options("paper-pf", laser)  # its base's


def test_a_localiser_without_laser_options_is_an_error_until_its_class_registers_them() -> None:
    laser = LaserScanner(max_range_cm=800.0)
    known = "known: amcl, ekf, grid, paper-pf, pf-multinomial, pf-residual, pf-stratified, pf-systematic, ukf$"
    with LOCALISERS.added({"dead-reckoning": _DeadReckoning}):
        with pytest.raises(ConfigError, match=r"localiser 'dead-reckoning' has no options for a laser .*" + known):
            laser_localiser_options("dead-reckoning", laser)  # before: {} without a word
        with laser_options_added(_DeadReckoning, lambda scanner: {"reach_cm": scanner.max_range_cm}):
            assert laser_localiser_options("dead-reckoning", laser) == {"reach_cm": 800.0}
            with pytest.raises(RegistryError, match="registered already"):
                laser_options_for(_DeadReckoning)(lambda scanner: {})
        with pytest.raises(ConfigError, match="has no options for a laser"):
            laser_localiser_options("dead-reckoning", laser)  # gone with its block
    with pytest.raises(RegistryError, match="unknown localiser 'dead-reckoning'"):
        laser_localiser_options("dead-reckoning", laser)
