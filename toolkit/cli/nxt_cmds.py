"""`nxtnav brick serve` (the virtual NXT brick), `nxtnav nxt check` and `nxtnav nxt calibrate`."""

from __future__ import annotations

import math
import signal
import sys
from pathlib import Path
from types import FrameType

import typer

from ..robots.brick_faults import Fault, FaultSchedule, Fired, parse_fault
from ..robots.nxt import NxtProfile, NxtRobot, connect_robot
from ..robots.nxt_profile import calibrated_track_width, calibrated_wheel_diameter
from ..robots.virtual_brick import BrickServer
from ..robots.virtual_brick_world import BrickConfig, BrickWorld
from ..seeds import derive_seed
from ..world import SONAR_MODELS, ConfigError, Map, NxtnavError, Pose, RobotGeometry, load_map
from .app import brick_app, nxt_app
from .choices import one_of
from .options import (
    MapName,
    NxtBackend,
    ProfileFile,
    SensorNoise,
    ServerHost,
    ServerPort,
    check_writable,
    count,
    non_negative,
    port_or_zero,
    pose_on_map,
    positive,
    sonar_profile,
    writable_file,
)
from .options import seed as seed_ok

__all__: list[str] = []

_FAULT_HELP = ("A scheduled fault (repeatable) of a KIND " + one_of("fault kind") + ": drop-link:AT_S:DOWN_S, "
               "stall:AT_S:DUR_S, sonar-stuck:AT_S:DUR_S, sonar-garbage:[AT_S:]P, motor-slip:AT_S:FRACTION. AT_S in "
               "brick time; link down and stall times in wall-clock seconds (docs/hardware.md).")


def _echo(text: str) -> None:
    typer.echo(text)
    sys.stdout.flush()


_ADDRESS_OPT = typer.Option(None, "--bt-address", help="Bluetooth address of the brick (00:16:53:xx:xx:xx).")
_NAME_OPT = typer.Option(None, "--brick-name", help="Only use the brick with this name.")


def _connect(backend: str, host: str, port: int, address: str | None, name: str | None,
             profile: NxtProfile | Path | None) -> NxtRobot:
    return connect_robot(backend, host=host, port=port, profile=profile, name=name, address=address)


def _say_fired(fault: Fault, fired: Fired) -> None:
    _echo(f"fault {fault.text} fired at brick time {fired.time_s:.2f} s")


def _brick_pose(text: str | None, m: Map) -> Pose:
    """The virtual brick's true pose from ``--pose`` (None: the map's start, facing +x), in the free area."""
    if text is None:
        if m.start is None:
            raise NxtnavError(f"--pose: map {m.name} has no start preset; give --pose")
        return Pose(float(m.start[0]), float(m.start[1]), 0.0)
    pose = pose_on_map(text, "--pose", m)
    assert isinstance(pose, Pose)
    return pose


