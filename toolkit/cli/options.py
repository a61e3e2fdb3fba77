"""Parsers and checks for the option values people type (points, poses, lists, numbers, ports, files).

The number checks are typer callbacks (``typer.Option(..., callback=positive)``): a value out of range
is a usage error that names the option (``Invalid value for '--radius': must be > 0, got -5``), exit 2.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..world import CHECKER_BACKENDS, COORDINATE_LIMIT_CM, OBJECTIVES, NxtnavError, NxtSonar, Pose, RobotTiming
from ..world.bundled import data_path
from .choices import one_of

if TYPE_CHECKING:
    from localisation.base import HeadingPrior

    from ..world import Map

__all__ = [
    "COLLISION_HELP",
    "MAX_COUNT",
    "MAX_SWEEP_READINGS",
    "NOISE_MODEL_HELP",
    "SENSOR_NOISE_HELP",
    "SONAR_PROFILE_HELP",
    "Collision",
    "ConfigFile",
    "Dask",
    "Force",
    "JsonOut",
    "MapList",
    "MapName",
    "NoiseModel",
    "OptionGone",
    "OutFolder",
    "PluginSets",
    "PngOut",
    "Radius",
    "RunSets",
    "Seed",
    "Sonar",
    "SonarProfile",
    "Workers",
    "check_writable",
    "collision",
    "count",
    "in_range",
    "non_negative",
    "output_problem",
    "parse_floats",
    "parse_list",
    "parse_pose",
    "parse_sweep",
    "parse_xy",
    "port",
    "port_or_zero",
    "pose_on_map",
    "positive",
    "remove_created_folders",
    "repeats",
    "seed",
    "shipped",
    "sonar_profile",
    "time_limit",
    "workers",
    "writable_file",
    "writable_folder",
]

MAX_COUNT = 1_000_000
"""Largest count (trials, runs, poses, repeats, ...) an option accepts: more would only exhaust memory."""
MAX_SWEEP_READINGS = 100_000
"""Most readings one simulated sweep may have (a real NXT sweep has 360 at most)."""
SENSOR_NOISE_HELP = "Noise of the ideal sonar (cm); the nxt sonar's comes from its model (see --sonar-profile)."
SONAR_PROFILE_HELP = ("A sonar profile (nxtnav sonar fit) for the nxt sonar: the readings are drawn from its model "
                      "and the localisers are told it. Default: the nxt model's own parameters.")


def in_range(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
             what: str = "") -> Callable[[Any], Any]:
    """A typer callback accepting finite numbers in [lo, hi] (``(lo, hi]`` with `lo_open`); None passes."""
    if lo is not None and hi is not None and not lo_open:
        rule = f"from {lo:.15g} to {hi:.15g}"
    else:
        low = "" if lo is None else f"{'>' if lo_open else '>='} {lo:g}"
        high = "" if hi is None else f"<= {hi:g}"
        rule = " and ".join(x for x in (low, high) if x)

    def check(value: Any) -> Any:
        if value is None:
            return value
        v = float(value)
        ok = math.isfinite(v) and (lo is None or (v > lo if lo_open else v >= lo)) and (hi is None or v <= hi)
        if not ok:
            raise typer.BadParameter(f"must be {what + ' ' if what else ''}{rule}, got {value!r}")
        return value

    return check


positive = in_range(0.0, lo_open=True)
"""A finite number > 0."""
non_negative = in_range(0.0)
"""A finite number >= 0."""
time_limit = in_range(0.0, lo_open=True, what="a time limit in seconds")
"""A planning budget: a finite number of seconds > 0."""
count = in_range(1, MAX_COUNT, what="a count")
"""An integer from 1 to `MAX_COUNT`."""
repeats = in_range(0, MAX_COUNT, what="a count")
"""An integer from 0 (none) to `MAX_COUNT`."""
seed = in_range(0, what="a seed")
"""A random seed: a non-negative integer."""
workers = in_range(1, 256, what="a number of worker processes")
"""Worker processes: 1 to 256."""
port = in_range(1, 65535, what="a TCP port")
"""A TCP port to connect to: 1-65535."""
port_or_zero = in_range(0, 65535, what="a TCP port (0 = any free one)")
"""A TCP port to listen on: 0-65535 (0 picks a free one)."""

COLLISION_HELP = ("Collision checks of the robot disc " + one_of("collision") + ": index (exact distances over a grid "
                  "of the walls, compiled) or fcl (python-fcl's BVH); a point robot (radius 0) has its own exact "
                  "checker.")
NOISE_MODEL_HELP = ("Motion noise model " + one_of("noise model") + ": botsim (proportional to each drive and turn) or "
                    "absolute.")


def collision(value: str) -> str:
    """A typer callback accepting a collision backend (`toolkit.world.CHECKER_BACKENDS`: index or fcl)."""
    if value not in CHECKER_BACKENDS:
        raise typer.BadParameter(f"must be one of {', '.join(CHECKER_BACKENDS)}, got {value!r}")
    return value


def shipped(value: Any) -> Any:
    """A typer callback for data paths (a path or a list of them): each as the documentation writes it
    (``maps/real-nxt``) also names the data shipped with nxtnav from any folder
    (`toolkit.world.bundled.data_path`); None passes."""
    if value is None:
        return None
    if isinstance(value, list | tuple):
        return [data_path(v) for v in value]
    return data_path(value)


def _nearest_existing(path: Path) -> Path:
    """`path` itself when it exists, else its nearest ancestor that does (the folder a write creates
    the missing ones in)."""
    here = path.absolute()
    while not here.exists() and here != here.parent:
        here = here.parent
    return here


def _probe_folder(folder: Path) -> str | None:
    """Why a file cannot be created in the existing folder `folder`, as the system says it (None: it can).

    Permission bits do not tell (root passes them, /proc refuses every new file), so a probe file of
    nxtnav's own, with a unique name, is created and removed again at once.
    """
    try:
        fd, name = tempfile.mkstemp(prefix=".nxtnav-write-check-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(name)
    return None


def output_problem(path: Path, folder: bool = False) -> str | None:
    """Why the output `path` (a file, or with `folder` a folder) could not be written later; None when it can.

    Nothing of the user's is created or changed: the path's missing folders must be creatable in its
    nearest existing ancestor, an existing file must open for appending (nothing is written to it).
    """
    if not folder and path.is_dir():
        return f"{path} is a folder, not a file"
    if folder and path.exists() and not path.is_dir():
        return f"{path} exists and is not a folder"
    if not folder and path.exists():
        try:
            with open(path, "ab"):
                return None
        except OSError as exc:
            return f"{path} is not writable ({exc.strerror or exc})"
    ancestor = _nearest_existing(path if folder else path.parent)
    if not ancestor.is_dir():
        return f"cannot create the folder of {path}: {ancestor} is not a folder"
    reason = _probe_folder(ancestor)
    return None if reason is None else f"cannot write {path}: no file can be made in {ancestor} ({reason})"


def writable_file(param: typer.CallbackParam, value: Any) -> Any:
    """A typer callback for an output file option: an output that could not be written is a usage error
    naming the option and the path now, before any work (nothing is created); None passes."""
    if value is not None:
        problem = output_problem(Path(value))
        if problem:
            raise typer.BadParameter(problem)
    return value


def writable_folder(param: typer.CallbackParam, value: Any) -> Any:
    """A typer callback for an output folder option (`writable_file` for a folder); None passes."""
    if value is not None:
        problem = output_problem(Path(value), folder=True)
        if problem:
            raise typer.BadParameter(problem)
    return value


def check_out_folder(out: Path, force: bool, option: str = "--out") -> None:
    """Fail now when the output folder `out` is a file, cannot be written, or holds files and `force` is
    not given."""
    problem = output_problem(out, folder=True)
    if problem:
        raise NxtnavError(f"{option}: {problem}")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise NxtnavError(f"{option}: {out} is not empty (use --force to write into it)")


def check_writable(path: Path | None, option: str) -> None:
    """Fail now, before any work, when the output file `path` could not be written later; then create
    its missing folders, as writing it would (None passes). If the command ends on bad input before it
    writes, `toolkit.cli.app.main` removes them again (`remove_created_folders`)."""
    if path is None:
        return
    problem = output_problem(path)
    if problem:
        raise NxtnavError(f"{option}: {problem}")
    missing = []
    folder = path.absolute().parent
    while not folder.exists():
        missing.append(folder)
        folder = folder.parent
    for folder in reversed(missing):
        try:
            folder.mkdir()
        except OSError as exc:
            raise NxtnavError(f"{option}: cannot create the folder of {path}: {exc.strerror or exc}") from None
        _CREATED.append(folder)


_CREATED: list[Path] = []
"""Folders `check_writable` made for outputs in this process, outermost first."""


def remove_created_folders(keep: bool = False) -> None:
    """Remove the folders `check_writable` made that are still empty (the command ended on bad input
    before writing into them); anything else stays. With `keep`, only forget them (the command ran)."""
    if keep:
        _CREATED.clear()
    while _CREATED:
        try:
            _CREATED.pop().rmdir()
        except OSError:  # something was written into it: it stays
            pass


def parse_floats(text: str, option: str, count: tuple[int, ...]) -> list[float]:
    """Comma-separated finite numbers, as many as one of `count`."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise NxtnavError(f"{option}: expected {' or '.join(map(str, count))} comma-separated numbers, "
                          f"got {text!r}") from None
    if len(values) not in count:
        raise NxtnavError(f"{option}: expected {' or '.join(map(str, count))} comma-separated numbers, "
                          f"got {len(values)} in {text!r}")
    for v in values:
        if not math.isfinite(v):
            raise NxtnavError(f"{option}: values must be finite, got {text!r}")
        if abs(v) > COORDINATE_LIMIT_CM:
            raise NxtnavError(f"{option}: values must lie within +-{COORDINATE_LIMIT_CM:g}, got {text!r}")
    return values


