"""How a mission is run: `MissionConfig`, a frozen tree of small groups.

Each group documents its own fields (lengths in cm, angles in degrees unless the name says otherwise,
times in s). `MissionConfig.with_options` sets fields from flat ``key=value`` options, as
``nxtnav paper --option`` passes them: a key is ``group.field`` (``fix.rule``) or a field name that
only one group has (``rule``). `MissionConfig.for_sonar` holds the tuning for the ``nxt`` sensor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from localisation.global_localisation import GlobalLocalisation
from localisation.scan import sweep_angles
from toolkit.world import CHECKER_BACKENDS, ConfigError, check_objective

__all__ = ["FIX_RULES", "TRACK_WINDOWS", "DriveConfig", "FinalConfig", "FixConfig", "LimitsConfig", "MissionConfig",
           "PlanningConfig", "SweepConfig"]

TRACK_WINDOWS: dict[str, tuple[float, ...]] = {"axes": (0.0, 90.0, 180.0, 270.0), "sides": (-90.0, 0.0, 90.0)}
"""Centres (deg, relative to the heading) of the windows a tracking sweep reads."""

FIX_RULES = ("always", "spread")
"""When a leg ends: re-localise ``always``, or only when the belief's ``spread`` could not drive on."""

TRACKING = ("continue", "prior")
"""How a tracking re-localisation starts (`FixConfig.tracking`)."""


def _check(group: str, name: str, value: Any, *, low: float = 0.0, strict: bool = False,
           integer: bool = False, high: float = math.inf) -> None:
    """ConfigError unless `value` is a finite number (an int when `integer`) in the range."""
    kind = int if integer else int | float
    ok = isinstance(value, kind) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (value > low if strict else value >= low) and value <= high
    if not ok:
        what = "an integer" if integer else "a number"
        bounds = f"> {low:g}" if strict else f">= {low:g}"
        if high < math.inf:
            bounds += f" and <= {high:g}"
        raise ConfigError(f"MissionConfig.{group}.{name} must be {what} {bounds}, got {value!r}")


def _check_choice(group: str, name: str, value: Any, choices: tuple[str, ...] | Mapping[str, Any]) -> None:
    if value not in choices:
        raise ConfigError(f"MissionConfig.{group}.{name} must be one of {', '.join(choices)}, got {value!r}")


@dataclass(frozen=True)
class PlanningConfig:
    """How paths are planned.

    Parameters
    ----------
    time_s : float
        Time budget of each planner query (s).
    safety_margin_cm : float
        Clearance added to the robot radius when planning; half of it, then the bare radius, when no
        path exists with it. Starts and targets closer to a wall join the path by a short straight leg.
    planner_options : mapping
        Keyword arguments of `make_planner` when the planner is given by name.
    objective : str or None
        What the planner minimises (``length``, ``turns``, ``robot-time``; None: its own default), when
        it is given by name; its ``objective`` in `planner_options` wins.
    """

    time_s: float = 1.0
    safety_margin_cm: float = 2.0
    planner_options: Mapping[str, Any] = field(default_factory=dict)
    objective: str | None = None

    def __post_init__(self) -> None:
        _check("planning", "time_s", self.time_s, strict=True)
        _check("planning", "safety_margin_cm", self.safety_margin_cm)
        if self.objective is not None:
            check_objective(self.objective)

    def planner_kwargs(self) -> dict[str, Any]:
        """`make_planner`'s keywords: `planner_options` with `objective` where it is set."""
        return {**({"objective": self.objective} if self.objective is not None else {}), **self.planner_options}