@brick_app.command("serve")
def brick_serve(
    map_name: MapName = "map1",
    pose_text: str | None = typer.Option(None, "--pose", metavar="X,Y,HEADING_DEG",
                                         help="True start pose (cm, cm, deg); default: the map's start, heading 0."),
    port: int = typer.Option(2727, "--port", help="TCP port (0 = any free port, printed at start).",
                             callback=port_or_zero),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on."),
    time_factor: float = typer.Option(1.0, "--time-factor", help="Brick seconds per wall second (>1 = faster).",
                                      callback=positive),
    max_step: float | None = typer.Option(
        None, "--max-step", help="Largest brick-time step per exchange (s); default 0.25 in real time, "
                                 "0.02 when faster.", callback=positive),
    sonar: str = typer.Option("nxt", "--sonar", help="Sonar model " + one_of("sonar") + " (default: nxt, "
                                                     "the sensor an NXT client's localisers are told of)."),
    sensor_noise: SensorNoise = 1.0,
    sonar_profile_path: Path | None = typer.Option(
        None, "--sonar-profile", metavar="FILE",
        help="A sonar profile (nxtnav sonar fit) for the nxt sonar: the brick's readings are drawn from its model. "
             "Default: the nxt model's own parameters."),
    seed: int | None = typer.Option(None, "--seed", help="Random seed (sonar noise, wheel slip).", callback=seed_ok),
    log: Path | None = typer.Option(None, "--log", callback=writable_file,
                                    help="Truth log: one JSON line (t, pose, collisions) per motion."),
    wheel_diameter: float = typer.Option(RobotGeometry().wheel_diameter_cm, "--wheel-diameter",
                                         help="True wheel diameter of the simulated robot (cm).", callback=positive),
    track_width: float = typer.Option(RobotGeometry().track_width_cm, "--track-width",
                                      help="True track width of the simulated robot (cm).", callback=positive),
    radius: float = typer.Option(RobotGeometry().radius_cm, "--radius", help="Robot disc radius (cm).",
                                 callback=positive),
    wheel_slip: float = typer.Option(0.0, "--wheel-slip",
                                     help="Wheel slip: sd of the fraction a wheel's travel differs from its tachos.",
                                     callback=non_negative),
    brake_decel: float | None = typer.Option(None, "--brake-decel",
                                             help="Motor braking (deg/s^2): motors overshoot their limits like "
                                                  "real ones; default: ideal stops on the limit.",
                                             callback=positive),
    run_on: bool = typer.Option(False, "--motors-run-on-disconnect",
                                help="Like a real NXT, keep the motors running when a client's link drops "
                                     "(default: brake the motors that client started)."),
    fault_texts: list[str] | None = typer.Option(
        None, "--fault", metavar="KIND:AT_S[:ARG]",
        help=_FAULT_HELP),
    reassembly: float = typer.Option(
        0.25, "--reassembly-window", metavar="S", callback=positive,
        help="Seconds to wait for the rest of a telegram TCP delivered in pieces before refusing the piece."),
) -> None:
    """Serve a simulated NXT robot to nxt-python clients (socket backend) until Ctrl-C."""
    if sonar not in SONAR_MODELS.names():
        raise typer.BadParameter(f"expected one of {', '.join(SONAR_MODELS.names())}, got {sonar!r}",
                                 param_hint="--sonar")
    profile = sonar_profile(sonar_profile_path, sonar)
    check_writable(log, "--log")
    m = load_map(map_name)
    pose = _brick_pose(pose_text, m)
    if max_step is None:
        max_step = 0.25 if time_factor <= 1.0 else 0.02
    try:
        faults = FaultSchedule([parse_fault(t) for t in fault_texts or []],
                               rng=None if seed is None else derive_seed(seed, "faults"),
                               on_fire=_say_fired)
    except ConfigError as exc:
        raise typer.BadParameter(str(exc), param_hint="--fault") from None
    try:
        geometry = RobotGeometry(radius_cm=radius, wheel_diameter_cm=wheel_diameter, track_width_cm=track_width)
        config = BrickConfig(geometry=geometry, time_factor=time_factor, max_step_s=max_step, wheel_slip=wheel_slip,
                             brake_decel_deg_s2=brake_decel, brake_on_disconnect=not run_on,
                             reassembly_s=reassembly)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None
    world = BrickWorld(m, pose, config, sonar=sonar if profile is None else profile, sensor_noise=sensor_noise,
                       rng=seed, log=log, faults=faults)
    try:
        server = BrickServer(world, host=host, port=port)
    except OSError as exc:
        world.close()
        raise typer.BadParameter(f"cannot listen on {host}:{port}: {exc.strerror or exc}", param_hint="--port") \
            from None

    def _terminate(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, _terminate)
    _echo(f"virtual NXT brick on {server.host}:{server.port}: map {m.name}, pose ({pose.x:g}, {pose.y:g}, "
          f"{pose.heading_deg:g} deg), time factor {time_factor:g}, sonar {sonar}"
          f"{'' if sonar_profile_path is None else f' (profile {sonar_profile_path})'}; Ctrl-C stops")
    if faults:
        _echo(f"scheduled faults: {', '.join(f.text for f in faults.faults)}")
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, previous)
        server.stop()
    p = world.pose
    _echo(f"stopped: {server.clients} connection(s), brick time {world.time_s:.1f} s, pose ({p.x:.1f}, {p.y:.1f}, "
          f"{p.heading_deg:.1f} deg), {world.collisions} collision(s)")
    for f, fired, n in zip(faults.faults, faults.fired, faults.acted, strict=True):
        _echo(f"fault {f.text}: " + ("did not fire" if fired is None else
                                     f"fired at brick time {fired.time_s:.2f} s, acted {n} time(s)"))