def parse_xy(text: str, option: str) -> tuple[float, float]:
    """``X,Y`` in cm."""
    x, y = parse_floats(text, option, (2,))
    return x, y


def parse_pose(text: str, option: str, heading_required: bool = True) -> Pose | tuple[float, float]:
    """``X,Y,HEADING_DEG`` as a Pose (or ``X,Y`` as a tuple when the heading is optional)."""
    values = parse_floats(text, option, (3,) if heading_required else (2, 3))
    if len(values) == 2:
        return values[0], values[1]
    return Pose.from_deg(*values)


def pose_on_map(text: str, option: str, m: Map, radius_cm: float | None = None,
                heading_required: bool = True) -> Pose | tuple[float, float]:
    """`parse_pose`, then a pose the robot can stand on: inside the free area of `m` and, with `radius_cm`,
    a robot disc of that radius clear of its walls; every refusal is one line in one style
    (``--pose: (500, 1) is outside the free area of map1``)."""
    pose = parse_pose(text, option, heading_required)
    x, y = (pose.x, pose.y) if isinstance(pose, Pose) else pose
    if not m.contains((x, y)):
        raise NxtnavError(f"{option}: ({x:g}, {y:g}) is outside the free area of {m.name}")
    if radius_cm is not None:
        from ..world import CollisionChecker

        if not CollisionChecker(m, radius_cm).point_free((x, y)):
            raise NxtnavError(f"{option}: a robot of radius {radius_cm:g} cm at ({x:g}, {y:g}) touches a wall "
                              f"of {m.name}")
    return pose


