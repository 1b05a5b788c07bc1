"""Layer rules that import-linter cannot see (widgets/ is mapped into wrinkle_vis), the
contracts run on the installed tree, and the import graph has no cycle.
"""

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
QT = ("qtpy", "PySide6", "pyvistaqt")


def _imported(modules: str) -> list[str]:
    code = (f"import sys; import {modules}; "
            f"print([m for m in {QT!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return eval(out.stdout.strip())  # noqa: S307 (our own printout)


def test_placement_widgets_and_the_app_model_import_no_qt():
    assert _imported("wrinkle_vis.widgets, wrinkle_vis.app.session, wrinkle_vis.app.views, "
                     "wrinkle_vis.app.recovery, wrinkle_vis.app.newface") == []


def test_the_qt_panels_do_use_qt():  # the check above can fail
    assert "qtpy" in _imported("wrinkle_vis.widgets.panels")


def test_datasets_import_neither_qt_nor_pyvista():
    modules = ", ".join(f"wrinkle_vis.datasets.{p.stem}"
                        for p in sorted((ROOT / "datasets").glob("*.py")))
    code = (f"import sys; import {modules}; "
            "print([m for m in ('qtpy', 'PySide6', 'pyvista', 'vtk') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_adding_a_muscle_in_the_session_loads_no_widgets():
    """The app's Qt-free model makes a new muscle with the core's ``created``, not through
    the placement widgets (which load VTK).
    """
    code = ("import sys; from wrinkle_vis.app.session import Session; "
            "from wrinkle_vis.datasets import load_face; s = Session(load_face()); "
            "s.added('linear', s.face.skin.points[0]); "
            "print('wrinkle_vis.widgets' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"


def test_the_contracts_are_kept_on_the_installed_tree():
    """``scripts/lint_imports.py`` lays out ``wrinkle_vis`` as installed (``widgets/`` and
    ``datasets/`` inside it), so that the layers contract sees them.
    """
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "lint_imports.py"),
                           "--no-logo"], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 broken" in done.stdout
    for name in ("datasets", "widgets"):
        assert (ROOT / name / "__init__.py").is_file()


# ---------------------------------------------------------------------- import cycles
#: Import cycles allowed (none: the plot methods are bound from wrinkle_vis/_plot.py).
DECLARED: set[tuple[str, str]] = set()


def _modules() -> dict[str, Path]:
    """Every module of the installed package by its dotted name."""
    found = {}
    for folder, package in ((ROOT / "wrinkle_vis", "wrinkle_vis"),
                            (ROOT / "widgets", "wrinkle_vis.widgets"),
                            (ROOT / "datasets", "wrinkle_vis.datasets")):
        for path in folder.rglob("*.py"):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join((package, *parts))] = path
    return found


def _run_time_nodes(tree: ast.AST):
    """Every node of ``tree`` but those under ``if TYPE_CHECKING:`` (never run)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            todo.extend(node.orelse)
        else:
            todo.extend(ast.iter_child_nodes(node))


def _imports(name: str, path: Path, modules) -> set[str]:
    """The package's modules that ``name`` imports anywhere in its file (functions too)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in _run_time_nodes(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join([package.rsplit(".", node.level - 1)[0]] + ([base] if base
                                                                           else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                       for a in node.names]
        else:
            continue
        out |= {t for t in targets if t in modules and t != name}
    return out


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle of ``graph`` (a list of names, the first repeated at the end), or []."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node):
        state[node], _ = 1, stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        state[node], _ = 2, stack.pop()
        return []

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return []


def test_the_package_has_no_import_cycle_but_the_declared_one():
    """No two modules import each other, directly or around a loop, counting imports inside
    functions (a package's ``__init__`` counts as the package); :data:`DECLARED` is empty.
    """
    modules = _modules()
    graph = {name: {t for t in _imports(name, path, modules)
                    if not any(name == a and t.startswith(b) for a, b in DECLARED)}
             for name, path in modules.items()}
    assert _cycle(graph) == []


def test_the_cycle_check_finds_a_cycle():  # the check above can fail
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]


# ---------------------------------------------------------------------- Qt-free core tests
#: The tests of the core (wrinkle_vis.core, and the built-in face it is tested on): they run
#: without Qt and PyVista, as ``pytest -p no:pytest-qt -p no:pyvista -p no:xvfb FILES``. (A
#: few of their tests check a layer above inside the test function: test_mesh's polydata,
#: test_parameters' command line and panel, test_folds' and test_hostile_layouts' command
#: lines; those import it when they run.)
CORE_TESTS = ("test_analysis", "test_builtin_face", "test_cache", "test_damaged_cache",
              "test_dynamic", "test_equations", "test_face", "test_folds",
              "test_fuzz_layouts", "test_hostile_layouts", "test_landmark_fit",
              "test_layout", "test_mesh", "test_metrics", "test_muscles", "test_parameters",
              "test_physical", "test_refine", "test_registry", "test_sphincter",
              "test_tracks", "test_units", "test_values_at")
HEAVY = ("qtpy", "PySide6", "pyvista", "vtkmodules", "pytestqt")


def _collected_imports(files: list[str], where: Path) -> tuple[int, str]:
    """Collect ``files`` with pytest in a new process, without its Qt, PyVista and Xvfb
    plugins: its exit status, and its output, which lists the Qt and PyVista modules then
    imported after ``SEEN``.
    """
    code = f"""
import sys, pytest
class Seen:
    def pytest_collection_finish(self, session):
        print("SEEN", [m for m in {HEAVY!r} if m in sys.modules])
sys.exit(pytest.main(["--collect-only", "-q", "-p", "no:pytest-qt", "-p", "no:pyvista",
                      "-p", "no:xvfb", "-p", "no:cacheprovider",
                      "-W", "ignore::pytest.PytestConfigWarning", *{files!r}],
                     plugins=[Seen()]))
"""
    done = subprocess.run([sys.executable, "-c", code], cwd=where, capture_output=True,
                          text=True)
    return done.returncode, done.stdout + done.stderr


def test_the_core_tests_import_neither_qt_nor_pyvista():
    """Issue 28: the core's tests (and this conftest) load no Qt and no PyVista."""
    files = [f"tests/{name}.py" for name in CORE_TESTS]
    assert all((ROOT / f).is_file() for f in files)
    status, out = _collected_imports(files, ROOT)
    assert status == 0, out
    assert "SEEN []" in out, out


def test_the_qt_free_check_sees_what_a_test_file_imports(tmp_path):  # the above can fail
    (tmp_path / "test_qt.py").write_text("import pytestqt\n\ndef test_x():\n    pass\n")
    status, out = _collected_imports(["test_qt.py"], tmp_path)
    assert status == 0 and "'pytestqt'" in out.split("SEEN", 1)[1], out
