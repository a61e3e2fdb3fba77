"""The figures of the README and docs/ as jobs: each one seeded `nxtnav` command and the PNGs it writes.

`nxtnav figures` (`toolkit.cli.figures_cmds`) runs them; the help texts list their names
(`toolkit.cli.choices`). This module imports no command module, so both can import it.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["FIGURE_JOBS", "REPO", "SCREENSHOTS", "WORK", "FigureJob", "figure_names"]

WORK = "{work}"
"""Placeholder in a job's arguments for the folder its outputs go to."""
REPO = "{repo}"
"""Placeholder for the repository's folder (files it ships, such as the example recording), so the
command runs from any folder; shown as a path relative to the repository."""
_REPO_DIR = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class FigureJob:
    """One seeded ``nxtnav`` command and the figures it writes.

    Parameters
    ----------
    name : str
        Short name (``--only``).
    argv : tuple of str
        The command's arguments after ``nxtnav``; `WORK` stands for the output folder.
    figures : dict of str to str
        Documentation file name -> the file the command writes (relative to the output folder).
    caption : str
        One line on what the figures show.
    quick : dict of str to str
        Option -> value replacing it (or added) on the reduced setting of ``--quick``.
    """

    name: str
    argv: tuple[str, ...]
    figures: dict[str, str]
    caption: str
    quick: dict[str, str] = field(default_factory=dict)

    def args(self, work: str, quick: bool = False) -> list[str]:
        """The command's arguments with `work` for the output folder (and the quick setting)."""
        args = list(self.argv)
        if quick:
            for opt, value in self.quick.items():
                if opt in args:
                    args[args.index(opt) + 1] = value
                else:
                    args.extend([opt, value])
        return [a.replace(WORK, work).replace(REPO, str(_REPO_DIR)) for a in args]

    def command(self) -> str:
        """The command as a reader types it (outputs in the current folder or ``out/``)."""
        args = [a.replace(f"{WORK}/", "") if a.endswith(".png") else a.replace(WORK, "out") for a in self.argv]
        args = [a.replace(f"{REPO}/", "") for a in args]
        return " ".join(shlex.quote(a) for a in ["nxtnav", *args])