def parse_heading_prior(text: str | None, option: str) -> HeadingPrior | None:
    """``H:SD`` (degrees) as a `localisation.base.HeadingPrior` (None: none given); one line naming
    `option` when it is not one."""
    from localisation.base import HeadingPrior

    if text is None:
        return None
    try:
        return HeadingPrior.parse(text)
    except NxtnavError as exc:
        raise NxtnavError(option + str(exc).removeprefix("heading prior")) from None


def parse_list(text: str, option: str, known: list[str] | None = None) -> list[str]:
    """Comma-separated names; with `known`, unknown names are an error that lists the known ones."""
    names = [p.strip() for p in str(text).split(",") if p.strip()]
    if not names:
        raise NxtnavError(f"{option}: expected a comma-separated list, got {text!r}")
    if known is not None:
        bad = [n for n in names if n not in known]
        if bad:
            raise NxtnavError(f"{option}: unknown {', '.join(bad)}; known: {', '.join(known)}")
    return names


def parse_sweep(text: str, option: str) -> tuple[float, float, int]:
    """``START:STEP:COUNT``: the first angle and the step (degrees; STEP > 0) and the number of readings
    (a whole number from 1 to `MAX_SWEEP_READINGS`)."""
    parts = [p.strip() for p in str(text).split(":")]
    usage = f"expected START:STEP:COUNT (degrees, degrees, readings; e.g. 0:1:360), got {text!r}"
    if len(parts) != 3:
        raise NxtnavError(f"{option}: {usage}")
    try:
        start, step, n = (float(p) for p in parts)
    except ValueError:
        raise NxtnavError(f"{option}: {usage}") from None
    if not (math.isfinite(start) and abs(start) <= 360.0 * MAX_SWEEP_READINGS):
        raise NxtnavError(f"{option}: START must be a finite angle in degrees, got {parts[0]!r}")
    if not (math.isfinite(step) and 0.0 < step <= 360.0):
        raise NxtnavError(f"{option}: STEP must be a number of degrees > 0 and <= 360, got {parts[1]!r}")
    if not (math.isfinite(n) and n == int(n) and 1 <= n <= MAX_SWEEP_READINGS):
        raise NxtnavError(f"{option}: COUNT must be a whole number from 1 to {MAX_SWEEP_READINGS}, got {parts[2]!r}")
    return start, step, int(n)


