"""`nxtnav maps list|show`, `nxtnav scan` and `nxtnav bench world`."""

from __future__ import annotations

import json
from typing import Any

import typer
from rich.console import Console
from rich.table import Table

from ..robots.sim import simulated_sonar
from ..world import (
    SONAR_MODELS,
    Pose,
    RobotGeometry,
    default_scan_angles,
    list_maps,
    load_map,
)
from .app import app, bench_app, maps_app
from .options import (
    Collision,
    ConfigFile,
    FigureOut,
    JsonFlag,
    JsonOut,
    MapName,
    PngOut,
    PoseText,
    Radius,
    Seed,
    SensorNoise,
    Sonar,
    SonarProfile,
    check_writable,
    count,
    non_negative,
    parse_sweep,
    pose_on_map,
    sonar_profile,
)
from .run_config import configuration
from .tables import NEVER_CUT, print_json, print_table

__all__: list[str] = []


@maps_app.command("list")
def maps_list(as_json: JsonFlag = False) -> None:
    """List the map names that resolve, with their files and presets."""
    rows: list[dict[str, Any]] = []
    for name, path in list_maps().items():
        m = load_map(path)
        rows.append({"name": name, "file": str(path), "walls": len(m.walls), "free_area_cm2": round(m.area, 1),
                     "start": None if m.start is None else list(m.start),
                     "target": None if m.target is None else list(m.target)})
    if as_json:
        print_json(rows)
        return
    table = Table()
    for column in ("name", "file"):
        table.add_column(column, **NEVER_CUT)  # type: ignore[arg-type]
    for column in ("walls", "free area (cm²)", "start", "target"):
        table.add_column(column)
    fmt = lambda p: "-" if p is None else f"({p[0]:g}, {p[1]:g})"  # noqa: E731
    for row in rows:
        table.add_row(row["name"], row["file"], str(row["walls"]), f"{row['free_area_cm2']:.0f}", fmt(row["start"]),
                      fmt(row["target"]))
    print_table(table)


