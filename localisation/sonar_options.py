"""Localiser options that describe the robot's sonar and motion model to a localiser, by registry name."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from localisation.base import LOCALISERS
from toolkit.world import NxtSonar, make_sonar

NXT_SONAR_SIGMA_CM = 3.0
"""Range standard deviation (cm) a localiser is told for the `nxt` sonar model: the sensor's +-3 cm,
which also absorbs the lobe and rounding the range model does not represent (1 cm made paper-pf
overconfident and wrong in half the map1 missions; 3 cm made them all succeed)."""


def lobe_options(localiser: str, sonar: str, sensor_noise: float = 1.0,
                 sonar_model: NxtSonar | None = None) -> dict[str, Any]:
    """The sonar model's lobe as constructor options of `localiser`, when it can model one.

    A localiser whose constructor takes ``beam_width_deg`` (and ``critical_incidence_deg``), such as
    the particle filters' range tables, gets the sonar model's values: for ``nxt`` (and a real NXT) a
    20-degree lobe with specular loss beyond 40 degrees of incidence, the rays that sample it
    (``beam_rays``) and its 255 cm range limit (``max_range_cm``), when the localiser takes them;
    nothing for the thin-ray ``ideal`` sonar or for localisers without the options. `sonar_model`
    (the ``nxt`` sonar's whole model, a fitted profile say) replaces the default one.
    """
    model = sonar_model if sonar == "nxt" and sonar_model is not None else make_sonar(
        sonar, **({"noise_sd": sensor_noise} if sonar == "ideal" else {}))
    width = float(getattr(model, "beam_width_deg", 0.0))
    if width <= 0.0:
        return {}
    lobe = {"beam_width_deg": width}
    if hasattr(model, "beam_rays"):
        lobe["beam_rays"] = int(model.beam_rays)
    if hasattr(model, "critical_incidence_deg"):
        lobe["critical_incidence_deg"] = float(model.critical_incidence_deg)
    if hasattr(model, "max_range_cm"):
        lobe["max_range_cm"] = float(model.max_range_cm)
    return accepted_model_options(localiser, lobe)


def accepted_model_options(localiser: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """The robot-model `options` that the localiser registered as `localiser` takes (its `model_options`)."""
    takes = LOCALISERS.get(localiser).model_options
    return {k: v for k, v in options.items() if k in takes}


def geometry_options(localiser: str, radius_cm: float) -> dict[str, Any]:
    """The robot's radius as options of `localiser`: ``clearance_cm`` (particles are kept that far
    from the walls) when it takes it."""
    return accepted_model_options(localiser, {"clearance_cm": float(radius_cm)})


def matched_localiser_options(localiser: str, *, sonar: str = "ideal", noise_model: str = "botsim",
                              motion_noise: float = 0.1, turn_noise: float = 0.005,
                              sensor_noise: float = 1.0, sonar_model: NxtSonar | None = None,
                              simulated: bool = False) -> dict[str, Any]:
    """Options that tell a localiser (by registry name) the robot's motion and sensor model.

    Only the options its constructor accepts are returned (``noise_model``, ``motion_noise``,
    ``turn_noise``, ``sensor_sigma_cm``, ``sonar_model``, the lobe of `lobe_options`): the ideal
    sonar's noise, or for the ``nxt`` sonar (and a real NXT) the sensor's whole model (`sonar_model`,
    the fitted `NxtSonar` by default: localisers that take it use its beam mixture) and, for those
    that do not, `NXT_SONAR_SIGMA_CM` and the sensor's lobe. With `simulated` the readings come from a
    simulator or the virtual brick, which draw each reading independently: the model is
    `NxtSonar.simulated` (no reading correlation), where real readings keep the fitted one. Without the
    lobe, paper-pf settles on headings 5-10 degrees off near the slanted walls of map2 with the
    ``nxt`` sonar while reporting a narrow belief (23 of 100 Table I missions on map2 with absolute
    noise ended 3-5 cm from the target; with it, none of the 600 Table I missions failed).
    """
    known: dict[str, Any] = {"noise_model": noise_model, "motion_noise": motion_noise, "turn_noise": turn_noise}
    if sonar == "ideal" and sensor_noise > 0:
        known["sensor_sigma_cm"] = sensor_noise
    elif sonar == "nxt":
        known["sensor_sigma_cm"] = NXT_SONAR_SIGMA_CM
        model = sonar_model if sonar_model is not None else NxtSonar()
        known["sonar_model"] = model.simulated() if simulated else model
    return {**accepted_model_options(localiser, known), **lobe_options(localiser, sonar, sensor_noise, sonar_model)}
