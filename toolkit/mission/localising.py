"""`Fixes`: the looks a mission takes, global and on the way, with their fallbacks."""

from __future__ import annotations

from typing import Any

from localisation.ambiguity import candidate_poses, describe_candidates
from localisation.base import PoseEstimate, Prior
from localisation.heading_check import HeadingCheck, check_heading
from localisation.procedure import LocaliseProcedure
from localisation.robot_options import told_sonar_model
from localisation.scan import sweep_fault

from .checkers import Checkers
from .context import MissionContext
from .fix_policy import FixPolicy
from .report import Action, Outcome
from .states import MissionEnded


class Fixes:
    """Localises the robot of `mission` with `procedure` (one look), as `policy` says."""

    def __init__(self, mission: MissionContext, policy: FixPolicy, checkers: Checkers,
                 procedure: LocaliseProcedure, rng: Any) -> None:
        self.mission = mission
        self.policy = policy
        self.checkers = checkers
        self.procedure = procedure
        self.rng = rng

    def look_options(self) -> dict[str, Any]:
        """Keyword arguments of every look, global or tracking: the config's, and `on_sweep_fault`."""
        options = dict(self.mission.cfg.sweeps.localise_options)
        if self.mission.on_sweep_fault is not None:
            options["on_sweep_fault"] = self.mission.on_sweep_fault
        return options

    def _look(self, prior: Prior | None, kind: str, **extra: Any) -> PoseEstimate:
        kwargs: dict[str, Any] = {"prior": prior, "rng": self.rng, **self.policy.sweep(kind), **self.look_options(),
                                  **extra}
        return self.procedure(self.mission.robot, self.mission.localiser, **kwargs).estimate

    def ok(self, est: PoseEstimate) -> bool:
        """A fix: converged, and inside the map."""
        return bool(est.converged) and bool(self.mission.map.contains(est.pose.xy))

    def localise_global(self) -> PoseEstimate:
        """Global localisation by the exploration policy (`MissionConfig.global_localisation`), the mission
        as its `Driver` (the first one from the start's heading prior, when the mission has one); ends
        the mission when the robot stays lost, naming the candidate places when several fit."""
        mission = self.mission
        strategy = mission.cfg.global_localisation
        heading, mission.start_heading = mission.start_heading, None  # the start's heading, once
        result = strategy.run(mission.robot, mission.localiser, prior=heading, rng=self.rng, driver=mission,
                              procedure=self.procedure, look_options=self.look_options(), map=mission.map,
                              checker=self.checkers.bare,
                              margin_checker=self.checkers.safe[-1] if self.checkers.safe else None)
        mission.estimate = result.estimate
        if result.converged:
            mission.fresh_fix = True
            mission.since_fix_cm = 0.0
            return result.estimate
        mission.candidates = candidate_poses(mission.localiser)
        if mission.candidates:  # several places fit the scans equally: say which, not just "lost"
            raise MissionEnded(Outcome.AMBIGUOUS, f"{describe_candidates(mission.candidates)}; global localisation "
                               f"could not tell them apart in {strategy.attempts} attempts")
        raise MissionEnded(Outcome.LOST, f"robot lost: global localisation did not converge in "
                           f"{strategy.attempts} attempts")

    def relocalise(self, reason: str, kind: str = "track") -> PoseEstimate:
        """A tracking re-localisation from the current belief (`kind` ``track``, or ``final`` at the target,
        chooses the sweep); from the other start when it does not converge, then a global one."""
        mission = self.mission
        mission.counts.relocalisations += 1
        if mission.estimate is None:
            return self.localise_global()
        first_prior = self.policy.from_prior
        est = self._fix(reason, kind, first_prior, with_spread=True)
        if self.ok(est):
            mission.fresh_fix = False
            mission.since_fix_cm = 0.0
            return est
        if not first_prior:
            est = self._fix(f"{reason}, from a wider prior", kind, True, with_spread=False)
            if self.ok(est):
                mission.since_fix_cm = 0.0
                return est
        return self.localise_global()

    def _fix(self, reason: str, kind: str, from_prior: bool, *, with_spread: bool) -> PoseEstimate:
        """One look from a prior around the estimate (`from_prior`) or from the belief; recorded with
        `reason` (and the spread of the fix, `with_spread`)."""
        mission = self.mission
        assert mission.estimate is not None
        if from_prior:
            est = self._look(self.policy.prior(mission.estimate), kind, reset=True)
        else:
            est = self._look(None, kind, reset=False)
        mission.estimate = est
        note = f"{reason}: {'converged' if self.ok(est) else 'not converged'}"
        mission.record(Action.RELOCALISE, note=f"{note}, spread {est.std_xy_cm:.2f} cm" if with_spread else note)
        return est

    def relocalise_from(self, prior: Prior, reason: str) -> PoseEstimate:
        """`relocalise` with the belief reset to `prior` first; a short first leg follows, as after a
        global fix."""
        mission = self.mission
        mission.localiser.reset(prior)
        mission.estimate = mission.localiser.estimate()
        est = self.relocalise(reason)
        mission.fresh_fix = True
        return est

    def heading_check(self) -> HeadingCheck | None:
        """One sweep of the front half (`SweepConfig.heading_check_angles`), read against the believed heading
        (`localisation.heading_check`) with the sonar model the localiser was told
        (its ``sonar_model`` option, `localisation.robot_options.told_sonar_model`; none: ideal readings); the
        belief is left as it was.
        None when the sensor was stuck or gave garbage (said through `on_sweep_fault`)."""
        mission = self.mission
        assert mission.estimate is not None
        scan = mission.robot.ultrascan(self.policy.sweeps.heading_check_angles())
        fault = sweep_fault(scan, mission.map)
        if fault is not None:
            if mission.on_sweep_fault is not None:
                mission.on_sweep_fault(fault)
            return None
        return check_heading(mission.map, mission.estimate.pose, scan, told_sonar_model(mission.cfg.localiser_options))
