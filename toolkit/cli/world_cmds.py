"""`nxtnav maps list|show`, `nxtnav scan` and `nxtnav bench world`."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from ..plotting import (
    draw_cspace,
    draw_map,
    draw_pose,
    draw_radar,
    draw_scan_rays,
    expected_ranges,
    new_axes,
    save_figure,
)
from ..world import (
    SONAR_MODELS,
    CollisionChecker,
    Pose,
    RobotGeometry,
    default_scan_angles,
    list_maps,
    load_map,
    make_sonar,
    ray_cast,
)
from .app import app, bench_app, maps_app
from .options import check_writable, count, non_negative, parse_pose, positive
from .options import seed as seed_ok

__all__: list[str] = []


@maps_app.command("list")
def maps_list() -> None:
    """List the map names that resolve, with their files and presets."""
    table = Table("name", "file", "walls", "free area (cm²)", "start", "target")
    for name, path in list_maps().items():
        m = load_map(path)
        fmt = lambda p: "-" if p is None else f"({p[0]:g}, {p[1]:g})"  # noqa: E731
        table.add_row(name, str(path), str(len(m.walls)), f"{m.area:.0f}", fmt(m.start), fmt(m.target))
    Console().print(table)


@maps_app.command("show")
def maps_show(
    map_name: str = typer.Argument(..., metavar="NAME|PATH", help="Map name (map1) or YAML file."),
    output: Path = typer.Option(..., "-o", "--output", help="PNG file to write."),
    radius: float = typer.Option(RobotGeometry().radius_cm, help="Robot radius for the c-space (cm).",
                                 callback=positive),
) -> None:
    """Draw a map with its c-space and presets."""
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
    map_name: str = typer.Option("map1", "--map", help="Map name or YAML file."),
    pose_text: str = typer.Option(..., "--pose", metavar="X,Y,HEADING_DEG", help="Robot pose (cm, cm, deg)."),
    sonar: str = typer.Option("ideal", help=f"Sonar model: {', '.join(SONAR_MODELS.names())}."),
    sensor_noise: float = typer.Option(1.0, help="Sonar noise (cm).", callback=non_negative),
    seed: int = typer.Option(0, help="Random seed.", callback=seed_ok),
    output: Path | None = typer.Option(None, "-o", "--output", metavar="FILE.png",
                                       help="Draw the scan (rays on the map, radar chart)."),
    json_out: Path | None = typer.Option(None, "--json", help="Write the scan as JSON."),
) -> None:
    """One 360-degree scan at a pose: printed, drawn as the paper's Fig. 3 with -o (rays, radar chart)."""
    if sonar not in SONAR_MODELS:
        raise typer.BadParameter(f"unknown sonar model {sonar!r}; known: {', '.join(SONAR_MODELS.names())}",
                                 param_hint="--sonar")
    check_writable(output, "--output")
    check_writable(json_out, "--json")
    m = load_map(map_name)
    pose = parse_pose(pose_text, "--pose")
    assert isinstance(pose, Pose)
    if not m.contains(pose.xy):
        raise typer.BadParameter(f"pose ({pose.x:g}, {pose.y:g}) is outside the free area of {m.name}",
                                 param_hint="--pose")
    model = make_sonar(sonar, noise_sd=sensor_noise)
    angles = default_scan_angles()
    from ..world import Scan

    readings = model.measure(m.walls, pose.xy, pose.theta + angles, rng=seed)
    s = Scan.from_readings(angles, readings)
    echo = s.ranges[s.valid]
    typer.echo(f"scan at ({pose.x:g}, {pose.y:g}, {pose.heading_deg:g} deg) on {m.name}, sonar {sonar}: "
               f"{int(s.valid.sum())}/{len(s)} readings with an echo"
               + (f", {echo.min():.1f} to {echo.max():.1f} cm" if echo.size else ""))
    if json_out is not None:
        doc = {"map": m.name, "sonar": sonar, "seed": seed, "pose": pose.to_list_deg(), **s.to_dict()}
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
    draw_pose(pose, ax0, radius=RobotGeometry().radius_cm)
    ax0.set_title(f"{m.name}: scan at ({pose.x:g}, {pose.y:g}, {pose.heading_deg:g}°), sonar {sonar}")
    draw_radar(s, ax1, expected=expected_ranges(m, pose, s))
    ax1.set_title("readings (cm) vs sensor angle")
    ax1.legend(loc="lower left", fontsize=8, bbox_to_anchor=(-0.1, -0.12))
    save_figure(fig, output)
    typer.echo(f"wrote {output}")


@bench_app.command("world")
def bench_world(
    map_name: str = typer.Option("map1", "--map", help="Map name or YAML file."),
    poses: int = typer.Option(1000, help="Poses per ray-casting call.", callback=count),
    repeats: int = typer.Option(7, help="Repetitions; the median is reported.", callback=count),
    segments: int = typer.Option(20000, help="Random segments for the FCL segment check timing.", callback=count),
    seed: int = typer.Option(0, help="Random seed.", callback=seed_ok),
) -> None:
    """Throughput of ray casting (poses x 360 angles) and collision checks; medians of repeats.

    The checks are `CollisionChecker`'s on random points and segments over the map's bounds: those
    outside the free area are settled by shapely's point-in-polygon test, the rest by FCL.
    """
    m = load_map(map_name)
    rng = np.random.default_rng(seed)
    origins = m.sample_free(poses, rng=rng)
    angles = default_scan_angles()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        ray_cast(m.walls, origins, angles)
        times.append(time.perf_counter() - t0)
    ray_t = float(np.median(times))
    cc = CollisionChecker(m, RobotGeometry().radius_cm)
    xmin, ymin, xmax, ymax = m.bounds
    a = rng.uniform([xmin, ymin], [xmax, ymax], (segments, 2))
    b = a + rng.normal(0.0, 20.0, (segments, 2))
    seg_times, pt_times = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        cc.segments_free(a, b)
        seg_times.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        cc.point_free(a)
        pt_times.append(time.perf_counter() - t0)
    table = Table("measure", "median", "rate", title=f"{m.name}: {len(m.walls)} walls, median of {repeats}")
    n_rays = poses * angles.size
    table.add_row(f"ray cast {poses} poses x {angles.size} angles", f"{ray_t * 1e3:.1f} ms",
                  f"{n_rays / ray_t / 1e6:.2f} M rays/s")
    st, pt = float(np.median(seg_times)), float(np.median(pt_times))
    table.add_row(f"segment checks ({segments} random)", f"{st * 1e3:.1f} ms", f"{segments / st / 1e3:.1f} k checks/s")
    table.add_row(f"point checks ({segments} random)", f"{pt * 1e3:.1f} ms", f"{segments / pt / 1e3:.1f} k checks/s")
    Console().print(table)
