"""Localisation from ultrasonic scans: the paper's particle filter and filterpy variants."""

from .base import LOCALISERS, Localiser, Motion, PoseEstimate, Prior, make_localiser

__all__ = ["LOCALISERS", "Localiser", "Motion", "PoseEstimate", "Prior", "make_localiser"]