FIGURE_JOBS: tuple[FigureJob, ...] = (
    FigureJob(
        "mission",
        ("run", "--map", "map3", "--seed", "4", "--plot", f"{WORK}/mission_map3.png"),
        {"mission_map3.png": "mission_map3.png"},
        "a whole mission on map3 from the preset start: planned path, estimates and the true trajectory",
        {"--map": "map1"}),
    FigureJob(
        "localise",
        ("localise", "--map", "map3", "--pose", "50,70,90", "--seed", "1", "-o", f"{WORK}/localise_map3.png"),
        {"localise_map3.png": "localise_map3.png"},
        "paper-pf localising globally on map3: the particle cloud per filter iteration, then the estimate"),
    FigureJob(
        "scan",
        ("scan", "--map", "map1", "--pose", "20,85,0", "--sonar", "nxt", "--seed", "1", "-o", f"{WORK}/scan_map1.png"),
        {"scan_map1.png": "scan_map1.png"},
        "one 360-degree scan with the LEGO sensor model, as the paper's Fig. 3"),
    FigureJob(
        "real-sonar",
        ("sonar", "plot", "maps/real-nxt", "--heading-prior", "0:20", "--out", f"{WORK}/real-sonar"),
        {"real_sonar_radar.png": "real-sonar/real_sonar_radar.png",
         "real_sonar_no_echo.png": "real-sonar/real_sonar_no_echo.png",
         "real_sonar_places.png": "real-sonar/real_sonar_places.png"},
        "the three shipped real NXT sweeps against the fitted nxt sonar model: radar charts, no-echo curves, "
        "where one sweep puts the robot"),
    FigureJob(
        "planners",
        # defaults: maps map1,map2,map3; planners min-turn, astar, rrtstar, prm, ompl:RRTConnect,
        # ompl:InformedRRTstar, ompl:BITstar; 1 s budget; 100 drives per path; --simplify ompl
        ("bench", "planners", "--runs", "20", "--seed", "0", "--workers", "2", "--out", f"{WORK}/planners"),
        {"planners_paths.png": "planners/paths.png",
         "planners_exec_vs_turns.png": "planners/exec_vs_turns.png",
         "planners_exec_error.png": "planners/boxplot_exec_error.png",
         "planners_time.png": "planners/boxplot_time.png",
         "planners_length_ratio.png": "planners/boxplot_length_ratio.png",
         "planners_cost_over_time.png": "planners/cost_over_time.png"},
        "the default planners on the preset queries: paths, execution error against turns (raw and "
        "simplified), box plots, best length over time",
        {"--runs": "1", "--time-limit": "0.05", "--exec-repeats": "5", "--workers": "1", "--maps": "map1"}),
    FigureJob(
        "budgets",
        ("bench", "planners", "--budgets", "0.02,0.05,0.1,0.2,0.5,1", "--runs", "10", "--seed", "0",
         "--exec-repeats", "50", "--workers", "2", "--out", f"{WORK}/budgets"),
        {"planners_budget_sweep.png": "budgets/budget_sweep.png"},
        "what a planning budget buys: length over the shortest, turns and execution error, raw and simplified",
        {"--runs": "1", "--budgets": "0.02,0.05", "--exec-repeats": "2", "--workers": "1", "--maps": "map1",
         "--planners": "min-turn,rrtstar,ompl:RRTConnect"}),
    FigureJob(
        "objectives",
        # defaults: planners rrtstar, ompl:InformedRRTstar, ompl:BITstar, astar, min-turn; 1 s budget;
        # 100 drives per path
        ("bench", "objectives", "--maps", "map1,map2,map3,pillars", "--runs", "20", "--seed", "0", "--workers", "2",
         "--out", f"{WORK}/objectives"),
        {f"objectives_pareto_{m}.png": f"objectives/pareto_{m}.png" for m in ("map1", "map2", "map3", "pillars")}
        | {"objectives_cost_over_time.png": "objectives/cost_over_time.png"},
        "every planner under every objective it can minimise: robot time against open-loop error per map, and "
        "the best robot time over the least against planning time under robot-time",
        {"--runs": "1", "--time-limit": "0.05", "--exec-repeats": "1", "--workers": "1",
         "--planners": "astar,min-turn,rrtstar"}),
    FigureJob(
        "localisers",
        ("bench", "localisers", "--localisers", "paper-pf,amcl,pf-systematic,ekf,ukf", "--trials", "20",
         "--scenario", "all", "--seed", "0", "--workers", "2", "--out", f"{WORK}/localisers"),
        {"localisers_success.png": "localisers/success.png",
         "localisers_kidnapped.png": "localisers/kidnapped.png",
         "localisers_errors.png": "localisers/errors.png",
         "localisers_tracking.png": "localisers/tracking.png"},
        "the localiser benchmark: success, kidnap recovery, error distributions, tracking error",
        {"--trials": "1", "--workers": "1", "--tracking-steps": "3", "--maps": "map1"}),
    FigureJob(
        "replay",
        ("replay", f"{REPO}/tests/data/recording_map1_nxt.jsonl", "--localisers", "paper-pf,amcl,pf-systematic",
         "-o", f"{WORK}/replay_amcl.png"),
        {"replay_amcl.png": "replay_amcl.png"},
        "amcl against paper-pf and pf-systematic on the same recorded readings (NXT sonar model, map1)"),
    FigureJob(
        "paper",
        ("paper", "--trials", "20", "--noise-model", "botsim", "--seed", "0", "--workers", "2",
         "--plot", f"{WORK}/paper_table1.png"),
        {"paper_table1.png": "paper_table1.png"},
        "the paper's Table I as a plot: final error and driven length per map beside the paper's means",
        {"--trials": "2", "--workers": "1", "--maps": "map1"}),
    FigureJob(
        "pareto",
        ("paper", "--pareto", f"{WORK}/pareto.png", "--trials", "3", "--seed", "0", "--workers", "2"),
        {"pareto.png": "pareto.png"},
        "mean final error against median robot time for every mission setting, both sonar models, per map",
        {"--trials": "1", "--workers": "1", "--maps": "map1"}),
    FigureJob(
        "arena2",
        ("maps", "show", "arena2", "--radius", "2", "-o", f"{WORK}/map_arena2.png"),
        {"map_arena2.png": "map_arena2.png"},
        "the Moving AI map arena2 imported exactly: free cells as polygons, c-space of a 2 cm disc"),
    FigureJob(
        "depot",
        ("maps", "show", "depot", "-o", f"{WORK}/map_depot.png"),
        {"map_depot.png": "map_depot.png"},
        "the nav2 depot (a ROS map_server map) imported"),
    FigureJob(
        "scen",
        # arena2.map.scen, last query (line 911): octile optimum 362.05 cells
        ("plan", "--map", "arena2", "--planner", "astar", "--radius", "0", "--start", "5.5,96.5",
         "--goal", "275.5,27.5", "--exec-repeats", "0", "-o", f"{WORK}/scen_arena2.png"),
        {"scen_arena2.png": "scen_arena2.png"},
        "grid A* on arena2's own cells (octile) against the any-angle shortest path (dashed), point robot"),
)


SCREENSHOTS: dict[str, str] = {
    "plannerarena_progress.png": "Planner Arena (OMPL's viewer, a separate web app: `pip install plannerarena`) "
    "showing the progress view of `ompl_benchmark_statistics out/planners/ompl/map2-presets.log -d benchmark.db` "
    "(best cost against time of the anytime planners); a screenshot of a local server, not made by "
    "`nxtnav figures`",
    "rerun-view.png": "Rerun's web viewer (the `rerun` program of rerun-sdk) showing a mission saved with "
    "`nxtnav run --view-save out/view-check.rrd`; taken in headless Chromium by `make view-check`",
}
"""Images in the figure folder that no `FigureJob` makes (screenshots of other programs), with how
each was taken; `nxtnav figures` leaves them alone."""


def figure_names() -> list[str]:
    """Every figure file `FIGURE_JOBS` writes."""
    return [f for job in FIGURE_JOBS for f in job.figures]
