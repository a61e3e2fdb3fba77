"""The ROS 2 message types of the export: the ROS 2 Jazzy type store of `rosbags` plus nav2's particle cloud.

``nav2_msgs/msg/Particle`` and ``nav2_msgs/msg/ParticleCloud`` are not in rosbags' stores; their
definitions (as nav2 defines them: a pose and a weight; a header and a list of particles) are
registered here, so that the bag carries them in its schema and any reader can decode them.
"""

from __future__ import annotations

from functools import cache
from typing import Any

__all__ = ["PARTICLE", "PARTICLE_CLOUD", "typestore"]

PARTICLE = "nav2_msgs/msg/Particle"
PARTICLE_CLOUD = "nav2_msgs/msg/ParticleCloud"

_PARTICLE_MSG = """geometry_msgs/Pose pose
float64 weight
"""
_PARTICLE_CLOUD_MSG = """std_msgs/Header header
nav2_msgs/Particle[] particles
"""


@cache
def typestore() -> Any:
    """rosbags' ROS 2 Jazzy type store with nav2's ``Particle`` and ``ParticleCloud`` registered."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    types = {**get_types_from_msg(_PARTICLE_MSG, PARTICLE), **get_types_from_msg(_PARTICLE_CLOUD_MSG, PARTICLE_CLOUD)}
    store.register(types)
    return store