@nxt_app.command("check")
def nxt_check(
    backend: NxtBackend = "usb",
    server_host: ServerHost = "127.0.0.1",
    server_port: ServerPort = 2727,
    bt_address: str | None = _ADDRESS_OPT,
    brick_name: str | None = _NAME_OPT,
    profile: ProfileFile = None,
    readings: int = typer.Option(3, "--readings", help="Sonar readings to take.", callback=count),
) -> None:
    """Connect to the brick; print its name, battery, firmware and a live sonar reading."""
    with _connect(backend, server_host, server_port, bt_address, brick_name, profile) as robot:
        info = robot.info()
        _echo(f"brick {info['name']!r} over {info['link']}, firmware {info['firmware']}, "
              f"protocol {info['protocol']}")
        volts = info["battery_mv"] / 1000.0
        low = " (low: replace or charge the batteries)" if volts < 7.0 else ""
        _echo(f"battery {volts:.2f} V{low}")
        values = [robot.read_sonar() for _ in range(readings)]
        shown = ", ".join("no echo" if v >= 255 else f"{v:g} cm" for v in values)
        _echo(f"sonar on port {robot.profile.sonar_port}: {shown}")
        _echo(f"clock: {robot.clock_source}")


@nxt_app.command("calibrate")
def nxt_calibrate(
    backend: NxtBackend = "usb",
    server_host: ServerHost = "127.0.0.1",
    server_port: ServerPort = 2727,
    bt_address: str | None = _ADDRESS_OPT,
    brick_name: str | None = _NAME_OPT,
    profile: Path = typer.Option(Path("nxt-profile.yaml"), "--profile", callback=writable_file,
                                 help="Profile YAML to update (read if it exists, then written)."),
    distance: float = typer.Option(50.0, "--distance", help="Distance to drive (cm)."),
    angle: float = typer.Option(360.0, "--angle", help="Angle to spin (deg)."),
) -> None:
    """Measure the wheel diameter and track width: drive a known distance, spin a known angle."""
    if not (math.isfinite(distance) and distance > 0):
        raise typer.BadParameter("must be a positive number of cm", param_hint="--distance")
    if not (math.isfinite(angle) and angle > 0):
        raise typer.BadParameter("must be a positive number of degrees", param_hint="--angle")
    check_writable(profile, "--profile")  # before the robot drives, not after the measurements
    current = NxtProfile.load(profile) if profile.exists() else NxtProfile()
    with _connect(backend, server_host, server_port, bt_address, brick_name, current) as robot:
        _echo(f"Step 1 of 2: put the robot on the floor with at least {distance + 20:g} cm free ahead and "
              "mark where a wheel touches the floor.")
        typer.prompt("Press Enter to drive", default="", show_default=False)
        outcome = robot.move(distance)
        if outcome.watchdog:
            raise typer.BadParameter(f"the watchdog stopped the drive after {outcome.distance_cm:.1f} cm: "
                                     "give the robot more room and run the calibration again")
        measured = typer.prompt("Distance the robot drove, measured on the floor (cm)", type=float)
        diameter = calibrated_wheel_diameter(current.wheel_diameter_cm, outcome.distance_cm, measured)
        updated = current.updated(wheel_diameter_cm=round(diameter, 4))
        robot.set_profile(updated)
        _echo(f"wheel diameter {current.wheel_diameter_cm:g} -> {updated.wheel_diameter_cm:g} cm")
        _echo(f"Step 2 of 2: mark the robot's heading; it will spin {angle:g} degrees counter-clockwise.")
        typer.prompt("Press Enter to spin", default="", show_default=False)
        robot.turn(math.radians(angle))
        turned = typer.prompt("Angle the robot spun, measured (deg)", type=float)
        track = calibrated_track_width(current.track_width_cm, angle, turned)
        updated = updated.updated(track_width_cm=round(track, 4))
        robot.set_profile(updated)
        _echo(f"track width {current.track_width_cm:g} -> {updated.track_width_cm:g} cm")
    updated.save(profile)
    _echo(f"wrote {profile}")
