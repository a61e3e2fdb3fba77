"""`nxtnav bench faults`: missions through virtual bricks that lose their link, stall, and whose sensor
sticks or talks garbage (`toolkit.bench.faults`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from ..number_format import json_safe
from .app import bench_app
from .choices import one_of
from .interrupts import run_batch
from .options import (
    ConfigFile,
    Dask,
    JsonOut,
    MapList,
    ReconnectTimeout,
    ReplyTimeout,
    Seed,
    Workers,
    check_writable,
    count,
    parse_list,
    writable_folder,
)
from .run_config import configuration

__all__: list[str] = []


@bench_app.command("faults")
def bench_faults(
    ctx: typer.Context,
    missions: int = typer.Option(20, "--missions", help="Missions to run (each also once without faults).",
                                 callback=count),
    seed: Seed = 0,
    kinds_text: str | None = typer.Option(
        None, "--faults", metavar="KIND[,KIND]",
        help="Fault kinds to draw from " + one_of("fault kind") + " (default all)."),
    maps_text: MapList = "map1,map2,map3",
    workers: Workers = 1,
    dask: Dask = None,
    reconnect_timeout: ReconnectTimeout = 30.0,
    reply_timeout: ReplyTimeout = 3.0,
    json_out: JsonOut = None,
    recordings: Path | None = typer.Option(None, "--recordings", callback=writable_folder, metavar="DIR",
                                           help="Keep each faulty mission's recording here (default: checked, "
                                                "then deleted)."),
    config_file: ConfigFile = None,
) -> None:
    """Missions with random faults on virtual bricks: success, collisions, faults seen and recovered,
    extra robot time, motors left running, recordings replayed."""
    from ..bench.faults import FAULT_KINDS, fault_tasks, run_fault_task, summarise
    from ..world import load_map

    kinds = parse_list(kinds_text or ",".join(FAULT_KINDS), "--faults", list(FAULT_KINDS))
    maps = parse_list(maps_text, "--maps")
    for name in maps:
        m = load_map(name)
        if m.start is None or m.target is None:
            raise typer.BadParameter(f"map {name} has no start and target presets", param_hint="--maps")
    check_writable(json_out, "--json")
    tasks = fault_tasks(missions, seed, kinds, maps, reconnect_timeout, reply_timeout, recordings)
    results = run_batch(run_fault_task, tasks, "missions", workers=workers, dask=dask, keep_partial=False).results
    results.sort(key=lambda r: r.index)
    summary = summarise(results)
    _print(summary)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        doc = {"settings": {"missions": missions, "seed": seed, "faults": kinds, "maps": maps,
                            "reconnect_timeout_s": reconnect_timeout, "reply_timeout_s": reply_timeout},
               "summary": summary, "missions": [r.to_dict() for r in results],
               "configuration": configuration(ctx, [])}
        json_out.write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False))
        typer.echo(f"wrote {json_out}")


def _s(v: float | None) -> str:
    return "-" if v is None else f"{v:.1f} s"


def _print(s: dict[str, Any]) -> None:
    n = s["missions"]
    typer.echo(f"missions {n}: {s['success']} reached the target ({100 * float(s['success_rate']):.1f} %; without "
               f"faults {s['baseline_success']}), {s['collisions']} collision(s), {s['motors_left_running']} motor(s) "
               "left running")
    typer.echo(f"faults: {s['faults_scheduled']} scheduled, {s['faults_acting']} acting, "
               f"{s['faults_acting_recovered']} of those in missions that reached the target; median extra robot "
               f"time per fault {_s(s['median_extra_robot_s_per_fault'])} against the same mission without faults")
    typer.echo(f"noticed by the missions: {s['links_lost']} lost link(s), {s['links_back']} back (median "
               f"{_s(s['median_outage_s'])} offline, {_s(s['median_recovery_robot_s'])} of robot time to resume); "
               f"{s['sonar_sweeps_repeated']} sweep(s) taken again for a faulty sonar; "
               f"{s['fixes_off_course']} fix(es) off course")
    typer.echo(f"recordings: {s['recordings_readable']} readable, {s['recordings_reproduced']} replayed bit for bit, "
               f"{s['recordings_truncated']} cut short")
    typer.echo("| fault | scheduled | fired | acting | acting, target reached | acting, with a collision | "
               "alone in a mission | median extra robot time (s) |")
    typer.echo("|---|---:|---:|---:|---:|---:|---:|---:|")
    for kind, r in sorted(s["by_kind"].items()):
        extra = "-" if r["median_extra_robot_s"] is None else f"{r['median_extra_robot_s']:.1f}"
        typer.echo(f"| {kind} | {r['scheduled']} | {r['fired']} | {r['acting']} | {r['recovered']} | "
                   f"{r['missions_with_collisions']} | {r['missions_with_it_alone']} | {extra} |")
    for line in s["failures"]:
        typer.echo(f"failed: {line}", err=True)
