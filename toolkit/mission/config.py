"""How a mission is run: `MissionConfig`, a frozen tree of small groups.

Each field declares its type, default, range, unit and description once, in its ``Field`` (lengths in
cm, angles in degrees unless the name says otherwise, times in s); docs/parameters.md lists them,
generated. `MissionConfig.with_options` sets fields from flat ``key=value`` options, as the mission
settings of ``paper_pareto`` are written: a key is ``group.field`` (``fix.rule``) or a field name that
only one group has (``rule``). The command line sets them with ``--set mission.group.field=V``.
`MissionConfig.for_sonar` holds the tuning for the ``nxt`` sensor.

Every group is a typed model (`toolkit.world.typed.Typed`): frozen, unknown fields refused, each field's
type and range declared once; a bad value is one `ConfigError` line naming the group, the field and the
value.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from localisation.global_localisation import GlobalLocalisation
from localisation.scan import sweep_angles
from toolkit.world import ConfigError, check_objective
from toolkit.world.typed import Typed, build, group_fields, with_unit, with_values

__all__ = ["FIX_RULES", "TRACK_WINDOWS", "DriveConfig", "FinalConfig", "FixConfig", "LimitsConfig", "MissionConfig",
           "PlanningConfig", "SweepConfig"]

TRACK_WINDOWS: dict[str, tuple[float, ...]] = {"axes": (0.0, 90.0, 180.0, 270.0), "sides": (-90.0, 0.0, 90.0)}
"""Centres (deg, relative to the heading) of the windows a tracking sweep reads."""

FIX_RULES = ("always", "spread")
"""When a leg ends: re-localise ``always``, or only when the belief's ``spread`` could not drive on."""

TRACKING = ("continue", "prior")
"""How a tracking re-localisation starts (`FixConfig.tracking`)."""



class PlanningConfig(Typed):
    """How paths are planned."""

    time_s: float = Field(default=1.0, gt=0, json_schema_extra=with_unit("s"),
                          description="Time budget of each planner query.")
    safety_margin_cm: float = Field(default=2.0, ge=0, json_schema_extra=with_unit("cm"), description=(
        "Clearance added to the robot radius when planning; half of it, then the bare radius, when no path "
        "exists with it. Starts and targets closer to a wall join the path by a short straight leg."))
    planner_options: dict[str, Any] = Field(default_factory=dict, description=(
        "Keyword arguments of make_planner when the planner is given by name (nxtnav run fills it from "
        "--set PLANNER.KEY=VALUE)."))
    objective: str | None = Field(default=None, description=(
        "What the planner minimises (length, turns, robot-time; null: its own default), when it is given by "
        "name; an objective in planner_options wins."))

    @field_validator("objective")
    @classmethod
    def _known_objective(cls, value: str | None) -> str | None:
        if value is not None:
            check_objective(value)
        return value

    def planner_kwargs(self) -> dict[str, Any]:
        """`make_planner`'s keywords: `planner_options` with `objective` where it is set."""
        return {**({"objective": self.objective} if self.objective is not None else {}), **self.planner_options}



class DriveConfig(Typed):
    """How a path is driven, leg by leg."""

    move_step_cm: float = Field(default=10.0, gt=0, json_schema_extra=with_unit("cm"), description=(
        "Longest single Move; the localiser predicts after each (the watchdog runs inside every Move)."))
    waypoint_tolerance_cm: float = Field(default=1.0, gt=0, json_schema_extra=with_unit("cm"),
                                         description="A waypoint is reached when the estimate is this close to it.")
    max_legs: int = Field(default=12, ge=1,
                          description="Legs (each re-aimed from the estimate) toward one waypoint before re-planning.")
    heading_tolerance_deg: float = Field(default=8.0, ge=0, json_schema_extra=with_unit("deg"), description=(
        "A leg ends where the straight drive would touch a wall were the heading off by this much either way "
        "(the error a sonar localiser makes most)."))
    min_leg_cm: float = Field(default=4.0, ge=0, json_schema_extra=with_unit("cm"),
                              description="Legs are never cut shorter than this.")
    leg_margin_cm: float = Field(default=0.0, ge=0, json_schema_extra=with_unit("cm"), description=(
        "Extra clearance of the heading_tolerance_deg check, for the estimate's position error (from "
        "estimates that have it)."))



