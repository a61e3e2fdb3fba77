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
from dataclasses import dataclass, field, replace
from typing import Any, Literal

from .errors import ConfigError
from .robot import RobotGeometry
from .robot_timing import RobotTiming
from .sonar import IdealSonar, NxtSonar, SonarModel, make_sonar

__all__ = ["FACETS", "NXT_SONAR_SIGMA_CM", "MotionNoise", "RobotModel"]

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


@dataclass(frozen=True)
class MotionNoise:
    """Motion noise: `model` is ``botsim`` (proportional) or ``absolute``; defaults are the paper's.

    Parameters
    ----------
    model : {"botsim", "absolute"}
        How `motion` and `turn` apply (see `toolkit.robots.sim`).
    motion : float
        botsim: fraction of each move (0.1); absolute: cm per move.
    turn : float
        botsim: fraction of each turn and rad of heading noise per move (0.005); absolute: rad.
    """

    model: NoiseModelName = "botsim"
    motion: float = 0.1
    turn: float = 0.005

    def __post_init__(self) -> None:
        if self.model not in ("botsim", "absolute"):
            raise ConfigError(f"noise model must be 'botsim' or 'absolute', got {self.model!r}")
        for k in ("motion", "turn"):
            v = getattr(self, k)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"{k} noise must be a non-negative number, got {v!r}")

    def to_dict(self) -> dict[str, object]:
        return {"model": self.model, "motion": self.motion, "turn": self.turn}


@dataclass(frozen=True)
class RobotModel:
    """The robot a run simulates or drives, as every part of the run is told it.

    Parameters
    ----------
    sonar : SonarModel
        The sensor: ``ideal`` (its `noise_sd`) or ``nxt`` (a whole `NxtSonar`, fitted or from a profile).
    motion : MotionNoise
    geometry : RobotGeometry
    timing : RobotTiming
        How long its drives, turns and sweeps take: the robot time of a path (`toolkit.world.path_cost`).
    readings : {"simulated", "real"}
        Where the readings come from: a simulator or the virtual brick draws each reading independently
        (the localisers get `NxtSonar.simulated`, no reading correlation); real readings keep the
        model's fitted correlation.
    """

    sonar: SonarModel = field(default_factory=IdealSonar)
    motion: MotionNoise = field(default_factory=MotionNoise)
    geometry: RobotGeometry = field(default_factory=RobotGeometry)
    timing: RobotTiming = field(default_factory=RobotTiming)
    readings: Literal["simulated", "real"] = "simulated"

    def __post_init__(self) -> None:
        if not isinstance(self.sonar, SonarModel):
            raise ConfigError(f"RobotModel.sonar must be a sonar model, got {self.sonar!r}")
        if self.readings not in ("simulated", "real"):
            raise ConfigError(f"RobotModel.readings must be 'simulated' or 'real', got {self.readings!r}")

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
