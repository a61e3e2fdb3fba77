"""`MissionConfig`: nested groups, flat options, the sonar's tuning, refusals that name the key."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from localisation.global_localisation import GlobalLocalisation
from toolkit.mission import MissionConfig
from toolkit.world import ConfigError


def test_flat_options_reach_their_group() -> None:
    cfg = MissionConfig().with_options(**{"fix.rule": "always", "track_windows": "axes", "exploration": "scan",
                                          "collision": "fcl", "planning.time_s": 0.5})
    assert cfg.fix.rule == "always" and cfg.sweeps.track_windows == "axes"
    assert cfg.global_localisation == GlobalLocalisation(exploration="scan")
    assert cfg.collision == "fcl" and cfg.planning.time_s == 0.5
    # nothing else moved
    assert cfg.fix.model_copy(update={"rule": "spread"}) == MissionConfig().fix
    assert cfg.drive == MissionConfig().drive and cfg.final == MissionConfig().final


def test_configs_are_frozen() -> None:
    cfg = MissionConfig()
    with pytest.raises(ValidationError, match="frozen"):
        cfg.fix.rule = "always"  # type: ignore[misc]


@pytest.mark.parametrize(("key", "words"), [("fix_rule", "unknown mission option 'fix_rule'"),
                                             ("fix.habit", "'fix' has no field 'habit'"),
                                             ("steering.rule", "no group 'steering'")])
def test_an_unknown_key_is_named(key: str, words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        MissionConfig().with_options(**{key: 1})


def test_a_bad_value_names_group_and_field() -> None:
    with pytest.raises(ConfigError, match=r"MissionConfig: fix\.rule: 'habit' is not one of always, spread"):
        MissionConfig().with_options(rule="habit")
    with pytest.raises(ConfigError, match=r"MissionConfig: final\.max_corrections: expected an integer, got 1\.5"):
        MissionConfig().with_options(max_corrections=1.5)


def test_the_nxt_tuning_lives_in_for_sonar_and_options_override_it() -> None:
    ideal, nxt = MissionConfig.for_sonar("ideal"), MissionConfig.for_sonar("nxt")
    assert ideal == MissionConfig()
    assert (nxt.drive.heading_tolerance_deg, nxt.drive.leg_margin_cm) == (10.0, 1.0)
    assert nxt.fix.spread_min_heading_deg == 2.0 and nxt.sweeps.track_windows == "axes"
    assert MissionConfig.for_sonar("nxt", track_windows="sides").sweeps.track_windows == "sides"


def test_to_dict_nests_the_groups() -> None:
    d = MissionConfig.for_sonar("nxt", localiser_options={"n": 5}).to_dict()
    assert d["fix"]["rule"] == "spread" and d["drive"]["heading_tolerance_deg"] == 10.0
    assert d["global_localisation"]["attempts"] == GlobalLocalisation().attempts
    assert d["localiser_options"] == {"n": 5} and d["collision"] == "index"
