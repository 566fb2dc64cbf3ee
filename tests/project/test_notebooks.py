"""The notebooks of docs/notebooks/ run from a clean kernel and each shows an image; they
are stored without outputs (the images exist only in an executed copy).

Evidence: each notebook is executed by nbclient in a fresh kernel of this interpreter, as
a reader would run it; a cell that raises fails the test, and so do the notebooks' own
checks (page 1: the port against the original's ``expected.png``, byte for byte, where the
original's files are present; page 3: the bumped normals read back from the BSDF are unit
vectors). The test adds that at least one image reaches the notebook's output. A notebook
that calls an API that has changed therefore fails here.
"""

from __future__ import annotations

import re
import sys
import time
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from support import ROOT

NOTEBOOKS = sorted((ROOT / "docs" / "notebooks").glob("*.ipynb"))
#: Seconds per cell before the notebook counts as hung (each notebook takes well under a
#: minute on 2 cores).
CELL_TIMEOUT = 300


def _id(path):
    return path.stem


def test_the_tutorial_pages_and_an_own_scene_have_notebooks_in_the_site():
    names = {p.stem for p in NOTEBOOKS}
    assert {"page1", "page2", "page3", "page4", "own_scene"} <= names
    nav = (ROOT / "docs" / "mkdocs.yml").read_text(encoding="utf-8")
    for path in NOTEBOOKS:
        assert f"docs/notebooks/{path.name}" in nav, f"{path.name} is not in the site's nav"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_id)
def test_notebook_is_stored_without_outputs(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code
    assert all(c.outputs == [] and c.execution_count is None for c in code), \
        f"{path.name} has outputs: clear them before committing"
    assert nb.metadata.get("kernelspec", {}).get("name") == "python3"
    assert nb.cells[0].cell_type == "markdown" and re.match(r"# \S", nb.cells[0].source)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_id)
def test_notebook_executes_and_shows_an_image(path, monkeypatch):
    # the kernel is this interpreter's (the .venv with the package), whatever kernels the
    # user's Jupyter folders hold
    monkeypatch.setenv("JUPYTER_PATH", str(Path(sys.prefix) / "share" / "jupyter"))
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=CELL_TIMEOUT, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}})
    km = client.create_kernel_manager()
    assert km.format_kernel_cmd()[0] == sys.executable
    t0 = time.perf_counter()
    client.execute()                    # raises CellExecutionError naming the failing cell
    seconds = time.perf_counter() - t0
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs
              if "image/png" in o.get("data", {})]
    assert images, f"{path.name} shows no image"
    print(f"{path.name}: {seconds:.1f} s, {len(images)} images")