@dataclass(frozen=True)
class DriveConfig:
    """How a path is driven, leg by leg.

    Parameters
    ----------
    move_step_cm : float
        Longest single Move; the localiser predicts after each (the watchdog runs inside every Move).
    waypoint_tolerance_cm : float
        A waypoint is reached when the estimate is this close to it.
    max_legs : int
        Legs (each re-aimed from the estimate) toward one waypoint before re-planning.
    heading_tolerance_deg : float
        A leg ends where the straight drive would touch a wall were the heading off by this much
        either way (the error a sonar localiser makes most).
    min_leg_cm : float
        Legs are never cut shorter than this.
    leg_margin_cm : float
        Extra clearance of that check, for the estimate's position error (from estimates that have it).
    """

    move_step_cm: float = 10.0
    waypoint_tolerance_cm: float = 1.0
    max_legs: int = 12
    heading_tolerance_deg: float = 8.0
    min_leg_cm: float = 4.0
    leg_margin_cm: float = 0.0

    def __post_init__(self) -> None:
        _check("drive", "move_step_cm", self.move_step_cm, strict=True)
        _check("drive", "waypoint_tolerance_cm", self.waypoint_tolerance_cm, strict=True)
        _check("drive", "max_legs", self.max_legs, low=1, integer=True)
        for name in ("heading_tolerance_deg", "min_leg_cm", "leg_margin_cm"):
            _check("drive", name, getattr(self, name))


@dataclass(frozen=True)
class FixConfig:
    """When and how the robot re-localises on the way (`toolkit.mission.fix_policy.FixPolicy`).

    Parameters
    ----------
    rule : {"spread", "always"}
        Where a leg ends, ``always`` re-localises; ``spread`` only when the belief, predicted through the
        motion, could not drive on: its position spread across the next stretch plus its heading
        spread over the stretch's length, times `spread_sigmas`, must leave the robot disc clear of
        the walls. A missed waypoint is passed when the belief can drive on to the next one.
    relocalise_every_cm : float or None
        Legs longer than this end on the way to the waypoint (None: legs end at waypoints only).
    first_leg_cm : float or None
        The first leg after a global fix is at most this long, so a heading error of the fix shows
        as a sideways offset before it brings the robot to a wall (None: no short first leg).
    spread_sigmas : float
        Standard deviations of the belief the ``spread`` rule keeps clear of the walls.
    spread_min_heading_deg : float
        The ``spread`` rule takes the heading spread as at least this (a sonar belief can be
        narrower than its heading error).
    spread_drift : float
        ... and the position spread as at least this fraction of the distance driven since the last fix.
    tracking : {"continue", "prior"}
        A re-localisation starts from the localiser's predicted belief, or from a Gaussian prior around
        the last estimate; either falls back to the other, then to a global localisation.
    tracking_std_cm, tracking_std_deg : float
        Smallest standard deviations of that prior.
    check_turn_deg : float or None
        Once the turns toward waypoints since the heading was last checked add up to this many
        degrees, a leg whose way to its waypoint would meet a wall were its heading off by half of
        them (`toolkit.mission.driving.SLIP_SHARE`) is preceded by a heading check: one sweep of the
        front half, -90 to +90 degrees (`SweepConfig.heading_check_angles`), read against the believed heading
        (`localisation.heading_check`). A turn that slipped (wheels that skid turn the robot less
        than the tachometers say) is seen before the leg meets a wall, and the mission re-localises
        from the heading the sweep fits and plans again; a sweep that agrees leaves the belief as it
        was. None: no check (the default; the ``nxt`` sonar's tuning, `MissionConfig.for_sonar`,
        checks from 20 degrees).
    """

    rule: str = "spread"
    relocalise_every_cm: float | None = None
    first_leg_cm: float | None = 6.0
    spread_sigmas: float = 3.0
    spread_min_heading_deg: float = 1.0
    spread_drift: float = 0.05
    tracking: str = "continue"
    tracking_std_cm: float = 4.0
    tracking_std_deg: float = 8.0
    check_turn_deg: float | None = None

    def __post_init__(self) -> None:
        _check_choice("fix", "rule", self.rule, FIX_RULES)
        _check_choice("fix", "tracking", self.tracking, TRACKING)
        for name in ("relocalise_every_cm", "first_leg_cm", "check_turn_deg"):
            if getattr(self, name) is not None:
                _check("fix", name, getattr(self, name), strict=True)
        for name in ("spread_sigmas", "spread_min_heading_deg", "spread_drift"):
            _check("fix", name, getattr(self, name))
        _check("fix", "tracking_std_cm", self.tracking_std_cm, strict=True)
        _check("fix", "tracking_std_deg", self.tracking_std_deg, strict=True)