def sonar_profile(path: Path | None, sonars: str | Sequence[str], option: str = "--sonar-profile") -> NxtSonar | None:
    """The ``nxt`` sonar's model from the profile file `path` (None without one; ``maps/...`` also
    names the shipped profiles from any folder, as `shipped`).

    A profile describes the ``nxt`` sonar only: with `sonars` (the chosen sonar, or several) that do not
    include it, it is an error naming `option`; a file that cannot be used is a `SonarProfileError`
    naming the file and the field.
    """
    if path is None:
        return None
    chosen = [sonars] if isinstance(sonars, str) else list(sonars)
    if "nxt" not in chosen:
        raise NxtnavError(f"{option}: a sonar profile describes the nxt sonar; it cannot be used with --sonar "
                          f"{','.join(chosen)}")
    from ..real_sonar.fit import load_sonar_profile

    return load_sonar_profile(data_path(path))


def _option_gone(value: Any) -> Any:
    """Callback of the removed ``--option``: one line naming ``--set`` (exit 2)."""
    if value:
        raise typer.BadParameter("is gone: give mission settings as --set mission.GROUP.FIELD=VALUE "
                                 "(e.g. --set mission.fix.rule=always)")
    return value


def _load_config(ctx: typer.Context, param: typer.CallbackParam, value: Any) -> Any:
    from .run_config import load_config

    return load_config(ctx, param, value)


# The options many commands take, declared once (a command writes ``seed: Seed = 0``).
MapName = Annotated[str, typer.Option("--map", metavar="NAME|PATH", help="Map name (map1) or YAML file.")]
MapList = Annotated[str, typer.Option("--maps", metavar="NAME[,NAME]", help="Comma-separated map names or files.")]
JsonOut = Annotated[Path | None, typer.Option("--json", callback=writable_file, metavar="FILE",
                                              help="Write the results as JSON.")]
OutFolder = Annotated[Path, typer.Option("--out", callback=writable_folder,
                                         help="Output folder (must be empty or new, unless --force).")]
PngOut = Annotated[Path | None, typer.Option("-o", "--output", callback=writable_file, metavar="FILE.png",
                                             help="Draw the result into this PNG file.")]
Force = Annotated[bool, typer.Option("--force", help="Write into a non-empty --out, replacing files.")]
Seed = Annotated[int, typer.Option("--seed", callback=seed,
                                   help="Random seed (every random draw of the command derives from it).")]
Workers = Annotated[int, typer.Option("--workers", callback=workers, help="Worker processes (1 = in this process).")]
Dask = Annotated[str | None, typer.Option("--dask", metavar="ADDRESS",
                                          help="Dask scheduler address (tcp://host:8786), or local: run the "
                                               "tasks there (docs/cluster.md).")]
Radius = Annotated[float | None, typer.Option("--radius", min=0.1,
                                              help="Simulated robot's radius (cm; default 8): a robot scaled to "
                                                   "the map.")]
Collision = Annotated[str, typer.Option("--collision", metavar="index|fcl", help=COLLISION_HELP,
                                        callback=collision)]
