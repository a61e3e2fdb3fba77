"""Localisation from ultrasonic scans: the paper's particle filter and filterpy variants.

Importing the package registers every localiser (``paper-pf``, ``amcl``, the filterpy variants and
the ``grid`` reference) in
`LOCALISERS`; `localise` runs the global-localisation strategy (`GlobalLocalisation`) that missions and
the benchmark share, driving a robot; `look` is one look the paper's way (sweep, align, sweep, update).
"""

from .ambiguity import candidate_poses, describe_candidates
from .amcl import Amcl, DistanceField
from .base import LOCALISERS, HeadingPrior, Localiser, Motion, PoseEstimate, Prior, make_localiser
from .filterpy_variants import EkfLocaliser, UkfLocaliser, filterpy_resample
from .global_localisation import GlobalLocalisation, localise
from .grid_bayes import GridBayes
from .models import MotionModel, RangeLikelihood, RangeTable, exact_ranges, range_table
from .particle_filter import Mode, ParticleFilter, Snapshot
from .procedure import LocalisationResult, TraceStep, look
from .scan import ProcessedScan, ScanProcessing, min_reading, process_scan, raw_scan

__all__ = [
    "LOCALISERS",
    "Amcl",
    "DistanceField",
    "EkfLocaliser",
    "GlobalLocalisation",
    "GridBayes",
    "HeadingPrior",
    "LocalisationResult",
    "Localiser",
    "Mode",
    "Motion",
    "MotionModel",
    "ParticleFilter",
    "PoseEstimate",
    "Prior",
    "ProcessedScan",
    "RangeLikelihood",
    "RangeTable",
    "ScanProcessing",
    "Snapshot",
    "TraceStep",
    "UkfLocaliser",
    "candidate_poses",
    "describe_candidates",
    "exact_ranges",
    "filterpy_resample",
    "localise",
    "look",
    "make_localiser",
    "min_reading",
    "process_scan",
    "range_table",
    "raw_scan",
]