@dataclass(frozen=True)
class SweepConfig:
    """How the sonar sweeps of the re-localisations read (the global ones: `GlobalLocalisation`).

    Parameters
    ----------
    track_window_deg : float
        A tracking sweep reads windows of +-this around the centres of `track_windows` (180: the full turn).
    track_scan_step_deg : float
        Turret step inside those windows.
    track_windows : {"sides", "axes"}
        ``sides``: ahead and to the sides (-90, 0, 90 degrees); ``axes``: the paper's four (0, 90, 180, 270).
    track_align : bool
        Re-localise the paper's way (full sweep, align, full sweep); the window settings are then ignored.
    final_window_deg, final_scan_step_deg : float
        Window and step of the sweeps at the target (one window, ahead).
    localise_options : mapping
        Extra keyword arguments of every look (`localisation.procedure.look`), global or tracking.
    """

    track_window_deg: float = 15.0
    track_scan_step_deg: float = 2.0
    track_windows: str = "sides"
    track_align: bool = False
    final_window_deg: float = 15.0
    final_scan_step_deg: float = 1.0
    localise_options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("track_scan_step_deg", "final_scan_step_deg"):
            _check("sweeps", name, getattr(self, name), strict=True, high=90.0)
        for name in ("track_window_deg", "final_window_deg"):
            _check("sweeps", name, getattr(self, name), high=180.0)
        _check_choice("sweeps", "track_windows", self.track_windows, TRACK_WINDOWS)

    def heading_check_angles(self) -> NDArray[np.float64]:
        """The turret angles of a heading check: the front half, -90 to +90 degrees at the tracking step.
        It has less turret travel than the three tracking windows ahead and to the sides (360 degrees
        against 420) and sees the diagonals, where a turned heading shows most; it calls off a slipped
        turn where the windows leave it unsure (`tools/heading_check_rates.py`)."""
        return sweep_angles(self.track_scan_step_deg, 90.0, (0.0,))


@dataclass(frozen=True)
class FinalConfig:
    """The final correction at the target (`toolkit.mission.final_correction.FinalCorrectionPolicy`).

    Parameters
    ----------
    goal_tolerance_cm : float
        Corrections stop when the estimate is this close to the target.
    max_corrections : int
        Correction moves before giving up on the tolerance.
    success_radius_cm : float
        The mission succeeds when the estimate ends within this distance of the target.
    reverse_cm : float
        A correction up to this long toward a target behind the robot backs up instead of turning
        around (0: always turn toward the target).
    """

    goal_tolerance_cm: float = 0.5
    max_corrections: int = 6
    success_radius_cm: float = 3.0
    reverse_cm: float = 10.0

    def __post_init__(self) -> None:
        _check("final", "goal_tolerance_cm", self.goal_tolerance_cm, strict=True)
        _check("final", "max_corrections", self.max_corrections, integer=True)
        _check("final", "success_radius_cm", self.success_radius_cm, strict=True)
        _check("final", "reverse_cm", self.reverse_cm)


@dataclass(frozen=True)
class LimitsConfig:
    """When the mission gives up.

    Parameters
    ----------
    max_replans : int
        Re-plans (after watchdog stops or deviations).
    max_actions : int
        Turn and Move commands (a guard against endless loops).
    """

    max_replans: int = 12
    max_actions: int = 400

    def __post_init__(self) -> None:
        _check("limits", "max_replans", self.max_replans, integer=True)
        _check("limits", "max_actions", self.max_actions, low=1, integer=True)


