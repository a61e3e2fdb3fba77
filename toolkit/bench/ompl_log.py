"""Writing OMPL's benchmark log format, so that ``ompl_benchmark_statistics`` and Planner Arena read our results.

The format is the one of OMPL's ``doc/markdown/benchmark.md`` ("The benchmark logfile format"): a
preamble (version, experiment name, optional experiment properties, host, date, setup, random seed,
limits, run count, total time, enum types, planner count) followed, per planner, by its common
properties, the names and types of its per-run properties, one line per run (values each followed by
``"; "``), optionally its progress properties (values sampled during each run: ``time`` and, e.g.,
``best cost``; one line per run, each sample's values followed by ``","`` and each sample by
``";"``) and a closing ``"."``. One log file holds one experiment; ``ompl_benchmark_statistics``
reads several files into one database.

The log is written from our own results (not with ``ompl.tools.Benchmark``, which drops properties
set from Python and stops at the first Python exception).
"""

from __future__ import annotations

import math
import re
import socket
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, Field, StringConstraints, model_validator

from planners import PlanStatus
from toolkit.world import ConfigError
from toolkit.world.typed import typed_dataclass

__all__ = [
    "OMPL_STATUS",
    "OmplExperiment",
    "OmplPlannerData",
    "format_ompl_log",
    "ompl_status",
    "write_ompl_log",
]

#: OMPL's `ompl::base::PlannerStatus` values, in enum order (the ``status`` enum of OMPL's logs).
OMPL_STATUS = (
    "Unknown status",
    "Invalid start",
    "Invalid goal",
    "Unrecognized goal type",
    "Timeout",
    "Approximate solution",
    "Exact solution",
    "Crash",
    "Abort",
    "Infeasible",
)

_TYPES = ("REAL", "INTEGER", "BOOLEAN", "ENUM", "VARCHAR(512)")
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_ ]*$")


def _one_of(kinds: tuple[str, ...]) -> AfterValidator:
    """A check that a type name is one of `kinds`."""
    def check(kind: str) -> str:
        if kind not in kinds:
            raise ValueError(f"must be one of {', '.join(kinds)}")
        return kind
    return AfterValidator(check)


PropertyType = Annotated[str, _one_of(_TYPES)]
"""The types of a property OMPL's parser knows."""
ProgressType = Annotated[str, _one_of(_TYPES[:3])]
"""The types a progress property may have (numbers: the database plots them)."""
PropertyName = Annotated[str, StringConstraints(pattern=_NAME_RE.pattern)]
"""A property's name: letters, digits, spaces and underscores (it becomes a database column)."""


_OMPL_LABEL = {
    PlanStatus.EXACT: "Exact solution",
    PlanStatus.APPROXIMATE: "Approximate solution",
    PlanStatus.TIMEOUT: "Timeout",
    PlanStatus.NO_PATH: "Infeasible",
    PlanStatus.UNREACHABLE: "Infeasible",
    PlanStatus.START_IN_COLLISION: "Invalid start",
    PlanStatus.GOAL_IN_COLLISION: "Invalid goal",
    PlanStatus.ERROR: "Crash",
}


def ompl_status(success: bool, status: PlanStatus) -> int:
    """The OMPL status enum value for one of our results (`PlanResult.success`, `.status`)."""
    if success:
        return OMPL_STATUS.index("Exact solution")
    return OMPL_STATUS.index(_OMPL_LABEL.get(status, "Unknown status"))


@typed_dataclass()
class OmplPlannerData:
    """One planner's block of an OMPL log.

    Parameters
    ----------
    name : str
        Planner (configuration) name; no line breaks.
    properties : sequence of (name, type)
        Per-run property names (letters, digits, spaces, underscores) and their types
        (``REAL``, ``INTEGER``, ``BOOLEAN``, ``ENUM`` or ``VARCHAR(512)``).
    runs : sequence of sequences
        One row of values per run, in `properties` order; None or NaN are written empty.
    common : dict
        Planner settings written as its common properties (``name = value``).
    progress_properties : sequence of (name, type)
        Properties sampled during a run (``time`` among them: the database keys samples by run and
        time); empty when the planner reports none.
    progress : sequence of sequences of sequences
        Per run (in `runs` order), its samples, each a row of values in `progress_properties` order.
    """

    name: Annotated[str, StringConstraints(pattern=r"^[^\n]+$")]
    properties: Sequence[tuple[PropertyName, PropertyType]]
    runs: Sequence[Sequence[Any]]
    common: dict[str, Any] = Field(default_factory=dict)
    progress_properties: Sequence[tuple[PropertyName, ProgressType]] = ()
    progress: Sequence[Sequence[Sequence[Any]]] = ()

    @model_validator(mode="after")
    def _rows_fit(self) -> OmplPlannerData:
        for i, row in enumerate(self.runs):
            if len(row) != len(self.properties):
                raise ValueError(f"planner {self.name!r} run {i}: {len(row)} values for "
                                 f"{len(self.properties)} properties")
        if not self.progress_properties:
            if self.progress:
                raise ValueError(f"planner {self.name!r}: progress samples without progress properties")
            return self
        names = [pname for pname, _ in self.progress_properties]
        if "time" not in names:
            raise ValueError(f"planner {self.name!r}: the progress properties need a 'time', got {names}")
        if len(self.progress) != len(self.runs):
            raise ValueError(f"planner {self.name!r}: progress for {len(self.progress)} runs, {len(self.runs)} runs")
        for i, samples in enumerate(self.progress):
            if any(len(sample) != len(names) for sample in samples):
                raise ValueError(f"planner {self.name!r} run {i}: a progress sample of other than {len(names)} "
                                 "values (one per progress property)")
        return self


