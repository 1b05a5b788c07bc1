"""The test suite's own promises (conftest.py): no test writes into the user's home, and a
test of the model imports no Qt.
"""

import subprocess
import sys
from pathlib import Path

from wrinkle_vis.datasets._cache import cache_dir

TESTS = Path(__file__).resolve().parent


def test_built_faces_are_cached_outside_the_users_home_cache():
    assert not cache_dir().resolve().is_relative_to((Path.home() / ".cache").resolve())


def test_the_shared_set_up_imports_neither_qt_nor_pyvista_nor_the_app():
    code = (f"import sys; sys.path.insert(0, {str(TESTS)!r}); import conftest; "
            "print([m for m in ('qtpy', 'PySide6', 'pyvista', 'vtk', 'wrinkle_vis.app') "
            "if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"