NoiseModel = Annotated[str, typer.Option("--noise-model", help=NOISE_MODEL_HELP)]
Sonar = Annotated[str, typer.Option("--sonar", help="Sonar model of the simulator " + one_of("sonar") + ".")]
SonarProfile = Annotated[Path | None, typer.Option("--sonar-profile", metavar="FILE", help=SONAR_PROFILE_HELP)]
PluginSets = Annotated[list[str], typer.Option(
    "--set", metavar="[PLUGIN.]KEY=VALUE",
    help="A plug-in option (repeatable): NAME.KEY=VALUE for the chosen planner or localiser NAME, or KEY=VALUE "
         "for every chosen one that has it (docs/parameters.md); robot.GROUP.FIELD=VALUE, sonar.FIELD=VALUE for "
         "the robot model where the command has one (docs/reference/schemas.md).")]
RunSets = Annotated[list[str], typer.Option(
    "--set", metavar="SECTION.KEY=VALUE",
    help="A setting (repeatable): mission.GROUP.FIELD=VALUE for the mission (e.g. mission.drive.move_step_cm=20; "
         "docs/missions.md), robot.GROUP.FIELD=VALUE and sonar.FIELD=VALUE for the robot model (e.g. "
         "robot.timing.drive_speed_cm_s=20; docs/reference/schemas.md), PLUGIN.KEY=VALUE for the planner's or "
         "localiser's options (docs/parameters.md).")]
ConfigFile = Annotated[Path | None, typer.Option(
    "--config", metavar="FILE", is_eager=True, callback=_load_config,
    help="Run again as a run's JSON output (or its configuration) says: its options and settings are the "
         "defaults; options and --set given here win.")]
OptionGone = Annotated[list[str] | None, typer.Option("--option", hidden=True, callback=_option_gone)]
Objective = Annotated[str | None, typer.Option(
    "--objective", metavar="|".join(OBJECTIVES),
    help="What every planner minimises: " + ", ".join(OBJECTIVES) + " (default: each planner its own; "
         "`nxtnav planners show NAME` lists what a planner can minimise).")]
TIMING = RobotTiming()
"""The robot model's default timing: the defaults of the options below."""
DriveSpeed = Annotated[float, typer.Option("--drive-speed", metavar="CM/S",
                                           help="Robot model: driving speed (cm/s), for robot time.")]
TurnRate = Annotated[float, typer.Option("--turn-rate", metavar="DEG/S",
                                         help="Robot model: turn-in-place rate (deg/s), for robot time.")]
StopTurn = Annotated[float, typer.Option("--stop-turn", metavar="S",
                                         help="Robot model: fixed time of each stop-and-turn (s), for robot time.")]
def nxt_backend(value: str) -> str:
    """Callback of ``--nxt-backend``: one of the NXT links (`toolkit.robots.nxt_link.BACKENDS`)."""
    from ..robots.nxt_link import BACKENDS

    if value not in BACKENDS:
        raise typer.BadParameter(f"expected one of {', '.join(BACKENDS)}, got {value!r}", param_hint="--nxt-backend")
    return value


# Options that several commands take with one meaning (the default stays in each command's signature).
NxtBackend = Annotated[str, typer.Option("--nxt-backend", callback=nxt_backend,
                                         help="How to reach the brick " + one_of("nxt backend") + ".")]
ServerHost = Annotated[str, typer.Option("--server-host",
                                         help="Brick server host: nxt-server or a virtual brick (socket backend).")]
ServerPort = Annotated[int, typer.Option("--server-port", callback=port,
                                         help="Brick server port: nxt-server or a virtual brick (socket backend).")]
SweepSetFolder = Annotated[Path, typer.Argument(callback=shipped, help="Sweep set: a folder with sweeps.csv, the raw "
                                                                      "files and arena.yaml.")]
SweepsMap = Annotated[str | None, typer.Option("--map", metavar="NAME|FILE",
                                               help="The map of the sweeps (default: the folder's arena.yaml).")]
GlobalLocalisers = Annotated[str, typer.Option("--localisers", metavar="A,B,...",
                                               help="Comma-separated localisers that localise from one sweep.")]
Seeds = Annotated[str, typer.Option("--seeds", metavar="N,N,...",
                                    help="Comma-separated seeds (each run's random draws derive from one).")]
SweepsNoise = Annotated[str, typer.Option(
    "--noise", metavar="SENSOR,MOTION,TURN",
    help="As `nxtnav run` takes it; the odometry gets the motion and turn noise (the sensor's noise is the "
         "real sweeps').")]