@dataclass(frozen=True)
class OmplExperiment:
    """One OMPL experiment (one log file).

    Parameters
    ----------
    name : str
        Experiment name: one word (``ompl_benchmark_statistics`` keeps only the last word of the line;
        runs of whitespace become underscores).
    planners : sequence of OmplPlannerData
        The planner blocks.
    time_limit_s : float
        Planning budget per run (s).
    total_time_s : float
        Wall-clock time spent on the whole experiment (s).
    seed : int
        The experiment's random seed.
    run_count : int
        Runs per planner.
    setup : str
        Multi-line description of the problem (map, queries, robot, noise).
    properties : dict
        Experiment properties ``name -> (type, value)``; names become database columns.
    enums : dict
        Enum types ``name -> labels`` (``status`` with OMPL's labels is always included).
    memory_limit_mb : float
        Memory limit per run (MB); informative only.
    library, version : str
        The version line (``nxtnav version 0.1.0``).
    date : datetime or None
        Start of the experiment (default: now).
    hostname : str or None
        Host name (default: this machine's).
    cpuinfo : str or None
        Optional multi-line CPU description.
    """

    name: str
    planners: Sequence[OmplPlannerData]
    time_limit_s: float
    total_time_s: float
    seed: int = 0
    run_count: int = 0
    setup: str = ""
    properties: dict[str, tuple[str, Any]] = field(default_factory=dict)
    enums: dict[str, Sequence[str]] = field(default_factory=dict)
    memory_limit_mb: float = 0.0
    library: str = "nxtnav"
    version: str = "0.1.0"
    date: datetime | None = None
    hostname: str | None = None
    cpuinfo: str | None = None


def _value(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, float):
        if math.isnan(v) or math.isinf(v):
            return ""
        return repr(v)
    if hasattr(v, "item"):  # numpy scalars
        return _value(v.item())
    text = str(v)
    if ";" in text or "\n" in text:
        raise ConfigError(f"value {text!r} may not contain ';' or a line break")
    return text


def _sample_value(v: Any) -> str:
    text = _value(v)
    if "," in text:
        raise ConfigError(f"progress value {text!r} may not contain ','")
    return text


def _one_token(text: str, what: str) -> str:
    token = re.sub(r"\s+", "_", text.strip()) or "unknown"
    if not re.match(r"^[A-Za-z0-9_.:\-]+$", token):
        raise ConfigError(f"{what} {text!r} must be a single word")
    return token


def _multiline(text: str) -> list[str]:
    lines = [ln for ln in text.splitlines() if not ln.startswith("|>>>")]
    return ["<<<|", *lines, "|>>>"]


def format_ompl_log(exp: OmplExperiment) -> str:
    """The text of `exp` in OMPL's benchmark log format."""
    lines = [f"{_one_token(exp.library, 'library')} version {_one_token(exp.version, 'version')}",
             f"Experiment {_one_token(exp.name, 'experiment name')}"]
    if exp.properties:
        lines.append(f"{len(exp.properties)} experiment properties")
        for pname, (ptype, pvalue) in exp.properties.items():
            if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", pname):
                raise ConfigError(f"experiment property {pname!r}: use one word of letters, digits, underscores")
            if ptype not in _TYPES:
                raise ConfigError(f"experiment property {pname!r}: type {ptype!r} is not one of {', '.join(_TYPES)}")
            lines.append(f"{pname} {ptype} = {_value(pvalue)}")
    host = exp.hostname if exp.hostname is not None else socket.gethostname()
    lines.append(f"Running on {_one_token(host, 'hostname')}")
    date = exp.date or datetime.now()
    lines.append(f"Starting at {date.strftime('%Y-%m-%d %H:%M:%S')}")
    lines.extend(_multiline(exp.setup))
    if exp.cpuinfo:
        lines.extend(_multiline(exp.cpuinfo))
    lines.append(f"{int(exp.seed)} is the random seed")
    lines.append(f"{float(exp.time_limit_s)!r} seconds per run")
    lines.append(f"{float(exp.memory_limit_mb)!r} MB per run")
    lines.append(f"{int(exp.run_count)} runs per planner")
    lines.append(f"{float(exp.total_time_s)!r} seconds spent to collect the data")
    enums: dict[str, Sequence[str]] = {"status": OMPL_STATUS, **exp.enums}
    lines.append(f"{len(enums)} enum types")
    for ename, labels in enums.items():
        for label in (ename, *labels):
            if "|" in label or "\n" in label:
                raise ConfigError(f"enum {ename!r}: label {label!r} may not contain '|' or a line break")
        lines.append("|".join([ename, *labels]))
    lines.append(f"{len(exp.planners)} planners")
    for p in exp.planners:
        lines.append(p.name)
        lines.append(f"{len(p.common)} common properties")
        lines.extend(f"{k} = {_value(v)}" for k, v in p.common.items())
        lines.append(f"{len(p.properties)} properties for each run")
        lines.extend(f"{pname} {ptype}" for pname, ptype in p.properties)
        lines.append(f"{len(p.runs)} runs")
        lines.extend("".join(f"{_value(v)}; " for v in row) for row in p.runs)
        if p.progress_properties:
            lines.append(f"{len(p.progress_properties)} progress properties for each run")
            lines.extend(f"{pname} {ptype}" for pname, ptype in p.progress_properties)
            lines.append(f"{len(p.progress)} runs")
            lines.extend("".join("".join(f"{_sample_value(v)}," for v in sample) + ";" for sample in samples)
                         for samples in p.progress)
        lines.append(".")
    return "\n".join(lines) + "\n"


def write_ompl_log(path: str | Path, exp: OmplExperiment) -> Path:
    """Write `exp` to `path` (parent folders created) and return the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(format_ompl_log(exp), encoding="utf-8")
    return p
