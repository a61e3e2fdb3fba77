"""How the toolkit writes numbers: one rule for every CSV file and one for every Markdown or console table.

CSV cells are read back by programs (pandas, spreadsheets, `read_csv` of the benchmarks): booleans as
``true``/``false``, floats to a fixed number of significant digits, and a missing value (None, NaN,
an infinity standing for "never") as an empty cell. Table cells are read by people: a missing value
is a dash.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["MISSING", "cell", "csv_cell", "json_safe", "percent"]

MISSING = "–"
"""What a table shows for a value that does not exist (a failed run's time, an empty median)."""


def csv_cell(v: Any, digits: int | None = 10) -> str:
    """One CSV cell. `digits` significant digits for floats (None: as many as make it exact).

    >>> [csv_cell(v) for v in (True, 3, 0.1 + 0.2, float("nan"), None, "rrt*")]
    ['true', '3', '0.3', '', '', 'rrt*']
    >>> csv_cell(0.1 + 0.2, digits=None), csv_cell(123456.789, digits=6)
    ('0.30000000000000004', '123457')
    """
    if v is None:
        return ""
    if isinstance(v, bool | np.bool_):
        return "true" if v else "false"
    if isinstance(v, float):
        if not math.isfinite(v):
            return ""
        return repr(float(v)) if digits is None else f"{v:.{digits}g}"
    return str(v)


def cell(v: float | None, spec: str = ".2f", unit: str = "") -> str:
    """A number in a table, formatted by `spec`, with `unit` appended; `MISSING` when there is none.

    >>> cell(3.14159), cell(2.5, ".1f", " cm"), cell(float("nan")), cell(None)
    ('3.14', '2.5 cm', '–', '–')
    """
    if v is None or not math.isfinite(v):
        return MISSING
    return f"{format(v, spec)}{unit}"


def percent(fraction: float | None, digits: int = 0) -> str:
    """A fraction as a percentage in a table.

    >>> percent(0.995, 1), percent(1.0), percent(float("nan"))
    ('99.5 %', '100 %', '–')
    """
    return cell(None if fraction is None else 100.0 * fraction, f".{digits}f", " %")



def json_safe(obj: Any) -> Any:
    """`obj` (dicts, lists and tuples of values) with every NaN or infinite float replaced by None, so that
    it is strict JSON (``json.dumps(..., allow_nan=False)``): a value that does not exist is ``null``.

    >>> json_safe({"a": [1.5, float("nan")], "b": (float("-inf"), "x")})
    {'a': [1.5, None], 'b': [None, 'x']}
    """
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    return obj
