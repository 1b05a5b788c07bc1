"""Layer rules that import-linter cannot see (widgets/ is mapped into wrinkle_vis)."""

import subprocess
import sys

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