TruthHeadings = Annotated[str, typer.Option(
    "--headings", metavar="column|aligned|model",
    help="The truth's heading at a sweep: column (sweeps.csv's heading_deg), aligned (the heading that aligns the "
         "sweep with the map at its waypoint, as heading_deg is made) or model (where the sonar model finds the "
         "sweep most likely).")]


def checked_headings(value: str) -> str:
    """`TruthHeadings` checked: ``column``, ``aligned`` or ``model``."""
    if value not in ("column", "aligned", "model"):
        raise NxtnavError(f"--headings: must be column, aligned or model, got {value!r}")
    return value


SourceProfiles = Annotated[Path | None, typer.Option(
    "--sonar-profile", metavar="FILE|DIR",
    help="nxt sonar model: a profile for every source, or a folder of per-source profiles (OWNER+NAME.yaml, as "
         "`nxtnav sonar fit --per-source` writes them); default: the fitted default.")]
RecordingOut = Annotated[Path, typer.Option("-o", "--output", callback=writable_file, metavar="REC.jsonl",
                                            help="The recording to write.")]
FigureOut = Annotated[Path, typer.Option("-o", "--output", callback=writable_file, metavar="FILE.png",
                                         help="The PNG figure to write.")]
Overwrite = Annotated[bool, typer.Option("--force", help="Overwrite the output file if it exists.")]
JsonFlag = Annotated[bool, typer.Option("--json",
                                        help="Print JSON instead of a table (every field whole, for scripts).")]
PoseText = Annotated[str, typer.Option("--pose", metavar="X,Y,HEADING_DEG",
                                       help="The robot's true pose (cm, cm, degrees).")]
PlannerName = Annotated[str, typer.Option("--planner", help="Planner " + one_of("planner") + ".")]
PlannerList = Annotated[str, typer.Option("--planners", help="Comma-separated planners " + one_of("planner") + ".")]
LocaliserName = Annotated[str, typer.Option("--localiser", help="Localiser " + one_of("localiser") + ".")]
PlanRadius = Annotated[float, typer.Option("--radius", callback=non_negative,
                                           help="Robot radius (cm; 0: a point robot).")]
TimeLimit = Annotated[float, typer.Option("--time-limit", metavar="SECONDS", callback=time_limit,
                                          help="Planning budget per query (s).")]
def query_kind(value: str) -> str:
    """A typer callback accepting ``--queries``: presets or random."""
    if value not in ("presets", "random"):
        raise NxtnavError(f"--queries must be presets or random, got {value!r}")
    return value


Queries = Annotated[str, typer.Option("--queries", metavar="presets|random", callback=query_kind,
                                      help="presets (the map's start/target) or random.")]
ExecRepeats = Annotated[int, typer.Option("--exec-repeats", callback=repeats,
                                          help="Open-loop drives per query for the measured execution error "
                                               "(0 skips it).")]
MotionNoiseLevel = Annotated[float, typer.Option("--motion-noise", callback=non_negative,
                                                 help="botsim: fraction; absolute: cm per move.")]
TurnNoiseLevel = Annotated[float, typer.Option("--turn-noise", callback=non_negative,
                                               help="botsim: fraction of a turn; absolute: rad.")]
SensorNoise = Annotated[float, typer.Option("--sensor-noise", callback=non_negative, help=SENSOR_NOISE_HELP)]
TrackerPrior = Annotated[str, typer.Option("--tracker-prior", help="Prior of the EKF/UKF " + one_of("tracker prior")
                                           + " (pf: paper-pf's first estimate).")]
ScanProcessing = Annotated[str, typer.Option("--scan-processing",
                                             help="Scans for the localisers: paper (processed) or raw.")]
Lobe = Annotated[str, typer.Option("--lobe", help="auto: localisers that can model it get the sonar's lobe; off: "
                                                  "thin ray.")]
ProfileFile = Annotated[Path | None, typer.Option("--profile", metavar="FILE",
                                                 help="NXT robot profile YAML (ports, calibration).")]
ReconnectTimeout = Annotated[float, typer.Option(
    "--reconnect-timeout", metavar="S", callback=non_negative,
    help="NXT: after a lost link, try this many seconds to reach the brick again before the mission ends.")]
ReplyTimeout = Annotated[float, typer.Option(
    "--reply-timeout", metavar="S", callback=positive,
    help="NXT (socket, Bluetooth): a reply that takes longer than this counts as a lost link.")]
