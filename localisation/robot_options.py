"""The robot model as a localiser's options: one mapping per localiser class, checked, nothing dropped.

`localiser_options` turns a `toolkit.world.RobotModel` into constructor options of a registered localiser
through the class's ``robot_options`` (`localisation.base.RobotMapping`): every facet of the model
the localiser maps becomes its options (a value it does not use is mapped to None), every facet it does
not use has a stated reason, and a facet it does not mention is a `ConfigError`. Every localiser given the
same model is therefore told the same sigma, lobe, range limit, motion noise and size, whatever its own
options are called.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from toolkit.world import ConfigError, NxtSonar, RobotModel

from .base import LOCALISERS

__all__ = ["THIN_RAY", "localiser_options", "told_sonar_model"]

THIN_RAY = ("lobe", "beam_mixture")
"""Facets left out for ``--lobe off`` (localisers model the sonar as a thin ray with a Gaussian)."""


def localiser_options(name: str, robot: RobotModel, *, leave_out: tuple[str, ...] = ()) -> dict[str, Any]:
    """The constructor options that tell localiser `name` the robot `robot` (less the facets `leave_out`)."""
    cls = LOCALISERS.get(name)
    mapping = cls.robot_options
    if mapping is None:
        raise ConfigError(f"localiser {name} cannot be told a robot model (it declares no robot_options)")
    out: dict[str, Any] = {}
    for facet, values in robot.facets().items():
        if facet in leave_out:
            continue
        how = mapping.get(facet)
        if how is None:
            raise ConfigError(f"localiser {name} does not say how it takes the robot model's {facet} "
                              f"({', '.join(values)})")
        if isinstance(how, str):
            continue  # not used, for the stated reason
        if len(how) != len(values):
            raise ConfigError(f"localiser {name} maps the robot model's {facet} to {len(how)} options, "
                              f"not {len(values)}")
        out.update((own, value) for own, value in zip(how, values.values(), strict=True) if own is not None)
    return out


def told_sonar_model(options: Mapping[str, Any]) -> NxtSonar | None:
    """The NXT sonar model among a localiser's options (its ``sonar_model``, at any depth of the groups:
    ``sensor.sonar_model``), or None."""
    found = [v for k, v in options.items() if k.rpartition(".")[2] == "sonar_model" and isinstance(v, NxtSonar)]
    return found[-1] if found else None
