"""`nxtnav maps import`, `maps random` and `bench scen`: grid maps made elsewhere, their optima, and big ones."""

from __future__ import annotations

import math
from pathlib import Path

import typer
import yaml

from ..world import NxtnavError, import_map
from .app import bench_app, maps_app
from .choices import one_of
from .options import (
    Collision,
    ConfigFile,
    Dask,
    OutFolder,
    Overwrite,
    PlanRadius,
    Seed,
    TimeLimit,
    Workers,
    parse_list,
    shipped,
    writable_file,
)
from .progress import progress
from .run_config import configuration, dumps

__all__: list[str] = []


@maps_app.command("import")
def maps_import(
    src: Path = typer.Argument(..., metavar="SRC", callback=shipped,
                               help="A Moving AI .map file or a ROS map_server .yaml."),
    output: Path = typer.Option(..., "-o", "--output", callback=writable_file,
                                metavar="OUT.yaml", help="Map YAML to write."),
    cell_cm: float | None = typer.Option(None, "--cell-cm", help="Moving AI cell size in cm (default 1)."),
    unknown: str = typer.Option("occupied", "--unknown", help="ROS cells of unknown occupancy: occupied or free."),
    simplify: float = typer.Option(0.0, "--simplify", metavar="CM",
                                   help="Simplify outlines by up to CM cm, growing obstacles only (0: exact)."),
    name: str | None = typer.Option(None, "--name", help="Map name (default: the file name)."),
    force: Overwrite = False,
) -> None:
    """Import a grid map as an exact polygonal map YAML (free space = the free cells)."""
    if unknown not in ("occupied", "free"):
        raise NxtnavError(f"--unknown must be occupied or free, got {unknown!r}")
    if cell_cm is not None and not (math.isfinite(cell_cm) and cell_cm > 0):
        raise NxtnavError(f"--cell-cm must be a positive number of cm, got {cell_cm}")
    if not (math.isfinite(simplify) and simplify >= 0):
        raise NxtnavError(f"--simplify must be a non-negative number of cm, got {simplify}")
    if output.suffix not in (".yaml", ".yml"):
        raise NxtnavError(f"-o: the output must be a .yaml file, got {output}")
    if output.exists() and not force:
        raise NxtnavError(f"-o: {output} exists (use --force to overwrite)")
    if not output.parent.is_dir():
        raise NxtnavError(f"-o: folder {output.parent} does not exist")
    m = import_map(src, cell_cm=cell_cm, unknown=unknown, simplify_cm=simplify, name=name)  # type: ignore[arg-type]
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    text = yaml.dump(m.to_dict(), Dumper=dumper, sort_keys=False, default_flow_style=None, width=120)
    tmp = output.with_name(output.name + ".part")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(output)  # never leave a half-written map behind
    holes = sum(len(r.holes) for r in m.regions)
    typer.echo(f"wrote {output}: {m.name}, {len(m.regions)} free region(s), {holes} holes, {len(m.walls)} edges, "
               f"{len(m.pinch_points)} pinch points, free area {m.area / 1e4:.2f} m²")


@maps_app.command("random")
def maps_random(
    size: int = typer.Argument(..., metavar="SIZE", help="Cells along each side."),
    output: Path = typer.Option(..., "-o", "--output", callback=writable_file,
                                metavar="OUT.map", help="Moving AI .map file to write."),
    density: float = typer.Option(0.2, "--density", help="Probability that each cell is blocked."),
    seed: Seed = 0,
    force: Overwrite = False,
) -> None:
    """Write a SIZE x SIZE grid of independently blocked cells as a Moving AI map (for scaling runs)."""
    from ..world.generated import random_occupancy
    from ..world.importers import write_movingai_map

    if size < 1:
        raise NxtnavError(f"SIZE must be a positive number of cells, got {size}")
    if not (math.isfinite(density) and 0.0 <= density <= 1.0):
        raise NxtnavError(f"--density must be in [0, 1], got {density}")
    if output.suffix != ".map":
        raise NxtnavError(f"-o: the output must be a .map file, got {output}")
    if output.exists() and not force:
        raise NxtnavError(f"-o: {output} exists (use --force to overwrite)")
    if not output.parent.is_dir():
        raise NxtnavError(f"-o: folder {output.parent} does not exist")
    grid = random_occupancy(size, size, density, rng=seed)
    write_movingai_map(grid, output)
    typer.echo(f"wrote {output}: {size} x {size} cells, {int((~grid.free).sum())} blocked (seed {seed})")


