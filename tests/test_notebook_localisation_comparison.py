"""Execute notebooks/localisation_comparison.ipynb (small runs of the localiser benchmark, with plots)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "localisation_comparison.ipynb"


@pytest.mark.slow
def test_localisation_comparison_notebook_runs() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})
    client.execute()
    if os.environ.get("NXTNAV_SAVE_EXECUTED"):
        nbformat.write(nb, os.environ["NXTNAV_SAVE_EXECUTED"])
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("data", {}).get("text/markdown", "") for o in outputs)
    for needle in ("| processed (kept) |", "| auto | raw |", "| off | paper |", "| map3 | paper-pf |", "RMSE",
                   "recovered"):
        assert needle in text, needle
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 4  # clouds, radar, errors and times, tracking
