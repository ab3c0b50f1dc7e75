"""The notebooks: stored without outputs, small sample counts in their first cell, linked from the
README, and executed top to bottom (each must finish; the claims in their text are asserted in
their cells, so a changed number fails here)."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
EXPECTED = ["01_quickstart", "02_waveforms_and_phases", "03_noise_and_sbi", "04_calibration",
            "05_gradient_studies", "06_explorer", "07_validation", "08_full_frame", "09_camera_in_time",
            "10_robot_simulator"]


def _read(path):
    import nbformat  # at first use: it imports jsonschema's format checkers (2 s), which collection need not wait for

    return nbformat.read(path, as_version=4)


def test_the_ten_notebooks_exist():
    assert [p.stem for p in NOTEBOOKS] == EXPECTED


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_stored_without_outputs(path):
    import nbformat

    nb = _read(path)
    nbformat.validate(nb)
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, (
                f"{path.name} cell {i} has outputs: strip them (e.g. `nbstripout {path.relative_to(ROOT)}`)")
    assert "widgets" not in nb.metadata, f"{path.name} stores widget state: strip it"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_first_code_cell_sets_small_sample_counts(path):
    first = next(c for c in _read(path).cells if c.cell_type == "code")
    tree = ast.parse(first.source)
    assert tree.body, f"{path.name}: the first code cell is empty"
    for node in tree.body:
        assert isinstance(node, ast.Assign) and len(node.targets) == 1, f"{path.name}: only assignments"
        name, value = node.targets[0], node.value
        assert isinstance(name, ast.Name) and name.id.isupper(), f"{path.name}: upper-case names only"
        assert isinstance(value, ast.Constant) and isinstance(value.value, int), f"{path.name}: integer counts"
        assert 1 <= value.value <= 5000, f"{path.name}: {name.id} = {value.value} is not a small count"


def test_readme_links_every_notebook_with_one_line():
    readme = (ROOT / "README.md").read_text()
    for path in NOTEBOOKS:
        lines = [line for line in readme.splitlines() if f"notebooks/{path.name}" in line]
        assert len(lines) == 1, f"README should link {path.name} on exactly one line"
        assert re.search(r"\]\(notebooks/" + re.escape(path.name) + r"\)", lines[0])


def test_the_explorer_notebook_prints_text_not_its_widgets_html():
    """Voila shows a cell's printed output as text: printing an HTML widget's value showed
    ``<span style=...>`` and ``&#x27;`` (the explorer's ``message_text`` and ``summary_text`` are the text)."""
    source = "\n".join(c.source for c in _read(ROOT / "notebooks" / "06_explorer.ipynb").cells if c.cell_type == "code")
    assert "message_text" in source and not re.search(r"print\([^)]*\.(message|summary)\.value", source)


@pytest.fixture(scope="module")
def kernel():
    """One kernel for the notebooks, started once: each notebook starts from an empty namespace
    (``%reset``, figures closed, its own folder as the working directory) but shares the imports
    and the compiled programs, which are most of a notebook's time in a fresh kernel (the eight, cold,
    on a 2-core machine: 190 s in eight kernels, about 150 s in one)."""
    from jupyter_client.manager import KernelManager

    km = KernelManager(kernel_name="python3")
    km.start_kernel(cwd=str(ROOT / "notebooks"))
    yield km
    km.shutdown_kernel(now=True)


#: Run before each notebook in the shared kernel: an empty namespace, figures closed, its own folder, and
#: what the notebooks before it left (compiled programs) moved out of the garbage collector's way, as
#: tests/conftest.py does after each test.
_FRESH = """get_ipython().run_line_magic("reset", "-f")
import gc as _gc
import os as _os
import matplotlib.pyplot as _plt
_plt.close("all")
_os.chdir({folder!r})
_gc.collect(1)
_gc.freeze()
del _gc, _os, _plt"""


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_executes_top_to_bottom(path, kernel):
    import nbformat
    from nbclient import NotebookClient

    nb = _read(path)
    nb.cells.insert(0, nbformat.v4.new_code_cell(_FRESH.format(folder=str(path.parent))))
    client = NotebookClient(nb, km=kernel, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}})
    try:
        client.execute()  # raises CellExecutionError with the failing cell and its traceback
    finally:
        if client.kc is not None:
            client.kc.stop_channels()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
