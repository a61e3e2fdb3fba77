"""Data taken elsewhere, as recordings that `nxtnav replay` scores like any run.

`import_sweep_set` writes a sweep set (`toolkit.real_sonar.sweeps`: real sweeps at known waypoints) as one
``nxtnav-recording`` (``docs/recording.md``) in which each sweep is a global-localisation episode:

* a ``scan`` (the sweep as a `Scan`: no-echo readings kept as invalid 255s, among them the repeats
  of a held echo where the source says so, ``held_runs``; no robot clock, so
  ``t_start`` and ``t`` are null; ``label`` is ``repo/file``) whose ``true_pose`` is the waypoint with
  a null heading, since the heading of a real sweep was not measured;
* a ``reset`` with a null prior (the localiser forgets everything: global localisation);
* an ``update`` with every reading of that scan.

There is no live localiser and so no ``estimate`` line: the recording holds the data, and
``nxtnav replay REC --localisers A,B`` runs any localisers over it and scores the position of their
estimate after each sweep.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from ..real_sonar.sweeps import Sweep, SweepSet
from ..world import NO_ECHO
from .recorder import Recorder

__all__ = ["SweepImport", "import_sweep_set"]


@dataclass(frozen=True)
class SweepImport:
    """What `import_sweep_set` wrote.

    Attributes
    ----------
    folder : str
        The sweep set.
    map : str
        Name of its map (written in full in the recording's header).
    episodes : int
        Sweeps written, one global-localisation episode each.
    readings : int
        Readings written (all sweeps).
    no_echo : int
        Of those, the no-echo readings (kept as invalid readings of 255 cm).
    held_no_echo : int
        Of those, the repeats of a held echo read as no echo (`toolkit.real_sonar.sweeps`, ``held_runs`` ``no-echo``).
    lines : int
        Lines of the recording.
    """

    folder: str
    map: str
    episodes: int
    readings: int
    no_echo: int
    lines: int
    held_no_echo: int = 0

    def to_dict(self) -> dict[str, Any]:
        return {"folder": self.folder, "map": self.map, "episodes": self.episodes, "readings": self.readings,
                "no_echo": self.no_echo, "held_no_echo": self.held_no_echo, "lines": self.lines}


def _provenance(s: Sweep) -> dict[str, Any]:
    """Where a sweep comes from and how it was taken (not its aligned heading: that is not a measurement)."""
    d = {k: v for k, v in s.to_dict().items() if k != "heading_deg"}
    return {"label": s.label, **d, **{k: v for k, v in s.extra.items() if k in ("commit", "licence")}}


def import_sweep_set(sweeps: SweepSet, out: str | Path | IO[str]) -> SweepImport:
    """Write `sweeps` to `out` (a path or a text stream) as a recording of global-localisation episodes
    (module docstring). The header's ``source`` lists the sweeps with their provenance."""
    source = {"kind": "sweep-set", "folder": str(sweeps.folder), "sweeps": [_provenance(s) for s in sweeps]}
    rec = Recorder(out, map=sweeps.map, robot={"kind": "nxt", "imported": "sweep-set"}, sonar={"model": "nxt"},
                   seed=None, extra={"source": source})
    readings = no_echo = 0
    try:
        for s in sweeps:
            scan = s.scan()
            rec.known_scan(scan, (s.x_cm, s.y_cm), heading=None, label=s.label)
            rec.reset_event(None)
            rec.update_event(scan)
            readings += len(scan)
            no_echo += int(np.sum(~scan.valid & (scan.ranges == NO_ECHO)))
    except BaseException:
        rec.close(end=False)
        raise
    rec.close("imported", None)
    return SweepImport(str(sweeps.folder), sweeps.map.name, len(sweeps), readings, no_echo, rec.lines,
                       sum(s.held_count for s in sweeps))