class FixConfig(Typed):
    """When and how the robot re-localises on the way (`toolkit.mission.fix_policy.FixPolicy`).

    A heading check (`check_turn_deg`) is one sweep of the front half, -90 to +90 degrees
    (`SweepConfig.heading_check_angles`), read against the believed heading (`localisation.heading_check`);
    the legs it guards are those whose way to the waypoint would meet a wall were the heading off by
    half the turns (`toolkit.mission.driving.SLIP_SHARE`). A turn that slipped (wheels that skid turn the
    robot less than the tachometers say) is seen before the leg meets a wall, and the mission
    re-localises from the heading the sweep fits and plans again; a sweep that agrees leaves the belief
    as it was. The ``nxt`` sonar's tuning (`MissionConfig.for_sonar`) checks from 20 degrees.
    """

    rule: Literal["always", "spread"] = Field(default="spread", description=(
        "Where a leg ends, always re-localises; spread only when the belief, predicted through the motion, "
        "could not drive on: its position spread across the next stretch plus its heading spread over the "
        "stretch's length, times spread_sigmas, must leave the robot disc clear of the walls. A missed "
        "waypoint is passed when the belief can drive on to the next one."))
    relocalise_every_cm: float | None = Field(default=None, gt=0, json_schema_extra=with_unit("cm"), description=(
        "Legs longer than this end on the way to the waypoint (null: legs end at waypoints only)."))
    first_leg_cm: float | None = Field(default=6.0, gt=0, json_schema_extra=with_unit("cm"), description=(
        "The first leg after a global fix is at most this long, so a heading error of the fix shows as a "
        "sideways offset before it brings the robot to a wall (null: no short first leg)."))
    spread_sigmas: float = Field(default=3.0, ge=0, description=(
        "Standard deviations of the belief the spread rule keeps clear of the walls."))
    spread_min_heading_deg: float = Field(default=1.0, ge=0, json_schema_extra=with_unit("deg"), description=(
        "The spread rule takes the heading spread as at least this (a sonar belief can be narrower than its "
        "heading error)."))
    spread_drift: float = Field(default=0.05, ge=0, json_schema_extra=with_unit("fraction"), description=(
        "The spread rule takes the position spread as at least this fraction of the distance driven since "
        "the last fix."))
    tracking: Literal["continue", "prior"] = Field(default="continue", description=(
        "A re-localisation starts from the localiser's predicted belief (continue), or from a Gaussian prior "
        "around the last estimate (prior); either falls back to the other, then to a global localisation."))
    tracking_std_cm: float = Field(default=4.0, gt=0, json_schema_extra=with_unit("cm"),
                                   description="Smallest position standard deviation of the tracking prior.")
    tracking_std_deg: float = Field(default=8.0, gt=0, json_schema_extra=with_unit("deg"),
                                    description="Smallest heading standard deviation of the tracking prior.")
    check_turn_deg: float | None = Field(default=None, gt=0, json_schema_extra=with_unit("deg"), description=(
        "Once the turns toward waypoints since the heading was last checked add up to this, a leg that would "
        "meet a wall were its heading off by half of them is preceded by a heading check, a sweep of the "
        "front half (null: no check)."))



class SweepConfig(Typed):
    """How the sonar sweeps of the re-localisations read (the global ones: `GlobalLocalisation`)."""

    track_window_deg: float = Field(default=15.0, ge=0, le=180, json_schema_extra=with_unit("deg"), description=(
        "A tracking sweep reads windows of +-this around the centres of track_windows (180: the full turn)."))
    track_scan_step_deg: float = Field(default=2.0, gt=0, le=90, json_schema_extra=with_unit("deg"),
                                       description="Turret step inside those windows.")
    track_windows: Literal["sides", "axes"] = Field(default="sides", description=(
        "sides: ahead and to the sides (-90, 0, 90 degrees); axes: the paper's four (0, 90, 180, 270)."))
    track_align: bool = Field(default=False, description=(
        "Re-localise the paper's way (full sweep, align, full sweep); the window settings are then ignored."))
    final_window_deg: float = Field(default=15.0, ge=0, le=180, json_schema_extra=with_unit("deg"),
                                    description="Window of the sweeps at the target (one window, ahead).")
    final_scan_step_deg: float = Field(default=1.0, gt=0, le=90, json_schema_extra=with_unit("deg"),
                                       description="Turret step of the sweeps at the target.")
    localise_options: dict[str, Any] = Field(default_factory=dict, description=(
        "Extra keyword arguments of every look (localisation.procedure.look), global or tracking."))


    def heading_check_angles(self) -> NDArray[np.float64]:
        """The turret angles of a heading check: the front half, -90 to +90 degrees at the tracking step.
        It has less turret travel than the three tracking windows ahead and to the sides (360 degrees
        against 420) and sees the diagonals, where a turned heading shows most; it calls off a slipped
        turn where the windows leave it unsure (`tools/heading_check_rates.py`)."""
        return sweep_angles(self.track_scan_step_deg, 90.0, (0.0,))


class FinalConfig(Typed):
    """The final correction at the target (`toolkit.mission.final_correction.FinalCorrectionPolicy`)."""

    goal_tolerance_cm: float = Field(default=0.5, gt=0, json_schema_extra=with_unit("cm"),
                                     description="Corrections stop when the estimate is this close to the target.")
    max_corrections: int = Field(default=6, ge=0, description="Correction moves before giving up on the tolerance.")
    success_radius_cm: float = Field(default=3.0, gt=0, json_schema_extra=with_unit("cm"), description=(
        "The mission succeeds when the estimate ends within this distance of the target."))
    reverse_cm: float = Field(default=10.0, ge=0, json_schema_extra=with_unit("cm"), description=(
        "A correction up to this long toward a target behind the robot backs up instead of turning around "
        "(0: always turn toward the target)."))



