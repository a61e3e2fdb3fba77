"""The robot-model options each localiser declares (`Localiser.model_options`) are options its constructor
really takes, and `matched_localiser_options` hands a localiser exactly those."""

from __future__ import annotations

import pytest

from localisation import LOCALISERS, make_localiser
from localisation.base import MODEL_OPTIONS
from localisation.sonar_options import NXT_SONAR_SIGMA_CM, matched_localiser_options
from toolkit.world import NxtSonar, load_map

# a value of each model option that every localiser taking it accepts
_VALUES = {"noise_model": "absolute", "motion_noise": 0.2, "turn_noise": 0.01, "sensor_sigma_cm": 2.0,
           "beam_width_deg": 20.0, "beam_rays": 9, "critical_incidence_deg": 40.0, "max_range_cm": 255.0,
           "clearance_cm": 6.0, "sonar_model": NxtSonar()}


def test_the_values_cover_every_model_option() -> None:
    assert set(_VALUES) == MODEL_OPTIONS


@pytest.mark.parametrize("name", LOCALISERS.names())
def test_declared_model_options_are_constructor_options(name: str) -> None:
    cls = LOCALISERS.get(name)
    assert cls.model_options <= MODEL_OPTIONS
    options = {k: _VALUES[k] for k in cls.model_options}
    loc = make_localiser(name, load_map("map1"), rng=0, **options)
    assert loc.name == name


@pytest.mark.parametrize("name", LOCALISERS.names())
def test_matched_options_are_the_declared_ones(name: str) -> None:
    nxt = matched_localiser_options(name, sonar="nxt", noise_model="absolute")
    assert set(nxt) <= LOCALISERS.get(name).model_options
    if "sensor_sigma_cm" in LOCALISERS.get(name).model_options:
        assert nxt["sensor_sigma_cm"] == NXT_SONAR_SIGMA_CM
    if "beam_width_deg" in LOCALISERS.get(name).model_options:
        assert nxt["beam_width_deg"] == NxtSonar().beam_width_deg
        assert "beam_width_deg" not in matched_localiser_options(name, sonar="ideal")
    if "sonar_model" in LOCALISERS.get(name).model_options:
        assert nxt["sonar_model"] == NxtSonar()  # the nxt sonar's whole model (the fitted default)
        profile = NxtSonar(noise_sd=4.0)
        assert matched_localiser_options(name, sonar="nxt", sonar_model=profile)["sonar_model"] is profile
        assert "sonar_model" not in matched_localiser_options(name, sonar="ideal")
