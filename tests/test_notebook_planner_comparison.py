"""Execute notebooks/planner_comparison.ipynb (a small planner benchmark, its plots, error vs turns)."""

from __future__ import annotations

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "planner_comparison.ipynb"


@pytest.mark.slow
def test_planner_comparison_notebook_runs() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("data", {}).get("text/markdown", "") for o in outputs)
    for m in ("## map1", "## map2", "## map3"):
        assert m in text
    assert "| min-turn |" in text
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 4
