"""The code's structure (docs/model.md, "Architecture"): the packages' imports form no cycle, point one
way (fitting and measurements use tofjax; tofjax uses neither), and the siblings use tofjax's public
surface only. Read from the sources (every import, also those inside functions and under
``TYPE_CHECKING``), so nothing is imported and nothing compiled."""

import ast
from pathlib import Path

ROOT = Path(__file__).parents[1]
PACKAGES = ("tofjax", "fitting", "measurements")


def _imports() -> dict[str, set[str]]:
    """Module -> the modules of the three packages it imports (anywhere in its text)."""
    found = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).glob("*.py")):
            module = pkg if path.stem == "__init__" else f"{pkg}.{path.stem}"
            names = set()
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.ImportFrom):
                    base = (pkg + (f".{node.module}" if node.module else "")) if node.level else node.module
                    names.add(base)
                    names.update(f"{base}.{a.name}" for a in node.names)
                elif isinstance(node, ast.Import):
                    names.update(a.name for a in node.names)
            found[module] = names
    return {m: {n for n in names if n in found and n != m} for m, names in found.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    state, stack, cycles = {}, [], []

    def visit(u):
        state[u] = "open"
        stack.append(u)
        for v in sorted(graph[u]):
            if state.get(v) == "open":
                cycles.append([*stack[stack.index(v):], v])
            elif v not in state:
                visit(v)
        stack.pop()
        state[u] = "done"

    for u in sorted(graph):
        if u not in state:
            visit(u)
    return cycles


def test_the_modules_import_no_cycle_and_the_packages_point_one_way():
    # The packages' __init__ only re-export names lazily (PEP 562): an edge into one is not a cycle.
    graph = {m: {d for d in deps if d not in PACKAGES} for m, deps in _imports().items() if m not in PACKAGES}
    assert _cycles(graph) == []
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]  # the search finds one
    for module, deps in _imports().items():
        if module.startswith("tofjax"):
            assert not {d.split(".")[0] for d in deps} - {"tofjax"}, module
        else:  # a sibling: tofjax's public modules and names only
            private = [d for d in deps if d.startswith("tofjax.") and d.split(".")[1].startswith("_")]
            assert private == [], (module, private)


def test_the_sweep_axes_are_one_table_that_agrees_with_the_schema():
    """tofjax.schema.SWEEP_AXES is the only table of the sweep axes (no module maps the sweep names
    to keys, columns, units or labels of its own), and its keys, ranges and units are the schema's."""
    import re

    from tofjax.schema import KEY_BY_DOTTED, OPERATING_POINT_COLUMNS, SWEEP_AXES, SWEEPS

    # A dict entry ("distance": ...) or a tuple of the names; not a comparison (sweep == "distance":).
    table = re.compile(r'(^|[{,])\s*"(distance|illuminance|integration_time|temperature)"\s*:|\("distance", "illuminance"',
                       re.M)
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).glob("*.py")):
            if path.name != "_schema.py":
                assert not table.search(path.read_text()), f"{path.relative_to(ROOT)} writes a sweep-axis table"
    assert SWEEPS == ("distance", "illuminance", "integration_time", "temperature")
    assert OPERATING_POINT_COLUMNS == ("distance_m", "illuminance_lx", "integration_time_s", "temperature_c")
    for name, axis in SWEEP_AXES.items():
        assert axis.name == name and KEY_BY_DOTTED[axis.key].unit == axis.unit
        for bound in axis.range_keys:
            assert KEY_BY_DOTTED[f"scene.{bound}"].unit == axis.unit
        assert axis.axis_label.endswith(f"[{axis.display_unit}]")
    assert SWEEP_AXES["integration_time"].display_scale == 1e3 and SWEEP_AXES["integration_time"].display_unit == "ms"


def test_the_public_surface_is_the_documented_short_list():
    """tj.__all__ is at most 35 names, each documented in docs/api.md (the first column of its tables
    before "Public submodules", no more, no fewer), each with a docstring of its own; every public
    submodule named there imports."""
    import importlib
    import re

    import tofjax as tj

    text = (ROOT / "docs" / "api.md").read_text()
    names_part, modules_part = text.split("## Public submodules")
    documented = set(re.findall(r"^\| `(\w+)` \|", names_part, re.M))
    assert len(tj.__all__) <= 35
    assert documented == set(tj.__all__), (documented ^ set(tj.__all__))
    for name in tj.__all__:
        value = getattr(tj, name)
        if name not in ("PRESETS", "__version__"):  # data, documented in docs/api.md and their modules
            assert (value.__doc__ or "").strip() and value.__doc__ != type(value).__doc__, name
    for module in re.findall(r"^\| `tofjax\.(\w+)`", modules_part, re.M):
        assert module in tj._SUBMODULES and importlib.import_module(f"tofjax.{module}").__doc__, module
    assert set(re.findall(r"`tofjax\.(\w+)`", modules_part)) == set(tj._SUBMODULES)


def test_every_script_says_in_its_help_what_it_does(monkeypatch, capsys):
    """``python bench/bench.py --help`` (and the other scripts') prints the script's description whole:
    it printed the docstring's first line, which stops mid-sentence ("... floor, on")."""
    import re
    import runpy
    import sys

    import pytest

    monkeypatch.setattr(sys, "path", list(sys.path))  # a script puts its folder first: not for the next tests
    for path in [*sorted((ROOT / "bench").glob("*.py")), ROOT / "docs" / "gallery.py"]:
        text = path.read_text()
        if "argparse" not in text or "numpy_baseline" == path.stem:
            continue
        monkeypatch.setattr(sys, "argv", [str(path), "--help"])
        with pytest.raises(SystemExit) as done:
            runpy.run_path(str(path), run_name="__main__")
        printed = " ".join(capsys.readouterr().out.split())
        first = " ".join(ast.get_docstring(ast.parse(text)).split("\n\n")[0].split())  # the first paragraph
        assert done.value.code == 0 and first in printed and re.search(r"[.:)]$", first), path.name