@maps_app.command("show")
def maps_show(
    map_name: str = typer.Argument(..., metavar="NAME|PATH", help="Map name (map1) or YAML file."),
    *,
    output: FigureOut,
    radius: float = typer.Option(RobotGeometry().radius_cm, help="Robot radius for the c-space (cm; 0 = a point).",
                                 callback=non_negative),
) -> None:
    """Draw a map with its c-space and presets."""
    from ..plotting import draw_cspace, draw_map, new_axes, save_figure

    check_writable(output, "--output")
    m = load_map(map_name)
    fig, ax = new_axes(size=5.0 if len(m.walls) < 200 else 9.0)
    draw_map(m, ax)
    draw_cspace(m, radius, ax)
    if len(m.regions) > 1 or m.grid is not None:
        ax.set_title(f"{m.name}: {len(m.walls)} edges, {len(m.regions)} free region(s)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3, fontsize=8, frameon=False)
    save_figure(fig, output)
    typer.echo(f"wrote {output}")


@app.command("scan")
def scan(
    map_name: MapName = "map1",
    *,
    pose_text: PoseText,
    sonar: Sonar = "ideal",
    sensor_noise: SensorNoise = 1.0,
    sonar_profile_path: SonarProfile = None,
    seed: Seed = 0,
    radius: Radius = None,
    output: PngOut = None,
    json_out: JsonOut = None,
    angles_text: str | None = typer.Option(None, "--angles", metavar="START:STEP:COUNT",
                                           help="The sensor angles (degrees, relative to the heading): COUNT "
                                                "readings STEP apart from START (default 0:1:360)."),
    direction: str = typer.Option("ccw", "--direction", metavar="cw|ccw",
                                  help="The way the turret turns: reading k at START + k*STEP (ccw) or "
                                       "START - k*STEP (cw)."),
) -> None:
    """One scan at a pose: printed, drawn as the paper's Fig. 3 with -o (rays, radar chart).

    A full turn, one reading a degree counter-clockwise by default; the angles of a real sweep with
    --angles and --direction (`--angles 0:1:360 --direction cw`).
    """
    from ..plotting import draw_map, draw_pose, draw_radar, draw_scan_rays, expected_ranges, new_axes, save_figure
    from ..real_sonar.sweeps import sweep_angles

    if direction not in ("cw", "ccw"):
        raise typer.BadParameter(f"must be cw or ccw, got {direction!r}", param_hint="--direction")
    start_deg, step_deg, n = (0.0, 1.0, 360) if angles_text is None else parse_sweep(angles_text, "--angles")
    if sonar not in SONAR_MODELS:
        raise typer.BadParameter(f"unknown sonar model {sonar!r}; known: {', '.join(SONAR_MODELS.names())}",
                                 param_hint="--sonar")
    profile = sonar_profile(sonar_profile_path, sonar)
    check_writable(output, "--output")
    check_writable(json_out, "--json")
    m = load_map(map_name)
    pose = pose_on_map(pose_text, "--pose", m, radius)
    assert isinstance(pose, Pose)
    geometry = RobotGeometry() if radius is None else RobotGeometry(radius_cm=radius)
    model = simulated_sonar(sonar if profile is None else profile, sensor_noise)
    # the default full turn keeps its exact angles (k * 2 pi / 360); any other sweep is built as a real one
    default = angles_text is None and direction == "ccw"
    angles = default_scan_angles() if default else sweep_angles(n, step_deg, direction, start_deg)

    readings = model.measure(m.walls, pose.xy, pose.theta + angles, rng=seed)
    s = model.to_scan(angles, readings)
    echo = s.ranges[s.valid]
    named = sonar if sonar_profile_path is None else f"{sonar} (profile {sonar_profile_path})"
    typer.echo(f"scan at ({pose.x:g}, {pose.y:g}, {pose.heading_deg:g} deg) on {m.name}, sonar {named}: "
               f"{int(s.valid.sum())}/{len(s)} readings with an echo"
               + (f", {echo.min():.1f} to {echo.max():.1f} cm" if echo.size else ""))
    if json_out is not None:
        doc = {"map": m.name, "sonar": sonar, "sonar_model": model.to_dict(), "seed": seed, "pose": pose.to_list_deg(),
               "radius_cm": geometry.radius_cm,
               "sweep": {"start_deg": start_deg, "step_deg": step_deg, "count": n, "direction": direction},
               **s.to_dict()}
        json_out.write_text(json.dumps(doc, indent=1))
        typer.echo(f"wrote {json_out}")
    if output is None:
        return
    fig = new_axes(2, size=5.5)[0]
    fig.clf()
    ax0 = fig.add_subplot(1, 2, 1)
    ax1 = fig.add_subplot(1, 2, 2, projection="polar")
    draw_map(m, ax0, presets=False)
    draw_scan_rays(pose, s, ax0)
    draw_pose(pose, ax0, radius=geometry.radius_cm)
    ax0.set_title(f"{m.name}: scan at ({pose.x:g}, {pose.y:g}, {pose.heading_deg:g}°), sonar {sonar}")
    draw_radar(s, ax1, expected=expected_ranges(m, pose, s))
    ax1.set_title("readings (cm) vs sensor angle")
    ax1.legend(loc="lower left", fontsize=8, bbox_to_anchor=(-0.1, -0.12))
    save_figure(fig, output)
    typer.echo(f"wrote {output}")


@bench_app.command("world")
def bench_world(
    ctx: typer.Context,
    map_name: str = typer.Option("map1", "--map", help="Map name, YAML file, Moving AI .map or ROS map YAML."),
    random_grid: int = typer.Option(0, "--random-grid", metavar="CELLS",
                                    help="Instead of --map: a generated CELLS x CELLS random grid map "
                                         "(512: about 90,000 walls)."),
    cell_cm: float | None = typer.Option(None, help="Cell size (cm) of a Moving AI map (default 1) or of "
                                                    "--random-grid (default 5)."),
    radius: float = typer.Option(RobotGeometry().radius_cm, help="Robot radius for the checks and the c-space (cm)."),
    collision: Collision = "index",
    poses: int = typer.Option(1000, help="Poses per ray-casting call (x 360 directions).", callback=count),
    repeats: int = typer.Option(5, help="Repetitions; the median is reported.", callback=count),
    segments: int = typer.Option(20000, help="Random segments / points for the collision-check timing.",
                                 callback=count),
    range_model: bool = typer.Option(True, "--range-model/--no-range-model",
                                     help="Also build the particle filters' range table within the budget."),
    range_memory_mb: float | None = typer.Option(None, "--range-memory-mb",
                                                 help="Range model memory budget (MB; default 1024 or "
                                                      "$NXTNAV_RANGE_MEMORY_MB)."),
    sonar: Sonar = "ideal",
    peer: bool = typer.Option(True, "--peer/--no-peer", help="Measure raycast2d (optional extra) in the same run."),
    seed: Seed = 0,
    json_out: JsonOut = None,
    config_file: ConfigFile = None,
) -> None:
    """Throughput of ray casting and collision checks, c-space and range-model build; medians of repeats.

    Rays: `poses` random free positions x 360 directions. Checks: the --collision checker on random
    points over the map's bounds and random segments from them (normal x and y steps of 2.5 robot
    radii, 20 cm for 8 cm; long segments: 10 radii). The c-space is the free area shrunk by the radius
    plus the checker's structures (index and clearance raster, or FCL's BVH). The peer (``pip install nxtnav[peers]``)
    casts the same rays on the map rasterised at 1 cm (or coarser, at most 4096 pixels a side).
    """
    from ..bench.world import bench_world_figures

    if sonar not in SONAR_MODELS:
        raise typer.BadParameter(f"unknown sonar model {sonar!r}; known: {', '.join(SONAR_MODELS.names())}",
                                 param_hint="--sonar")
    if random_grid:
        from ..world.generated import random_grid_map

        m = random_grid_map(random_grid, cell_cm=cell_cm or 5.0, rng=seed)
    elif cell_cm is not None and str(map_name).endswith(".map"):
        from ..world.importers import import_map

        m = import_map(map_name, cell_cm=cell_cm)
    else:
        m = load_map(map_name)
    fig = bench_world_figures(m, radius=radius, poses=poses, repeats=repeats, segments=segments,
                              range_model=range_model, range_memory_mb=range_memory_mb, sonar=sonar, peer=peer,
                              collision=collision, rng=seed)
    table = Table("measure", "value", title=f"{m.name}: {fig['edges']} walls, {fig['collision']} collision checks, "
                                            f"medians of {repeats}")
    table.add_row("ray casting", f"{fig['rays_per_s'] / 1e6:.2f} M rays/s "
                  f"({fig['rays_per_cpu_s'] / 1e6:.2f} M per CPU second)")
    table.add_row(f"segment checks ({fig['mean_segment_cm']:.0f} cm mean)",
                  f"{fig['segment_checks_per_s'] / 1e3:.0f} k checks/s "
                  f"({fig['segment_checks_per_cpu_s'] / 1e3:.0f} k per CPU second)")
    table.add_row(f"long segment checks ({fig['mean_long_segment_cm']:.0f} cm mean)",
                  f"{fig['long_segment_checks_per_s'] / 1e3:.0f} k checks/s "
                  f"({fig['long_segment_checks_per_cpu_s'] / 1e3:.0f} k per CPU second)")
    table.add_row("point checks", f"{fig['point_checks_per_s'] / 1e3:.0f} k checks/s "
                  f"({fig['point_checks_per_cpu_s'] / 1e3:.0f} k per CPU second)")
    table.add_row("c-space build", f"{fig['cspace_build_s']:.2f} s")
    if fig.get("range_model_bytes") is not None:
        table.add_row(f"range model build ({sonar})", f"{fig['range_model_build_s']:.1f} s "
                      f"({fig['range_model_build_cpu_s']:.1f} CPU s) "
                      f"({fig['range_model_resolution_cm']:g} cm, {fig['range_model_dtype']})")
        table.add_row("range model memory", f"{fig['range_model_bytes'] / 2**20:.0f} MB")
    if fig.get("peer"):
        pr = fig["peer"]
        table.add_row(f"peer {pr['name']} ({pr['pixel_cm']:g} cm pixels)",
                      f"{pr['rays_per_s'] / 1e6:.2f} M rays/s (ours / peer {pr['ratio']:.1f}x), "
                      f"mean |range difference| {pr['mean_abs_range_diff_cm']:.2f} cm")
    Console().print(table)
    if json_out is not None:
        json_out.write_text(json.dumps({**fig, "configuration": configuration(ctx, [])}, indent=1))
        typer.echo(f"wrote {json_out}")
