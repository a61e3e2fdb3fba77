"""One robot model per run: what the simulator, the virtual brick and every localiser are told.

A comparison of localisers is fair only when each is told the same robot: the same motion noise, the
same sonar (its sigma, lobe, range limit and, for the NXT, its whole beam mixture) and the same size.
`RobotModel` is that description, frozen, built once per run (from the command line, a sonar profile
or a recording) and handed to the simulator, the brick, the localisers, the benchmarks and the mission.

A localiser sees the model through its *facets* (`RobotModel.facets`): named groups of canonical
values. Each localiser class maps every facet to its own options in one place (its ``robot_options``
attribute, `localisation.robot_options`), or says why it does not use one; a facet it does not
mention is a `ConfigError`, never silently dropped.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Annotated, Any, Literal

from pydantic import Field, PlainValidator, WithJsonSchema

from .errors import ConfigError
from .robot import RobotGeometry
from .robot_timing import RobotTiming
from .sonar import SONAR_MODELS, IdealSonar, NxtSonar, SonarModel, make_sonar
from .typed import Real, build, typed_dataclass, with_sets

__all__ = ["FACETS", "NXT_SONAR_SIGMA_CM", "MotionNoise", "RobotModel", "with_robot_sets"]

NoiseModelName = Literal["botsim", "absolute"]

NXT_SONAR_SIGMA_CM = 3.0
"""Range standard deviation (cm) a localiser without the beam mixture is told for the `nxt` sonar: the
sensor's +-3 cm, which also absorbs the lobe and rounding the range model does not represent (1 cm made
paper-pf overconfident and wrong in half the map1 missions; 3 cm made them all succeed)."""

IDEAL_SIGMA_FLOOR_CM = 1.0
"""Sigma a localiser is told for a noiseless ``ideal`` sonar (a zero sigma would make every likelihood a
delta): the paper's 1 cm."""

FACETS = ("motion", "sensor_sigma", "lobe", "max_range", "beam_mixture", "clearance")
"""The robot model's facets, in order: motion noise (``noise_model``, ``motion_noise``, ``turn_noise``),
the range sigma (``sensor_sigma_cm``), the sonar lobe (``beam_width_deg``, ``critical_incidence_deg``,
``beam_rays``), the range limit (``max_range_cm``), the NXT's beam mixture (``sonar_model``) and the
robot's radius (``clearance_cm``). A sonar without a lobe, a range limit or a mixture has no such facet."""


@typed_dataclass()
class MotionNoise:
    """Motion noise: `model` is ``botsim`` (proportional) or ``absolute``; defaults are the paper's (how
    `motion` and `turn` apply: `toolkit.robots.sim`)."""

    model: NoiseModelName = Field(default="botsim", description="How motion and turn apply: botsim (proportional) or "
                                                        "absolute.")
    motion: Real = Field(default=0.1, ge=0, json_schema_extra={"unit": "fraction (botsim) or cm (absolute)"},
                         description="botsim: fraction of each move (0.1); absolute: cm per move.")
    turn: Real = Field(default=0.005, ge=0, json_schema_extra={"unit": "fraction (botsim) or rad (absolute)"},
                       description=("botsim: fraction of each turn and rad of heading noise per move (0.005); "
                                    "absolute: rad."))

    def to_dict(self) -> dict[str, object]:
        return {"model": self.model, "motion": self.motion, "turn": self.turn}

    def move_cm(self, distance_cm: float, longest_cm: float) -> float:
        """The length (cm, at most `longest_cm`, at least the watchdog's 1 cm) of the moves a drive of
        `distance_cm` is made of, that leaves its end the least uncertain under this noise.

        Each move turns the heading by `turn` (rad, standard deviation) and misses its length by `motion`:
        in proportion to it (``botsim``) or by that many cm whatever it is (``absolute``). Moves of s cm
        leave the end of a drive of D cm off by variance motion^2 s D (botsim) or motion^2 D / s
        (absolute) along it, and turn^2 D^3 / (3 s) across it: under BotSim's noise the best move is
        D turn / (motion sqrt 3), about 4 cm for a 150 cm leg; under absolute noise the longest.

        >>> round(MotionNoise("botsim", 0.1, 0.005).move_cm(150.0, 10.0), 2)
        4.33
        >>> MotionNoise("absolute", 0.1, 0.005).move_cm(150.0, 10.0)
        10.0
        """
        if self.model != "botsim" or self.motion <= 0:
            return longest_cm
        return float(min(longest_cm, max(1.0, distance_cm * self.turn / (self.motion * math.sqrt(3.0)))))