class LimitsConfig(Typed):
    """When the mission gives up."""

    max_replans: int = Field(default=12, ge=0, description="Re-plans (after watchdog stops or deviations).")
    max_actions: int = Field(default=400, ge=1,
                             description="Turn and Move commands (a guard against endless loops).")



class MissionConfig(Typed):
    """How a mission is run: one group per concern, each field declared (with its description) in its
    ``Field``. ``global_localisation`` is the global strategy, the mission's exploration policy
    (`localisation.global_localisation`); its ``place_cm`` and ``margin_cm`` are its own settings (their
    defaults equal `FixConfig.tracking_std_cm` and `PlanningConfig.safety_margin_cm`)."""

    planning: PlanningConfig = PlanningConfig()
    drive: DriveConfig = DriveConfig()
    fix: FixConfig = FixConfig()
    global_localisation: GlobalLocalisation = GlobalLocalisation()
    sweeps: SweepConfig = SweepConfig()
    final: FinalConfig = FinalConfig()
    limits: LimitsConfig = LimitsConfig()
    localiser_options: dict[str, Any] = Field(default_factory=dict, description=(
        "Keyword arguments of make_localiser when the localiser is given by name (nxtnav run adds "
        "--set LOCALISER.KEY=VALUE)."))
    collision: Literal["index", "fcl"] = Field(default="index", description=(
        "Backend of the mission's collision checks (toolkit.world.make_checker); the simulator's watchdog "
        "and contacts use it too when the mission runs on it."))


    def with_options(self, **options: Any) -> MissionConfig:
        """This configuration with fields set from flat options: ``group.field`` or a field name only one
        group has (``fix.rule`` or ``rule``), or ``localiser_options`` / ``collision``; an unknown key or a
        bad value is a `ConfigError` naming it."""
        dotted = {".".join(part for part in _locate(key) if part): value for key, value in options.items()}
        return with_values(self, dotted, "MissionConfig")

    @classmethod
    def from_dict(cls, data: Any, where: str = "MissionConfig") -> MissionConfig:
        """A configuration from its `to_dict` form (a missing field keeps its default); a bad one is one
        `ConfigError` line naming `where`, the field and the value."""
        return build(cls, data, where)

    @classmethod
    def for_sonar(cls, sonar: str, **options: Any) -> MissionConfig:
        """The defaults for a sonar model, then `options` (as `with_options`). The ``nxt`` sensor (and a
        real NXT) gets a wider heading tolerance (10 degrees), a 1 cm position margin for each leg and a
        wider least heading spread (2 degrees): its fixes err about twice as much as the ideal sonar's
        (in heading up to 3 degrees against 1.8, in position up to 1.9 cm against 1.0, over the fixes
        of 30 missions per sonar, docs/real-sonar.md), the paper's four tracking windows (its wide lobe
        tracks less well with three), and a heading check after turns of 20 degrees or more (a real
        robot's turns slip). The allowances were 15 degrees, 2 cm and 4 degrees until the localisers
        weighed readings with the sensor's lobe and the fitted beam mixture; with them the robot crept
        along walls in 6 cm legs, each ended by a sweep."""
        base: dict[str, Any] = {}
        if sonar == "nxt":
            base = {"drive.heading_tolerance_deg": 10.0, "drive.leg_margin_cm": 1.0,
                    "fix.spread_min_heading_deg": 2.0, "fix.check_turn_deg": 20.0, "sweeps.track_windows": "axes"}
        return cls().with_options(**base).with_options(**options)

    def with_localiser_defaults(self, defaults: dict[str, Any]) -> MissionConfig:
        """This configuration with `defaults` under its own `localiser_options` (its own win)."""
        return self.model_copy(update={"localiser_options": {**defaults, **self.localiser_options}})

    def to_dict(self) -> dict[str, Any]:
        """Every field, groups as nested dicts."""
        return self.model_dump()


_GROUPS = ("planning", "drive", "fix", "global_localisation", "sweeps", "final", "limits")


def _group_fields() -> dict[str, tuple[str, ...]]:
    """The field names of each group."""
    own = group_fields(MissionConfig) or {}
    return {g: tuple(group_fields(own[g]) or ()) for g in _GROUPS}


def _locate(key: str) -> tuple[str, str]:
    """(group, field) of a flat option key (group "" for `MissionConfig`'s own fields)."""
    by_group = _group_fields()
    group, dot, name = key.rpartition(".")
    if dot:
        if group in by_group and name in by_group[group]:
            return group, name
        raise ConfigError(f"unknown mission option {key!r}: {group!r} has no field {name!r}"
                          if group in by_group else
                          f"unknown mission option {key!r}: no group {group!r} (groups: {', '.join(_GROUPS)})")
    if key in ("localiser_options", "collision"):
        return "", key
    owners = [g for g, names in by_group.items() if key in names]
    if len(owners) == 1:
        return owners[0], key
    if owners:
        raise ConfigError(f"mission option {key!r} is ambiguous: say {' or '.join(f'{g}.{key}' for g in owners)}")
    raise ConfigError(f"unknown mission option {key!r} (give group.field; groups: {', '.join(_GROUPS)})")
