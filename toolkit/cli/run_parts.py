"""The parts of `nxtnav run`: the stack it asks for, the mission on a real NXT or in the simulator, and
the outputs around it (the recording, the live view, the JSON report, the figures).

Each mission closes its recording and its view whatever happens: with the recording's ``end`` line
after a mission that ran, without one (cut short) after an error.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from ..number_format import json_safe
from ..world import Map, NxtnavError, RobotModel, SonarModel
from .compiling import compile_note
from .options import check_writable

if TYPE_CHECKING:
    from localisation import HeadingPrior

    from ..mission import MissionConfig

__all__ = ["RunOutputs", "Stack", "mission_on_nxt", "mission_on_sim"]


@dataclass(frozen=True)
class Stack:
    """What the mission runs: planner and localiser names, seed, collision backend, start heading prior and
    the mission settings (None: the sonar's defaults)."""

    planner: str
    localiser: str
    seed: int
    collision: str
    start_heading: HeadingPrior | None
    mission: MissionConfig | None = None
    objective: str | None = None

    def config(self, sonar: str) -> MissionConfig:
        """The mission settings: this stack's, else `sonar`'s defaults with the stack's collision backend;
        then the planner's objective, where one is chosen."""
        from ..mission import MissionConfig

        config = self.mission or MissionConfig.for_sonar(sonar, collision=self.collision)
        return config.with_options(**{"planning.objective": self.objective}) if self.objective else config


@dataclass(frozen=True)
class RunOutputs:
    """Where a run's results go: a recording (with at most `record_particles` particles per estimate), a
    live view (`view`) or its file (`view_save`), the JSON report, the plot and the animation; the run's
    effective `configuration` (`toolkit.cli.run_config.configuration`) goes into the report and the
    recording's header."""

    record: Path | None
    record_particles: int
    view: bool
    view_save: Path | None
    json_out: Path | None
    plot: Path | None
    animate: Path | None
    configuration: dict[str, Any] | None = None

    def check(self) -> None:
        """Fail now, before any work, on an output that could not be written or a view that cannot open."""
        check_writable(self.json_out, "--json")
        check_writable(self.plot, "--plot")
        check_writable(self.animate, "--animate")
        check_writable(self.view_save, "--view-save")
        if self.view or self.view_save is not None:  # Rerun, a display, the viewer program
            from ..view.viewer import check_view

            check_view("--view-save" if self.view_save is not None else "--view", "--view-save",
                       spawn=self.view_save is None)

    def open_stream(self) -> Any:
        """The live view's Rerun stream (a viewer, or the file `view_save`), or None without a view."""
        if not self.view and self.view_save is None:
            return None
        from ..view.live import open_stream

        what = "--view-save" if self.view_save is not None else "--view"
        return open_stream(self.view_save, what=what, save_option="--view-save")

    def recorder(self, m: Map, robot: dict[str, Any], sonar: dict[str, Any], stack: Stack,
                 noise: dict[str, Any] | None, stream: Any) -> Any:
        """The run's `Recorder` (writing `record`, feeding the view on `stream`), or None for neither."""
        if self.record is None and stream is None:
            return None
        from ..recordings.recorder import Recorder

        listeners = []
        if stream is not None:
            from ..view.live import LiveView

            listeners.append(LiveView(stream))
        try:
            if self.record is not None:
                self.record.parent.mkdir(parents=True, exist_ok=True)
            extra: dict[str, Any] = {"collision": stack.collision}
            if self.configuration is not None:
                extra["configuration"] = self.configuration
            if noise is not None:
                extra["noise"] = noise
            return Recorder(self.record, map=m, robot=robot, sonar=sonar, seed=stack.seed, extra=extra,
                            particles=self.record_particles, listeners=listeners)
        except OSError as exc:
            raise NxtnavError(f"--record: cannot write {self.record} ({exc.strerror or exc})") from None

    def write(self, report: Any, m: Map, doc: dict[str, Any], note: str | None = None) -> None:
        """Say what the recording and the view wrote (then `note`), and write the report and the figures;
        the JSON report is the mission's with `doc` added."""
        for path in (self.record, self.view_save):
            if path is not None:
                typer.echo(f"wrote {path}")
        if note is not None:
            typer.echo(note)
        if self.json_out is not None:
            self.json_out.parent.mkdir(parents=True, exist_ok=True)
            conf = {} if self.configuration is None else {"configuration": self.configuration}
            self.json_out.write_text(json.dumps(json_safe({**report.to_dict(), **doc, **conf}), indent=1,
                                                allow_nan=False))
            typer.echo(f"wrote {self.json_out}")
        if self.plot is not None or self.animate is not None:
            from ..bench.paper_plots import animate_mission, draw_mission
            from ..plotting import new_axes, save_figure

            if self.plot is not None:
                fig, ax = new_axes(size=6.0)
                draw_mission(report, m, ax)
                save_figure(fig, self.plot)
                typer.echo(f"wrote {self.plot}")
            if self.animate is not None:
                animate_mission(report, m, self.animate)
                typer.echo(f"wrote {self.animate}")


def finish(recorder: Any, report: Any, stream: Any) -> None:
    """Close a recording: with its ``end`` line after a mission that ran, without one (cut short) after an
    error; then the live view's stream."""
    if recorder is not None:
        recorder.close(None if report is None else report.status, None if report is None else report.success,
                       end=report is not None)
    if stream is not None:
        from ..view.live import close_stream

        close_stream(stream)


def mission_on_nxt(brick: Any, m: Map, target: Any, stack: Stack, sonar_model: SonarModel, outputs: RunOutputs,
                   reconnect_timeout_s: float) -> tuple[Any, float, float]:
    """The mission on the NXT robot `brick` (a real one, or the virtual brick): its report, the robot's
    radius (cm) and the robot time the simulator's time model gives the same commands (s)."""
    from ..mission import localiser_options, run_mission
    from ..robots.model_clock import ModelClock

    robot = ModelClock(brick)
    recorder = report = stream = None
    try:
        stream = outputs.open_stream()
        recorder = outputs.recorder(m, {"kind": "nxt", "link": robot.link, "virtual": robot.virtual,
                                        "profile": robot.profile.to_dict()},
                                    {"model": "nxt", "params": sonar_model.to_dict()}, stack, None, stream)
        # the virtual brick draws every reading independently; a real sensor's readings share errors
        robot_model = RobotModel(sonar_model, geometry=robot.geometry,
                                 readings="simulated" if robot.virtual else "real")
        opts = localiser_options(stack.localiser, robot_model)
        report = run_mission(robot, m, target, planner=stack.planner, localiser=stack.localiser, rng=stack.seed,
                             config=stack.config("nxt").with_localiser_defaults(opts),
                             recorder=recorder, reconnect_timeout_s=reconnect_timeout_s,
                             start_heading=stack.start_heading)
    finally:
        robot.close()
        finish(recorder, report, stream)
    return report, float(robot.geometry.radius_cm), robot.model_time_s


def mission_on_sim(m: Map, target: Any, start: Any, random_start: bool, stack: Stack, simulator: dict[str, Any],
                   robot_model: RobotModel, radius: float | None, outputs: RunOutputs) -> Any:
    """The mission in the simulator (`simulator`: the sonar's name, the noise model and its three noises, as
    the recording's header tells them; `robot_model`: the robot simulated; `radius`: the robot's when given,
    None for the default clearance of a random start): its report."""
    sonar_model = robot_model.sonar
    from ..mission import run_sim_mission

    stream = outputs.open_stream()
    recorder = report = None
    try:
        recorder = outputs.recorder(
            m, {"kind": "sim", "geometry": robot_model.geometry.to_dict()},
            {"model": simulator["sonar"], "sensor_noise": simulator["sensor_noise"],
             "params": sonar_model.to_dict()}, stack,
            {"model": simulator["noise_model"], "motion": simulator["motion_noise"],
             "turn": simulator["turn_noise"]}, stream)
        with compile_note("the collision checks, localisers and planners"):  # a first run's long wait
            report = run_sim_mission(
                m, seed=stack.seed, start=start, random_start_pose=random_start, target=target,
                planner=stack.planner, localiser=stack.localiser, noise_model=simulator["noise_model"],
                sensor_noise=simulator["sensor_noise"], motion_noise=simulator["motion_noise"],
                turn_noise=simulator["turn_noise"], sonar=simulator["sonar"], robot=robot_model,
                recorder=recorder, robot_radius_cm=radius, start_heading=stack.start_heading,
                config=stack.config(simulator["sonar"]),
            )
    finally:
        finish(recorder, report, stream)
    return report