_GROUPS = ("planning", "drive", "fix", "global_localisation", "sweeps", "final", "limits")


@dataclass(frozen=True)
class MissionConfig:
    """How a mission is run: one group per concern, each documenting its fields.

    Parameters
    ----------
    planning : PlanningConfig
    drive : DriveConfig
    fix : FixConfig
    global_localisation : GlobalLocalisation
        The global strategy, the mission's exploration policy (`localisation.global_localisation`); its
        ``place_cm`` and ``margin_cm`` are its own settings (their defaults equal `FixConfig.tracking_std_cm`
        and `PlanningConfig.safety_margin_cm`).
    sweeps : SweepConfig
    final : FinalConfig
    limits : LimitsConfig
    localiser_options : mapping
        Keyword arguments of `make_localiser` when the localiser is given by name.
    collision : {"index", "fcl"}
        Backend of the mission's collision checks (`toolkit.world.make_checker`); the simulator's
        watchdog and contacts use it too when the mission runs on it.
    """

    planning: PlanningConfig = field(default_factory=PlanningConfig)
    drive: DriveConfig = field(default_factory=DriveConfig)
    fix: FixConfig = field(default_factory=FixConfig)
    global_localisation: GlobalLocalisation = field(default_factory=GlobalLocalisation)
    sweeps: SweepConfig = field(default_factory=SweepConfig)
    final: FinalConfig = field(default_factory=FinalConfig)
    limits: LimitsConfig = field(default_factory=LimitsConfig)
    localiser_options: Mapping[str, Any] = field(default_factory=dict)
    collision: str = "index"

    def __post_init__(self) -> None:
        _check_choice("", "collision", self.collision, CHECKER_BACKENDS)

    def with_options(self, **options: Any) -> MissionConfig:
        """This configuration with fields set from flat options: ``group.field`` or a field name only one
        group has (``fix.rule`` or ``rule``), or ``localiser_options`` / ``collision``; an unknown key is
        a `ConfigError` naming it."""
        groups: dict[str, dict[str, Any]] = {}
        top: dict[str, Any] = {}
        for key, value in options.items():
            group, name = _locate(key)
            if group:
                groups.setdefault(group, {})[name] = value
            else:
                top[name] = value
        changed = {g: replace(getattr(self, g), **values) for g, values in groups.items()}
        return replace(self, **changed, **top)

    @classmethod
    def for_sonar(cls, sonar: str, **options: Any) -> MissionConfig:
        """The defaults for a sonar model, then `options` (as `with_options`). The ``nxt`` sensor (and a
        real NXT) gets a wider heading tolerance, a position margin for each leg and a wider least
        heading spread (its fixes err in heading near slanted walls while its belief stays narrow), the
        paper's four tracking windows (its wide lobe tracks less well with three), and a heading check
        after turns of 20 degrees or more (a real robot's turns slip)."""
        base: dict[str, Any] = {}
        if sonar == "nxt":
            base = {"drive.heading_tolerance_deg": 15.0, "drive.leg_margin_cm": 2.0,
                    "fix.spread_min_heading_deg": 4.0, "fix.check_turn_deg": 20.0, "sweeps.track_windows": "axes"}
        return cls().with_options(**base).with_options(**options)

    def to_dict(self) -> dict[str, Any]:
        """Every field, groups as nested dicts."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = ({g.name: _plain(getattr(v, g.name)) for g in fields(v)} if f.name in _GROUPS
                           else _plain(v))
        return out


def _plain(v: Any) -> Any:
    return dict(v) if isinstance(v, Mapping) else v


def _group_fields() -> dict[str, tuple[str, ...]]:
    """The field names of each group."""
    default = MissionConfig()
    return {g: tuple(f.name for f in fields(getattr(default, g))) for g in _GROUPS}


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
