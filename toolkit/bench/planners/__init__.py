"""The planner benchmark: every planner on every map and query, the same checks, honest numbers.

A benchmark is a set of tasks ``(map, planner, run, seed, start, goal)``. The start and goal of run
``r`` on a map are the map's presets (``queries="presets"``) or a random pair of free positions drawn
from the run's seed (``queries="random"``); every planner gets the same query for the same run. The
exact references (`shortest` for the length ratio, `min-link` for the turn ratio) are computed once
per query. Each run records the planner's result, the path metrics of `planners.metrics` and the
execution error of `toolkit.bench.execution` (the path driven open-loop under motion noise).

Seeds: the seed of run ``r`` on map ``m`` is derived from the benchmark seed, the map name and ``r``
with `numpy.random.SeedSequence`; it is shared by the planners (common random numbers: the same
query and the same motion noise for every planner in a run) and split into independent streams for
planning, execution and query sampling. Same seed, same results, on every executor.

Anytime planners (OMPL's) report their best cost over time (`planners.ompl_planners`): every run
records its first solution (time and length) and, where the planner reports them, best-cost samples
at every improvement and every ``progress_interval`` of budget. Every successful path is then
simplified (``simplify``: ``none``, ``shortcut`` or ``ompl``, see `.simplify`) and measured and
driven again, so each run has raw and simplified metrics.

Outputs (`write_results`): ``runs.csv``, ``progress.csv`` (the best-cost samples), ``paths.jsonl``,
``references.csv``, ``summary.md``, box plots ``boxplot_<metric>.png``, ``exec_vs_turns.png``
(execution error against turns, raw and simplified), ``paths.png`` (run 0 of every planner on every
map), ``cost_over_time.png`` (best length over `shortest` against time), ``benchmark.log`` (OMPL's
log format: one experiment with every run, the map as an enum run property, the best-cost samples as
progress properties) and ``ompl/<map>-<queries>.log`` (one OMPL experiment per map and query set,
for Planner Arena), and ``config.json``. A budget sweep (`.budgets`) runs the benchmark at several
budgets and reports what each buys.
"""

from __future__ import annotations

from .anytime import WITHIN, cost_band, reference_lengths, time_within
from .budgets import BudgetSweep, check_budgets, format_budget_sweep, run_budget_sweep, within_rows, write_budget_sweep
from .records import (
    LARGE_MAP_WALLS,
    PROGRESS_COLUMNS,
    REFERENCE_PLANNERS,
    REFERENCE_TIME_LIMIT_S,
    RUN_COLUMNS,
    BenchmarkConfig,
    BenchmarkResult,
    Query,
    ReferenceResult,
    ReferenceTask,
    RunRecord,
    RunTask,
)
from .report import check_out_dir, format_summary, summarise, turns_error_correlation, write_results
from .runner import (
    check_objectives,
    check_planner_names,
    known_planners,
    make_queries,
    planner_for,
    run_benchmark,
    run_reference,
    run_task,
)
from .simplify import SIMPLIFY_METHODS, shortcut_path, simplify_path

__all__ = [
    "LARGE_MAP_WALLS",
    "PROGRESS_COLUMNS",
    "REFERENCE_PLANNERS",
    "REFERENCE_TIME_LIMIT_S",
    "RUN_COLUMNS",
    "SIMPLIFY_METHODS",
    "WITHIN",
    "BenchmarkConfig",
    "BenchmarkResult",
    "BudgetSweep",
    "Query",
    "ReferenceResult",
    "ReferenceTask",
    "RunRecord",
    "RunTask",
    "check_budgets",
    "check_objectives",
    "check_out_dir",
    "check_planner_names",
    "cost_band",
    "format_budget_sweep",
    "format_summary",
    "known_planners",
    "make_queries",
    "planner_for",
    "reference_lengths",
    "run_benchmark",
    "run_budget_sweep",
    "run_reference",
    "run_task",
    "shortcut_path",
    "simplify_path",
    "summarise",
    "time_within",
    "turns_error_correlation",
    "within_rows",
    "write_budget_sweep",
    "write_results",
]
