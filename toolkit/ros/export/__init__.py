"""A recording as a ROS 2 bag: rosbag2 folder, MCAP storage, CDR messages (`export_mcap`).

nav2's topic names and REP-105 frames, SI units, integer-nanosecond stamps; written through
`rosbags`, so no ROS installation is needed. ``docs/recording.md`` lists the topics, types, frames
and units.
"""

from __future__ import annotations

from .messages import FRAMES, ExportError
from .writer import ROSBAG2_VERSION, TOPICS, ExportSummary, export_mcap

__all__ = ["FRAMES", "ROSBAG2_VERSION", "TOPICS", "ExportError", "ExportSummary", "export_mcap"]
