"""`nxtnav replay` never shows a large error without its reason: the user's path (import the shipped sweeps,
replay them; record a simulated run, replay it) through the real command in a folder outside the repository.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
from pathlib import Path
from typing import Any

from conftest import kept_run, nxtnav_exe

from localisation.ambiguity import CANDIDATE_RADIUS_CM

VERDICT_FIELDS = ("converged", "ambiguous", "candidates", "candidates_text", "truth_in_candidates",
                  "confidently_wrong", "reason")


def _ran_cleanly(proc: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc


def _nxtnav(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return _ran_cleanly(subprocess.run([nxtnav_exe(), *args], cwd=cwd, capture_output=True, text=True, timeout=600))


def _summary_line(stdout: str, name: str) -> re.Match[str]:
    found = re.search(rf"^{re.escape(name)}: (\d+) updates with a true pose, (\d+) within 10 cm, (\d+) ambiguous "
                      r"with the truth among the candidates, (\d+) confidently wrong$", stdout, re.MULTILINE)
    assert found is not None, stdout
    return found


def _judged(doc: dict[str, Any]) -> list[tuple[dict[str, Any], str, dict[str, Any]]]:
    """(step, localiser, estimate) of every update with a true pose and an estimate."""
    return [(s, n, e) for s in doc["steps"] if s["call"] == "update" and s["truth"] is not None
            for n, e in s["estimates"].items() if e is not None]


def test_replay_of_the_shipped_sweeps_says_why_each_large_error(shipped_sweeps_replayed: Path) -> None:
    """The trial's commands: every update more than 20 cm off gets one line with its reason, the JSON carries
    the verdict of every estimate, and the summary lines count what the JSON holds. The two commands,
    ``nxtnav import sweeps maps/real-nxt -o real.jsonl`` and ``nxtnav replay real.jsonl --localisers
    paper-pf,amcl --json replay.json``, run once for this test and test_stuck_runs.py (conftest)."""
    folder = shipped_sweeps_replayed
    _ran_cleanly(kept_run(folder, "import"))
    proc = _ran_cleanly(kept_run(folder, "replay"))
    doc = json.loads((folder / "replay.json").read_text())
    judged = _judged(doc)
    large = [(s, n, e) for s, n, e in judged if e["error_cm"] > CANDIDATE_RADIUS_CM]
    assert large, "no large error to explain: the test would prove nothing"
    explained = [ln for ln in proc.stdout.splitlines() if " cm off: " in ln]
    assert len(explained) == len(large), proc.stdout
    for step, name, est in judged:
        assert all(k in est for k in VERDICT_FIELDS), est
        truth = step["truth"]
        near = any(math.hypot(c[0] - truth[0], c[1] - truth[1]) <= CANDIDATE_RADIUS_CM for c in est["candidates"])
        assert est["truth_in_candidates"] == near
        assert est["ambiguous"] == (len(est["candidates"]) > 1)
        if est["error_cm"] <= CANDIDATE_RADIUS_CM:
            assert est["reason"] is None
            continue
        line = f"step {step['index']} (line {step['line']}, {step['label']}): {name} {est['error_cm']:.1f} cm off: "
        assert line + est["reason"] in explained, proc.stdout
        if est["ambiguous"]:
            among = "among" if near else "not among"
            assert est["reason"] == f"{est['candidates_text']}, the truth {among} them"
        elif not est["converged"]:
            assert est["reason"] == f"not converged (spread {est['spread_cm']:.1f} cm)"
        else:
            assert est["confidently_wrong"] and est["reason"].startswith("confidently wrong")
    for name in ("paper-pf", "amcl"):
        mine = [e for _, n, e in judged if n == name]
        counts = [int(g) for g in _summary_line(proc.stdout, name).groups()]
        assert counts == [len(mine), sum(e["error_cm"] <= 10.0 for e in mine),
                          sum(e["ambiguous"] and e["truth_in_candidates"] for e in mine),
                          sum(e["confidently_wrong"] for e in mine)]
        assert doc["summary"][name]["judged_updates"] == counts[0]


def test_replay_of_an_accurate_simulated_run_explains_nothing(tmp_path: Path) -> None:
    """A simulated run whose every estimate is near the truth: no reason line, every update within 10 cm."""
    _nxtnav("run", "--map", "map1", "--localiser", "amcl", "--record", "run.jsonl", cwd=tmp_path)
    proc = _nxtnav("replay", "run.jsonl", "--localisers", "amcl,paper-pf", "--json", "replay.json", cwd=tmp_path)
    doc = json.loads((tmp_path / "replay.json").read_text())
    judged = _judged(doc)
    assert judged and all(e["error_cm"] <= CANDIDATE_RADIUS_CM for _, _, e in judged)  # the premise
    assert not [ln for ln in proc.stdout.splitlines() if " cm off: " in ln], proc.stdout
    assert all(e["reason"] is None for _, _, e in judged)
    for name in ("amcl", "paper-pf"):
        n, within, _, wrong = (int(g) for g in _summary_line(proc.stdout, name).groups())
        assert n == sum(1 for _, m, _ in judged if m == name) == within and wrong == 0
