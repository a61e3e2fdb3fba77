"""`nxtnav import sweeps`: a sweep set (real sweeps at known waypoints) as a recording for `nxtnav replay`."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import import_app
from .options import (
    RecordingOut,
    SweepsMap,
    check_writable,
    count,
    in_range,
    positive,
    repeats,
    shipped,
)

__all__: list[str] = []


@import_app.command("sweeps")
def import_sweeps(
    folder: Path = typer.Argument(..., metavar="DIR", callback=shipped,
                                  help="A sweep set: a folder with sweeps.csv and the sweep files."),
    map_file: SweepsMap = None,
    *,
    output: RecordingOut,
) -> None:
    """A sweep set as one recording, each sweep a global-localisation episode; score it with nxtnav replay.

    Each sweep becomes a global reset of the localiser and an update with the sweep, its waypoint the
    true position (without a heading: a real sweep's heading is not known). Then
    `nxtnav replay REC.jsonl --localisers A,B` scores the localisers' position after each sweep.
    """
    from ..real_sonar.sweeps import load_sweep_set
    from ..recordings.imported import import_sweep_set

    check_writable(output, "--output")
    sweeps = load_sweep_set(folder, map=map_file)
    result = import_sweep_set(sweeps, output)
    share = result.no_echo / result.readings if result.readings else 0.0
    held = f"; {result.held_no_echo} of them repeat a held echo: held_runs = no-echo" if result.held_no_echo else ""
    typer.echo(f"{folder}: {result.episodes} sweeps on map {result.map}, {result.readings} readings "
               f"({result.no_echo} no-echo, {share:.0%}{held}); sources: {', '.join(sweeps.repos)}")
    typer.echo(f"wrote {output} ({result.lines} lines); score it with: nxtnav replay {output} --localisers A,B")


@import_app.command("bag")
def import_bag_cmd(
    bag: Path = typer.Argument(..., metavar="BAG", callback=shipped,
                               help="A ROS 1 .bag, or a ROS 2 bag (.db3 or .mcap, or its folder)."),
    map_file: str = typer.Option(..., "--map", metavar="MAP.yaml",
                                 help="The map the robot drove in (a ROS map_server YAML, or any nxtnav map)."),
    scan_topic: str = typer.Option(..., "--scan-topic", metavar="TOPIC",
                                   help="sensor_msgs/LaserScan or sensor_msgs/Range messages: the scans."),
    odom_topic: str | None = typer.Option(None, "--odom-topic", metavar="TOPIC",
                                          help="nav_msgs/Odometry messages (default: /tf from --odom-frame to "
                                               "--base-frame)."),
    odom_frame: str = typer.Option("odom", "--odom-frame", metavar="FRAME", help="Odometry frame in /tf."),
    base_frame: str | None = typer.Option(None, "--base-frame", metavar="FRAME",
                                          help="The robot's frame in /tf: the pose the localisers track (default: "
                                               "base_footprint, or base_link when /tf has no base_footprint)."),
    truth_topic: str | None = typer.Option(None, "--truth-topic", metavar="TOPIC",
                                           help="Ground-truth poses (geometry_msgs/PoseStamped, "
                                                "PoseWithCovarianceStamped or nav_msgs/Odometry)."),
    truth_frame: str = typer.Option("0,0,0", "--truth-frame", metavar="X,Y,H",
                                    help="Pose of the ground truth's frame in the map (cm, cm, degrees)."),
    truth_offset: str = typer.Option("0,0,0", "--truth-offset", metavar="X,Y,H",
                                     help="Pose of the base in the body the truth tracks (cm, cm, degrees): a "
                                          "marker or sensor mounted away from the base, or turned against it."),
    every: int = typer.Option(1, "--every", metavar="N", callback=count, help="Keep every N-th scan."),
    beams: int = typer.Option(0, "--beams", metavar="N", callback=repeats,
                              help="Readings kept per scan, evenly spread (0: all)."),
    range_noise: float = typer.Option(2.0, "--range-noise", metavar="CM", callback=positive,
                                      help="Reading noise of the laser model the localisers are told (cm)."),
    odometry_noise: str = typer.Option("0.05,0.01", "--odometry-noise", metavar="DRIVE,TURN",
                                       help="Odometry noise the localisers are told: fractions of each drive and "
                                            "of each turn."),
    deskew: bool = typer.Option(True, "--deskew/--no-deskew",
                                help="Place each reading where odometry puts the robot when it was taken."),
    scan_delay: float = typer.Option(0.0, "--scan-delay", metavar="S", callback=in_range(-10.0, 10.0),
                                     help="How late the scan stamps are against odometry (s; e.g. a driver that "
                                          "stamps a sweep when it ends)."),
    truth_delay: float = typer.Option(0.0, "--truth-delay", metavar="S", callback=in_range(-10.0, 10.0),
                                      help="How late the truth's stamps are against odometry (s)."),
    *,
    output: RecordingOut,
) -> None:
    """A ROS bag as a recording: scans, odometry as motions, ground truth as true poses (cm, base frame).

    Score localisers on it with `nxtnav replay REC.jsonl --localisers A,B --initial-pose X,Y,H`.
    """
    import math

    from ..ros.bag_import import OdometryNoise, import_bag
    from ..world import load_map
    from .options import parse_floats

    check_writable(output, "--output")
    tx, ty, th = parse_floats(truth_frame, "--truth-frame", (3,))
    ox, oy, oh = parse_floats(truth_offset, "--truth-offset", (3,))
    drive, turn = parse_floats(odometry_noise, "--odometry-noise", (2,))
    if drive < 0 or turn < 0:
        raise typer.BadParameter(f"must be two fractions >= 0, got {odometry_noise!r}", param_hint="--odometry-noise")
    world = load_map(map_file)
    result = import_bag(bag, world, output, scan_topic=scan_topic, odom_topic=odom_topic, odom_frame=odom_frame,
                        base_frame=base_frame, truth_topic=truth_topic, every=every, beams=beams,
                        truth_frame=(tx, ty, math.radians(th)), range_noise_cm=range_noise,
                        noise=OdometryNoise("botsim", drive, turn), deskew=deskew,
                        scan_delay_s=scan_delay, truth_delay_s=truth_delay, truth_offset=(ox, oy, math.radians(oh)))
    share = result.echoes / result.readings if result.readings else 0.0
    typer.echo(f"{bag}: {result.scans} of {result.scans_in_bag} scans ({result.skipped} skipped: no "
               f"odometry or no reading), {result.readings} readings ({share:.0%} echoes), {result.predicts} motions, "
               f"{result.truths} true poses, {result.duration_s:.1f} s, {result.odometry_m:.2f} m by odometry")
    typer.echo(f"wrote {output} ({result.lines} lines); score it with: nxtnav replay {output} --localisers A,B "
               f"--initial-pose X,Y,H")
