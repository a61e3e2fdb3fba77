"""Does one sweep agree with the believed heading? A turn that slipped, seen before the leg it aims.

A differential-drive robot that turns on the spot can turn less than its tachometers say (a wheel
that skids). Its belief then points where the robot does not, and a tracking sweep started from that
narrow belief settles near it: the sonar's 40-degree lobe hides 15-35 degrees of heading error. The
check here holds the believed position and asks the sensor model which heading the sweep fits:

* the expected echo distances of the sweep are cast from the believed position at the believed
  heading turned by every offset in -`MAX_OFFSET_DEG` .. +`MAX_OFFSET_DEG` (`OFFSET_STEP_DEG` apart);
* each offset is scored by the log-likelihood of the readings: the NXT sonar's beam mixture
  (`localisation.beam_model.BeamLikelihood`, no-echo readings as evidence, each reading weighed for
  the sweep's step) when a model is given, else a Gaussian of the range error (`RangeLikelihood`);
* the heading is **off** when the best offset lies at least `MIN_OFFSET_DEG` from the belief and its
  log-likelihood beats the belief's by at least `MARGIN_NATS`.

Measured on simulated NXT sweeps of the three paper maps (91 readings: the front half, -90 to +90
degrees at 2 degrees, as a mission checks; ``python tools/heading_check_rates.py --poses 60 --seed
1``, 180 checks per row): a heading that is right is called off in none of the checks; one that is
10, 20 or 35 degrees off is called off in 99.4, 99.4 and 100 %, always within 8 degrees of the
truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from toolkit.world import Map, NxtSonar, Pose, Scan

from .beam_model import BeamLikelihood, scan_readings
from .models import RangeLikelihood, exact_ranges

__all__ = ["MARGIN_NATS", "MAX_OFFSET_DEG", "MIN_OFFSET_DEG", "OFFSET_STEP_DEG", "HeadingCheck", "check_heading"]

MAX_OFFSET_DEG = 45.0
"""Largest heading offset tried, either way (degrees)."""
OFFSET_STEP_DEG = 1.0
"""Spacing of the offsets tried (degrees)."""
MIN_OFFSET_DEG = 6.0
"""A best offset nearer the belief than this (degrees) is within what a tracking fix corrects."""
MARGIN_NATS = 8.0
"""How much better (log-likelihood, nats) the best offset must fit than the belief for the heading to be off."""
GAUSSIAN_SIGMA_CM = 3.0
"""Reading spread (cm) of the Gaussian used without a sonar model (the paper's sonar)."""


@dataclass(frozen=True)
class HeadingCheck:
    """What one sweep says of the believed heading.

    Attributes
    ----------
    offset_rad : float
        The heading offset (rad, added to the belief's heading) that fits the sweep best.
    margin_nats : float
        Its log-likelihood above the believed heading's (0 when the belief fits best).
    readings : int
        Readings the check used.
    """

    offset_rad: float
    margin_nats: float
    readings: int

    @property
    def off(self) -> bool:
        """Whether the sweep says the heading is off (module docstring)."""
        return abs(math.degrees(self.offset_rad)) >= MIN_OFFSET_DEG and self.margin_nats >= MARGIN_NATS

    @property
    def unsure(self) -> bool:
        """Whether the sweep neither calls the heading off nor fits it best: a heading at least
        `MIN_OFFSET_DEG` away fits as well or better, by less than `MARGIN_NATS`."""
        return not self.off and abs(math.degrees(self.offset_rad)) >= MIN_OFFSET_DEG

    def describe(self) -> str:
        return (f"best fit {math.degrees(self.offset_rad):+.0f} degrees from the belief, "
                f"{self.margin_nats:.1f} nats better, {self.readings} readings")


def check_heading(map: Map, pose: Pose, scan: Scan, sonar: NxtSonar | None = None) -> HeadingCheck:
    """Which heading at `pose`'s position the sweep `scan` fits best, against `pose`'s heading (module
    docstring); `sonar` is the NXT sensor's model (None: ideal readings with a Gaussian error)."""
    offsets = np.radians(np.arange(-MAX_OFFSET_DEG, MAX_OFFSET_DEG + 1e-9, OFFSET_STEP_DEG))
    model: BeamLikelihood | RangeLikelihood = (BeamLikelihood(sonar) if sonar is not None
                                               else RangeLikelihood(GAUSSIAN_SIGMA_CM))
    rel, meas, model = scan_readings(scan, model, map)
    if rel.size == 0:
        return HeadingCheck(0.0, 0.0, 0)
    poses = np.column_stack([np.full(offsets.size, pose.x), np.full(offsets.size, pose.y), pose.theta + offsets])
    expected = (exact_ranges(map, poses, rel) if sonar is None else
                exact_ranges(map, poses, rel, beam_width_deg=sonar.beam_width_deg, beam_rays=sonar.beam_rays,
                             critical_incidence_deg=sonar.critical_incidence_deg, max_range_cm=sonar.max_range_cm))
    ll = model.log_likelihood(expected, meas)
    best = int(np.argmax(ll))
    zero = int(np.argmin(np.abs(offsets)))
    return HeadingCheck(float(offsets[best]), float(ll[best] - ll[zero]), int(rel.size))
