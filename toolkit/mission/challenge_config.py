"""The challenge mission's settings (`toolkit.mission.challenge`, whose module docstring says what each
step does): ``--set challenge.KEY=VALUE`` on the commands that run it."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..world.typed import Typed, with_unit

__all__ = ["ChallengeConfig", "ChallengeFix", "ChallengeRecovery", "ChallengeSonar", "HeadingFrom", "Oracle",
           "PositionFrom", "Readings"]

PositionFrom = Literal["prediction", "localiser"]
"""Where the belief's position comes from after a waypoint's sweep (`ChallengeFix.position_from`)."""

HeadingFrom = Literal["fused", "sweep"]
"""Where the belief's heading comes from after a waypoint's sweep (`ChallengeFix.heading_from`)."""

Readings = Literal["real", "simulated"]
"""Whose sweeps the challenge's robot reads (`ChallengeSonar.readings`)."""

Oracle = Literal["none", "heading", "pose"]
"""What the truth gives the belief after each waypoint's sweep, for measuring ceilings (`ChallengeFix.oracle`)."""


class ChallengeFix(Typed):
    """What a waypoint's sweep does to the belief (module docstring, step 3): ``--set challenge.fix.KEY=V``."""

    position_from: PositionFrom = Field(
        default="prediction", description="Where the belief's position comes from after a waypoint's sweep.")
    gate_sigmas: float = Field(default=3.0, gt=0, description=(
        "A sweep's fix is trusted when it lies within this many standard deviations of the prediction."))
    correction_cm: float = Field(default=3.0, ge=0, json_schema_extra=with_unit("cm"),
                                 description="Corrections go on while the estimate is farther from the waypoint.")
    max_corrections: int = Field(default=0, ge=0, description="Corrections (and sweeps) at most per waypoint.")
    heading_from: HeadingFrom = Field(default="fused", description=(
        "fused: the most likely heading given the sweep's fit at each heading and the predicted heading "
        "with its spread; sweep: the fitted heading alone."))
    fit_temperature_cm: float = Field(default=0.1, gt=0, json_schema_extra=with_unit("cm"), description=(
        "How much worse (median misfit) a heading's fit may be for its likelihood to fall by e (fused)."))
    oracle: Oracle = Field(default="none", description=(
        "For measuring ceilings on simulated robots only: after each waypoint's sweep the belief takes the "
        "truth's heading (heading) or pose (pose); none: the robot's own fix."))


class ChallengeSonar(Typed):
    """How the sweep-set sonar answers (`toolkit.real_sonar.sweep_sonar`): ``--set challenge.sonar.KEY=V``."""

    radius_cm: float = Field(default=10.0, gt=0, json_schema_extra=with_unit("cm"), description=(
        "A real sweep answers within this distance of its waypoint; farther, the sonar refuses."))
    offset_correction: bool = Field(default=False, description=(
        "Move each real echo by the map's change between the waypoint and the robot's true pose "
        "(a hybrid of real and map readings, for study; off: the sweep as it was taken)."))
    readings: Readings = Field(default="real", description=(
        "real: the sweep set's sweeps, at its waypoints only; simulated: the sonar model's sweep at the "
        "robot's true pose (the same mission on simulated readings, to compare with the real ones)."))


class ChallengeRecovery(Typed):
    """How the mission gets out of a belief gone wrong (module docstring, steps 2 and 3):
    ``--set challenge.recovery.KEY=V``."""

    escape_cm: float = Field(default=5.0, ge=0, json_schema_extra=with_unit("cm"), description=(
        "A belief this close to being free plans from the nearest free point (its first leg the move out)."))
    start_slack_cm: float = Field(default=20.0, ge=0, json_schema_extra=with_unit("cm"), description=(
        "A start is given up for good when it would have put the robot farther than this outside the free "
        "space by the end of the first leg."))


class ChallengeConfig(Typed):
    """How the challenge mission runs (module docstring): ``--set challenge.KEY=VALUE`` on the commands that
    run it."""

    move_step_cm: float = Field(default=10.0, gt=0, json_schema_extra=with_unit("cm"),
                                description=("Longest move between two predictions (under BotSim's noise a leg's "
                                             "moves are shorter: the length that ends it surest)."))
    margin_cm: float = Field(default=8.0, ge=0, json_schema_extra=with_unit("cm"),
                             description="Clearance asked of a path beyond the robot radius.")
    plan_time_s: float = Field(default=0.5, gt=0, json_schema_extra=with_unit("s"),
                               description="Planning budget per leg.")
    prior_std_cm: float = Field(default=3.0, gt=0, json_schema_extra=with_unit("cm"),
                                description="Spread of the belief reset at the start, and of a sweep's fix.")
    prior_std_deg: float = Field(default=2.0, gt=0, json_schema_extra=with_unit("deg"),
                                 description="Heading spread of that belief.")
    reach_cm: float = Field(default=10.0, gt=0, json_schema_extra=with_unit("cm"),
                            description="A waypoint is reached within this distance.")
    heading_span_deg: float = Field(default=30.0, ge=0, json_schema_extra=with_unit("deg"),
                                    description="Headings tried around the predicted one at a waypoint.")
    start_retries: int = Field(default=1, ge=0, description=(
        "Other start hypotheses tried when the first leg fails; the first leg is planned free at each."))
    facing_sweep: bool = Field(default=True, description=(
        "After the fix at the start and at each waypoint, turn toward the next leg and sweep again; the "
        "two sweeps are fitted together (false: one sweep a stop)."))
    fix: ChallengeFix = ChallengeFix()
    sonar: ChallengeSonar = ChallengeSonar()
    recovery: ChallengeRecovery = ChallengeRecovery()