def _as_sonar(value: Any) -> SonarModel:
    """A sonar model as given, or built from its ``to_dict`` form (``name`` and parameters) by its registry."""
    if isinstance(value, SonarModel):
        return value
    if not (isinstance(value, Mapping) and isinstance(value.get("name"), str)):
        raise ValueError(f"must be a sonar model or a mapping with its name, got {value!r}")
    kind = SONAR_MODELS.get(value["name"])
    return build(kind, {k: v for k, v in value.items() if k != "name"})


SonarField = Annotated[SonarModel, PlainValidator(_as_sonar), WithJsonSchema(
    {"type": "object", "description": "A sonar model: its name (ideal, nxt, laser, ...) and its parameters.",
     "properties": {"name": {"type": "string"}}, "required": ["name"]})]


@typed_dataclass()
class RobotModel:
    """The robot a run simulates or drives, as every part of the run is told it.

    ``readings`` says where the readings come from: a simulator or the virtual brick draws each reading
    independently (the localisers get `NxtSonar.simulated`, no reading correlation); real readings keep
    the model's fitted correlation. ``timing`` is how long its drives, turns and sweeps take: the robot
    time of a path (`toolkit.world.path_cost`).
    """

    sonar: SonarField = Field(default_factory=IdealSonar, description=(
        "The sensor: ideal (its noise_sd) or nxt (a whole NxtSonar, fitted or from a profile)."))
    motion: MotionNoise = Field(default_factory=MotionNoise, description="Motion noise.")
    geometry: RobotGeometry = Field(default_factory=RobotGeometry, description="Size and build.")
    timing: RobotTiming = Field(default_factory=RobotTiming, description="Robot time of each action.")
    readings: Literal["simulated", "real"] = Field(default="simulated", description=(
        "simulated: each reading drawn independently; real: readings keep the model's fitted correlation."))

    @classmethod
    def build(cls, sonar: str | SonarModel = "ideal", *, sensor_noise: float = 1.0, noise_model: str = "botsim",
              motion_noise: float = 0.1, turn_noise: float = 0.005, radius_cm: float | None = None,
              readings: Literal["simulated", "real"] = "simulated") -> RobotModel:
        """The model from command-line values: `sensor_noise` is the ``ideal`` sonar's noise (cm); the
        ``nxt`` sonar's noise is part of its model (pass a fitted `NxtSonar` as `sonar`)."""
        if isinstance(sonar, str):
            sonar = make_sonar(sonar, noise_sd=sensor_noise) if sonar == "ideal" else make_sonar(sonar)
        geometry = RobotGeometry() if radius_cm is None else RobotGeometry(radius_cm=float(radius_cm))
        return cls(sonar, MotionNoise(noise_model, motion_noise, turn_noise), geometry,  # type: ignore[arg-type]
                   readings=readings)

    def with_readings(self, readings: Literal["simulated", "real"]) -> RobotModel:
        return replace(self, readings=readings)

    @property
    def sonar_name(self) -> str:
        return self.sonar.name

    @property
    def sensor_sigma_cm(self) -> float:
        """Range sigma for localisers with a Gaussian range model (module constants explain the values)."""
        if isinstance(self.sonar, NxtSonar):
            return NXT_SONAR_SIGMA_CM
        noise = float(getattr(self.sonar, "noise_sd", 0.0))
        return noise if noise > 0 else IDEAL_SIGMA_FLOOR_CM

    @property
    def beam_mixture(self) -> NxtSonar | None:
        """The NXT's beam mixture as a localiser should weigh readings (None for other sonars)."""
        if not isinstance(self.sonar, NxtSonar):
            return None
        return self.sonar.simulated() if self.readings == "simulated" else self.sonar

    def facets(self) -> dict[str, dict[str, Any]]:
        """The model's facets (`FACETS`) present for this sonar, each as its canonical options."""
        m = self.motion
        out: dict[str, dict[str, Any]] = {
            "motion": {"noise_model": m.model, "motion_noise": float(m.motion), "turn_noise": float(m.turn)},
            "sensor_sigma": {"sensor_sigma_cm": self.sensor_sigma_cm},
        }
        sonar: Any = self.sonar  # a lobe and a range limit are attributes of the sonars that have them
        width = float(getattr(sonar, "beam_width_deg", 0.0))
        if width > 0:
            out["lobe"] = {"beam_width_deg": width, "critical_incidence_deg": float(sonar.critical_incidence_deg),
                           "beam_rays": int(sonar.beam_rays)}
        limit = getattr(sonar, "max_range_cm", None)
        if limit is not None and math.isfinite(limit):
            out["max_range"] = {"max_range_cm": float(limit)}
        mixture = self.beam_mixture
        if mixture is not None:
            out["beam_mixture"] = {"sonar_model": mixture}
        out["clearance"] = {"clearance_cm": float(self.geometry.radius_cm)}
        return out

    def describe(self) -> str:
        """One line for comparison tables: every value a localiser is told."""
        f = self.facets()
        parts = [f"sonar {self.sonar_name}", f"sigma {self.sensor_sigma_cm:g} cm"]
        if "lobe" in f:
            lobe = f["lobe"]
            parts.append(f"lobe {lobe['beam_width_deg']:g} deg ({lobe['beam_rays']} rays, specular beyond "
                         f"{lobe['critical_incidence_deg']:g} deg)")
        if "max_range" in f:
            parts.append(f"range limit {f['max_range']['max_range_cm']:g} cm")
        if "beam_mixture" in f:
            parts.append(f"beam mixture ({self.readings} readings)")
        m = self.motion
        parts.append(f"motion {m.model} {m.motion:g}/{m.turn:g}")
        parts.append(f"radius {self.geometry.radius_cm:g} cm")
        return ", ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {"sonar": self.sonar.to_dict(), "motion": self.motion.to_dict(), "geometry": self.geometry.to_dict(),
                "timing": self.timing.to_dict(), "readings": self.readings}


def with_robot_sets(model: RobotModel, sets: Mapping[str, str], where: str = "--set") -> RobotModel:
    """`model` with the settings `sets` (``robot.GROUP.FIELD`` and ``sonar.FIELD`` keys, values as typed,
    read as YAML), validated again; a bad key or value is one `ConfigError` line naming the key as given.

    >>> with_robot_sets(RobotModel(), {"robot.timing.drive_speed_cm_s": "20", "sonar.noise_sd": "2"}).timing
    RobotTiming(drive_speed_cm_s=20.0, turn_rate_deg_s=90.0, reading_s=0.023, turret_rate_deg_s=240.0, stop_turn_s=0.0)
    """
    own: dict[str, dict[str, str]] = {"robot": {}, "sonar": {}}
    for key, text in sets.items():
        section, _, rest = key.partition(".")
        if section not in own or not rest:
            raise ConfigError(f"{where}: {key!r} is no robot setting (robot.GROUP.FIELD or sonar.FIELD)")
        own[section][rest] = text
    if own["sonar"]:
        model = replace(model, sonar=with_sets(model.sonar, own["sonar"], where, section="sonar"))
    return with_sets(model, own["robot"], where, section="robot") if own["robot"] else model
