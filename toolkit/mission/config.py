"""How a mission is run: `MissionConfig` (the turret angles of its sweeps: `localisation.scan.sweep_angles`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from localisation.global_localisation import GlobalLocalisation
from toolkit.world import CHECKER_BACKENDS, ConfigError

_GLOBAL = GlobalLocalisation()
"""The global strategy's defaults: a mission's global-localisation settings default to them."""

_WINDOW_CENTRES: dict[str, tuple[float, ...]] = {"axes": (0.0, 90.0, 180.0, 270.0), "sides": (-90.0, 0.0, 90.0)}


@dataclass(frozen=True)
class MissionConfig:
    """How a mission is run (all lengths in cm, angles in rad, times in s).

    Parameters
    ----------
    planning_time_s : float
        Time budget of each planner query.
    planner_options, localiser_options : mapping
        Keyword arguments for `make_planner` / `make_localiser` when the stack is given by name.
    localise_options : mapping
        Extra keyword arguments of every look (`localisation.procedure.look`), global or tracking.
    safety_margin_cm : float
        Extra clearance added to the robot radius when planning; the mission tries half the margin and
        then the bare radius when no path exists with it (narrow passages). Starts and targets closer
        to a wall than the margin are joined to the path by a short straight leg.
    move_step_cm : float
        Longest single Move command; a segment is driven as several Moves, the localiser predicting
        after each one (the watchdog runs inside every Move).
    relocalise_every_cm : float or None
        Re-localise (tracking) after driving this far along one segment, then re-aim at the waypoint;
        None re-localises at the waypoints only.
    first_leg_cm : float or None
        After a global fix, the first leg is at most this long before re-localising: a heading error
        of the fix shows as a sideways offset after a short drive, before it can bring the robot to
        a wall (None: no special first leg).
    waypoint_tolerance_cm : float
        A waypoint counts as reached when the estimate is this close to it (after re-localising there).
    max_legs : int
        Legs (re-aimed after each re-localisation) toward one waypoint before re-planning.
    heading_tolerance_deg, min_leg_cm : float
        A leg ends (and the robot re-localises) where the straight drive would touch a wall if the
        estimated heading were off by this much either way; legs are never shorter than
        `min_leg_cm`. Bounds the damage of a heading error, the error a sonar localiser makes most.
    leg_margin_cm : float
        Extra clearance (cm) for that check (position error of the estimate); used from estimates
        that have it.
    goal_tolerance_cm : float
        The final correction stops when the estimate is this close to the target.
    max_corrections : int
        Correction moves at the target before giving up on the tolerance (the mission still counts
        as a success when the estimate ends within `success_radius_cm`).
    success_radius_cm : float
        The estimate must end within this distance of the target for the mission to succeed.
    final_scans : int
        Scans fused at the target before each correction decision (more scans, tighter estimate).
    reverse_cm : float
        A correction move at the target up to this long whose direction is more than 90 degrees off
        the heading backs up instead of turning around (0: always turn toward the target).
    max_replans : int
        Re-plans (after watchdog stops or deviations) before the mission gives up.
    max_localisation_attempts : int
        Global localisation attempts before the robot is declared lost.
    max_explore_moves, explore_step_cm : int, float
        While a global belief stays ambiguous, up to this many moves of at most this length toward
        open space (chosen from the scan with room for the robot disc and the margin).
    exploration : {"modes", "scan"}
        How those moves are chosen (`localisation.exploration`): ``modes``, collision-free with half
        the margin from every candidate pose the localiser reports (from the scan when it reports
        none); ``scan``, the paper procedure's rule, toward the longest free run of the last sweep.
    explore_heading_tolerance_deg : float
        An exploration move planned from the localiser's modes must stay free when the modes'
        headings are off by this much either way. From a belief that knows the place (position
        spread and modes within `tracking_std_cm`) the move allows for three standard deviations
        of the belief's heading and position instead, when more (its mean stands for the modes
        when there are none).
    align_sweeps : int
        When a global belief that knows the place (position spread and modes within
        `tracking_std_cm`) but not its heading finds no exploration move that is safe for its
        heading spread, the robot settles the heading the paper's way on the spot instead (turning
        cannot touch a wall): turn toward the minimum reading, sweep the four windows around the
        axes again, update the same belief; up to this many times per global attempt. (Done before
        every exploration, it cost map2's `nxt` missions 20 s of robot time for no gain: a move
        tells more than a second look from the same place.)
    confirm_global : bool
        Confirm a global fix that rests on scans from one place with a second, independent one
        (guards against a localiser that collapses on one of several identical places); fixes further apart than
        `confirm_tolerance_cm` count as ambiguous.
    confirm_tolerance_cm : float
    confirm_all : bool
        Confirm every global fix, also those reached by exploring (a short exploration can leave the
        localiser collapsed on a twin place; on map3 without it about 1 mission in 100 ended in the
        wrong room). False confirms single-place fixes only.
    tracking : {"continue", "prior"}
        How a re-localisation starts: from the localiser's current (predicted) belief, or reset to a
        Gaussian prior around the last estimate (`tracking_std_cm`, `tracking_std_deg`). Either falls
        back to the other, then to a global localisation, when it does not converge.
    tracking_std_cm, tracking_std_deg : float
        Minimum standard deviations of the prior handed to a tracking re-localisation.
    max_actions : int
        Hard limit on Turn/Move commands (guards against endless loops).
    global_scan_step_deg : float
        Turret step (deg) of the sweeps of a global localisation (1: the paper's 360 readings).
    global_align : bool
        Global localisation the paper's way: sweep, turn toward the minimum reading, sweep again and
        keep the windows around the axes. False: one sweep, keeping the windows around the minimum
        reading's direction of that sweep (the same near-perpendicular readings, half the sweeps).
    track_window_deg : float
        Sweeps of a tracking re-localisation (from a belief, no alignment) read only windows of
        +-this many degrees around the robot's axes (`track_windows`; 15: the paper's window);
        180 sweeps the full turn.
    track_scan_step_deg : float
        Turret step (deg) inside those windows.
    track_windows : {"sides", "axes"}
        ``sides``: the three windows ahead and to the sides (-90, 0, 90); ``axes``: the paper's
        four, around 0, 90, 180 and 270 degrees. A tracking belief needs no look behind: over 30
        Table I trials per map, ``sides`` (45 readings and 420 degrees of turret travel at 2 degrees,
        2.8 s, against 62 and 600, 4.0 s) cut the median robot time by 2-14 s at the same
        accuracy.
    track_align : bool
        Re-localise along the way the paper's way (full sweep, align, full sweep) instead of one
        window sweep; the window settings are then ignored.
    final_window_deg, final_scan_step_deg : float
        The same for the re-localisations at the target (the final correction loop).
    fix_rule : {"habit", "spread"}
        When a leg ends (at a waypoint, after `relocalise_every_cm`, or where `heading_tolerance_deg`
        cuts it), ``habit`` re-localises every time; ``spread`` only when the belief as predicted
        through the motion could not drive on: the position spread across the next stretch plus
        the heading spread over its length, times `spread_sigmas`, must leave the robot disc clear
        of the walls along it. A waypoint the robot missed is skipped when the belief can drive on
        to the next one by the same rule.
    spread_sigmas : float
        Standard deviations of the belief the ``spread`` rule keeps clear of the walls.
    spread_min_heading_deg : float
        The ``spread`` rule never takes the heading spread as smaller than this (deg): a sonar
        localiser's belief can be narrower than its heading error.
    spread_drift : float
        Nor the position spread as smaller than this fraction of the distance driven since the
        last fix (a localiser whose belief does not grow with the motion is not trusted blindly).
    collision : {"index", "fcl"}
        Backend of the mission's collision checks (planning, legs, exploration; the simulator's
        watchdog and contacts too when the mission runs on it): `toolkit.world.make_checker`.
    """

    planning_time_s: float = 1.0
    planner_options: Mapping[str, Any] = field(default_factory=dict)
    localiser_options: Mapping[str, Any] = field(default_factory=dict)
    localise_options: Mapping[str, Any] = field(default_factory=dict)
    safety_margin_cm: float = 2.0
    move_step_cm: float = 10.0
    relocalise_every_cm: float | None = None
    first_leg_cm: float | None = 6.0
    waypoint_tolerance_cm: float = 1.0
    max_legs: int = 12
    heading_tolerance_deg: float = 8.0
    leg_margin_cm: float = 0.0
    min_leg_cm: float = 4.0
    goal_tolerance_cm: float = 0.5
    max_corrections: int = 6
    success_radius_cm: float = 3.0
    final_scans: int = 1
    reverse_cm: float = 10.0
    max_replans: int = 12
    max_localisation_attempts: int = _GLOBAL.attempts
    max_explore_moves: int = _GLOBAL.max_explore_moves
    explore_step_cm: float = _GLOBAL.explore_step_cm
    exploration: str = _GLOBAL.exploration
    explore_heading_tolerance_deg: float = _GLOBAL.explore_heading_tolerance_deg
    align_sweeps: int = _GLOBAL.align_sweeps
    tracking: str = "continue"
    confirm_global: bool = _GLOBAL.confirm
    confirm_tolerance_cm: float = _GLOBAL.confirm_tolerance_cm
    confirm_all: bool = _GLOBAL.confirm_all
    tracking_std_cm: float = 4.0
    tracking_std_deg: float = 8.0
    max_actions: int = 400
    global_scan_step_deg: float = _GLOBAL.scan_step_deg
    global_align: bool = _GLOBAL.align
    track_window_deg: float = 15.0
    track_scan_step_deg: float = 2.0
    track_windows: str = "sides"
    track_align: bool = False
    final_window_deg: float = 15.0
    final_scan_step_deg: float = 1.0
    fix_rule: str = "spread"
    spread_sigmas: float = 3.0
    spread_min_heading_deg: float = 1.0
    spread_drift: float = 0.05
    collision: str = "index"

    def __post_init__(self) -> None:
        positive = ("planning_time_s", "move_step_cm", "waypoint_tolerance_cm", "goal_tolerance_cm",
                    "success_radius_cm", "tracking_std_cm", "tracking_std_deg")
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ConfigError(f"MissionConfig.{name} must be a positive number, got {v!r}")
        if not (math.isfinite(self.safety_margin_cm) and self.safety_margin_cm >= 0):
            raise ConfigError(f"MissionConfig.safety_margin_cm must be >= 0, got {self.safety_margin_cm!r}")
        for name in ("global_scan_step_deg", "track_scan_step_deg", "final_scan_step_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 < v <= 90):
                raise ConfigError(f"MissionConfig.{name} must be in (0, 90] degrees, got {v!r}")
        for name in ("track_window_deg", "final_window_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 <= v <= 180):
                raise ConfigError(f"MissionConfig.{name} must be in [0, 180] degrees, got {v!r}")
        if self.track_windows not in _WINDOW_CENTRES:
            raise ConfigError(f"MissionConfig.track_windows must be one of {', '.join(_WINDOW_CENTRES)}, "
                             f"got {self.track_windows!r}")
        if self.fix_rule not in ("habit", "spread"):
            raise ConfigError(f"MissionConfig.fix_rule must be 'habit' or 'spread', got {self.fix_rule!r}")
        for name in ("spread_sigmas", "spread_min_heading_deg", "spread_drift"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"MissionConfig.{name} must be >= 0, got {v!r}")
        if self.collision not in CHECKER_BACKENDS:
            raise ConfigError(f"MissionConfig.collision must be one of {', '.join(CHECKER_BACKENDS)}, "
                              f"got {self.collision!r}")
        if self.tracking not in ("continue", "prior"):
            raise ConfigError(f"MissionConfig.tracking must be 'continue' or 'prior', got {self.tracking!r}")
        if self.relocalise_every_cm is not None and not self.relocalise_every_cm > 0:
            raise ConfigError("MissionConfig.relocalise_every_cm must be > 0 or None, "
                              f"got {self.relocalise_every_cm!r}")
        for name in ("max_corrections", "max_replans", "max_localisation_attempts", "max_actions", "final_scans",
                     "max_legs", "max_explore_moves", "align_sweeps"):
            v = getattr(self, name)
            lowest = 0 if name in ("max_corrections", "max_replans", "max_explore_moves", "align_sweeps") else 1
            if not (isinstance(v, int) and v >= lowest):
                raise ConfigError(f"MissionConfig.{name} must be a non-negative integer, got {v!r}")
        self.global_strategy()  # its own checks (exploration rule, ...)

    def global_strategy(self) -> GlobalLocalisation:
        """The global-localisation strategy of this mission, from its settings (the localiser benchmark
        runs `GlobalLocalisation`'s defaults, which are the default mission's)."""
        return GlobalLocalisation(
            scan_step_deg=self.global_scan_step_deg, align=self.global_align,
            attempts=self.max_localisation_attempts, confirm=self.confirm_global, confirm_all=self.confirm_all,
            confirm_tolerance_cm=self.confirm_tolerance_cm, max_explore_moves=self.max_explore_moves,
            explore_step_cm=self.explore_step_cm, explore_heading_tolerance_deg=self.explore_heading_tolerance_deg,
            align_sweeps=self.align_sweeps, place_cm=self.tracking_std_cm, margin_cm=self.safety_margin_cm,
            exploration=self.exploration)

    def to_dict(self) -> dict[str, Any]:
        return {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in self.__dict__.items()}

    @classmethod
    def for_sonar(cls, sonar: str, **overrides: Any) -> MissionConfig:
        """Defaults for a sonar model: the ``nxt`` sensor (and a real NXT) gets a wider heading
        tolerance and a position margin for each leg (its localisation errs by up to ~10 degrees in
        heading and ~2 cm in position near slanted walls while reporting a narrow belief), and keeps
        the paper's four tracking windows (the wide lobe's tracking drifts with three: a virtual-brick
        mission ended 2.4 cm off with ``sides``)."""
        base: dict[str, Any] = {}
        if sonar == "nxt":
            base = {"heading_tolerance_deg": 15.0, "leg_margin_cm": 2.0, "spread_min_heading_deg": 4.0,
                    "track_windows": "axes"}
        return cls(**{**base, **overrides})