@bench_app.command("scen")
def bench_scen(
    ctx: typer.Context,
    scen: Path = typer.Argument(..., metavar="FILE.scen", callback=shipped, help="Moving AI / GPPC scenario file."),
    map_path: Path | None = typer.Option(None, "--map", metavar="FILE.map", callback=shipped,
                                         help="The map (default: the file the scenarios name, next to FILE.scen)."),
    kind: str = typer.Option(..., "--kind", help="Kind " + one_of("scen kind")
                             + ": octile (cells, 8-connected) or any-angle (cell corners)."),
    planners_text: str = typer.Option("astar,shortest", "--planners",
                                      help="Comma-separated planners " + one_of("planner")
                                           + ", or peers (benchmark extra 'peers') " + one_of("peer") + "."),
    radius: PlanRadius = 0.0,
    collision: Collision = "index",
    cell_cm: float = typer.Option(1.0, "--cell-cm", help="Cell size in cm (lengths are compared in cells)."),
    limit: int | None = typer.Option(None, "--limit", help="Run N queries spread evenly over the file."),
    time_limit: TimeLimit = 10.0,
    seed: Seed = 0,
    out: OutFolder = Path("out/scen"),
    workers: Workers = 1,
    dask: Dask = None,
    check: bool = typer.Option(False, "--check", help="Exit 1 when an exact planner mismatches the published optimum "
                                                      "or any path is shorter than it where none can be."),
    config_file: ConfigFile = None,
) -> None:
    """Run planners on a scenario file and compare their lengths with the published optima.

    Writes DIR/scen.csv, DIR/summary.md, DIR/scen.log (OMPL format, for Planner Arena) and DIR/config.json
    (the run's configuration, for --config).
    """
    from planners import PLANNERS

    from ..bench.scen import ScenConfig, load_scen_map, read_scen, run_scen, select_queries, summarise
    from ..bench.scen import write_scen_outputs as write_outputs

    if kind not in ("octile", "any-angle"):
        raise NxtnavError(f"--kind must be octile or any-angle, got {kind!r}")
    names = parse_list(planners_text, "--planners")
    from ..bench.peers import PEERS

    for n in names:
        if not n.startswith("peer:"):
            PLANNERS.check(n)
        elif n.startswith("peer:") and n not in PEERS:
            raise NxtnavError(f"--planners: unknown peer {n!r}; known: {', '.join(PEERS)}")
    if not (math.isfinite(radius) and radius >= 0):
        raise NxtnavError(f"--radius must be a non-negative number of cm, got {radius}")
    if not (math.isfinite(time_limit) and time_limit > 0):
        raise NxtnavError(f"--time-limit must be a positive number of seconds, got {time_limit}")
    if not scen.is_file():
        raise NxtnavError(f"scenario file {str(scen)!r} not found")
    if map_path is None:
        first = next((ln for ln in scen.read_text(encoding="utf-8").splitlines()[1:] if ln.strip()), "")
        fields = first.split("\t") if "\t" in first else first.split()
        if len(fields) < 2:
            raise NxtnavError(f"{scen}: line 2: cannot tell which map the scenarios use (give --map)")
        map_path = scen.parent / Path(fields[1]).name
    if out.exists() and not out.is_dir():
        raise NxtnavError(f"--out: {out} exists and is not a folder")
    m = load_scen_map(map_path, cell_cm)
    queries = read_scen(scen, m, kind)  # type: ignore[arg-type]
    chosen = select_queries(queries, limit)
    out.mkdir(parents=True, exist_ok=True)
    config = ScenConfig(str(scen), str(map_path), kind, tuple(names), radius, cell_cm, time_limit, seed,  # type: ignore[arg-type]
                        collision=collision)
    with progress(f"{scen.name}: {', '.join(names)}", len(chosen) * len(names)) as advance:
        result = run_scen(config, chosen, workers=workers, dask_address=dask, on_done=advance)
    files = write_outputs(result, out, len(chosen))
    files["config"] = out / "config.json"
    files["config"].write_text(dumps({"configuration": configuration(ctx, [])}), encoding="utf-8")
    typer.echo(files["summary"].read_text(encoding="utf-8"))
    typer.echo(f"wrote {', '.join(str(p) for p in files.values())}")
    if not result.complete:
        typer.echo(f"nxtnav: interrupted; partial results (marked incomplete) are in {out}", err=True)
        raise typer.Exit(130)
    if check and any(s.mismatches or s.below_optimum for s in summarise(result)):
        typer.echo("nxtnav: check failed: a planner's length disagrees with the published optimum", err=True)
        raise typer.Exit(1)
