"""Execute the comparison notebooks and check that they drew their tables and figures.

Each runs every cell at its quick size (``NXTNAV_NOTEBOOK_QUICK=1``: fewer trials, seeds and runs, as
the notebook's first code cell says); the site's build runs them at the size they show. Set
``NXTNAV_SAVE_EXECUTED=DIR`` to keep the executed notebooks (with outputs) in DIR.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import nbclient
import nbformat
import pytest

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"

# notebook -> (Markdown fragments its outputs must contain, minimum number of figures)
EXPECTED: dict[str, tuple[tuple[str, ...], int]] = {
    "planner_comparison": (("## map1", "## map2", "## map3", "| min-turn |", "| map1 | min-turn | turns |"), 4),
    "localisation_comparison": (("| processed (kept) |", "| auto | raw |", "| off | paper |", "| map3 | paper-pf |",
                                 "RMSE", "recovered", "| nxt, amcl live | paper-pf |",
                                 "| bit for bit |", "| amcl | 0 +- 20 deg |"), 5),
    "paper_reproduction": (("| map1 |", "| map3 |", "| paper-habit | ideal |"), 4),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_notebook_runs_and_shows_its_results(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("NXTNAV_NOTEBOOK_QUICK", "1")  # the kernel inherits it
    path = NOTEBOOKS / f"{name}.ipynb"
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOKS)}})
    client.execute()
    if os.environ.get("NXTNAV_SAVE_EXECUTED"):
        out = Path(os.environ["NXTNAV_SAVE_EXECUTED"])
        out.mkdir(parents=True, exist_ok=True)
        nbformat.write(nb, out / path.name)
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    errors = [o for o in outputs if o.get("output_type") == "error"]
    assert not errors, errors[0].get("evalue") if errors else ""
    text = "".join(o.get("data", {}).get("text/markdown", "") for o in outputs)
    needles, min_images = EXPECTED[name]
    for needle in needles:
        assert needle in text, needle
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= min_images
    # the site shows these outputs: no folder of the machine that built it
    shown = "".join(o.get("text", "") + o.get("data", {}).get("text/plain", "") for o in outputs) + text
    for machine_path in {tempfile.gettempdir(), str(NOTEBOOKS.parent), str(Path.home())} - {"/", ""}:
        assert machine_path not in shown, f"{name} prints {machine_path}"
