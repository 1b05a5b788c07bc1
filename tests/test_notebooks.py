"""Jupyter: state.plot and face.plot, the FaceExplorer widget, the example notebooks run in a
kernel (nbclient), and the trame view served from a kernel and drawn by headless Chromium.
"""

import asyncio
import base64
import json
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from browser import Browser
from browser import chromium as find_chromium

import wrinkle_vis as wv
from wrinkle_vis.plotting import FaceExplorer, default_backend, plot_state
from wrinkle_vis.plotting import notebook as nbmod

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "docs" / "notebooks").glob("*.ipynb"))


# ---------------------------------------------------------------------- plot()
def test_backend_is_trame_when_installed_else_static(monkeypatch):
    monkeypatch.delenv(nbmod.BACKEND_VARIABLE, raising=False)
    assert default_backend() == "trame"  # the test extra installs trame
    real = nbmod.importlib.util.find_spec
    monkeypatch.setattr(nbmod.importlib.util, "find_spec",
                        lambda name: None if name == "trame_vtk" else real(name))
    assert default_backend() == "static"
    monkeypatch.setenv(nbmod.BACKEND_VARIABLE, "Static ")
    assert default_backend() == "static"


def test_state_plot_draws_the_field_of_a_muscle(wv_face, no_leaked_plotters):
    state = wv_face.evaluate("surprise")
    plotter = state.plot("eps", "frontalis_major_L", return_plotter=True, off_screen=True)
    try:
        mesh = plotter.actors["skin"].mapper.dataset
        np.testing.assert_array_equal(mesh.points, state.points)
        np.testing.assert_array_equal(mesh.point_data["frontalis_major_L__eps"],
                                      state.fields["frontalis_major_L"]["eps"])
        assert plotter.actors["skin"].mapper.scalar_visibility
        assert not plotter.notebook and plotter.off_screen
    finally:
        plotter.close()


def test_plain_skin_is_lit_by_a_raking_light_and_writes_a_screenshot(wv_face, tmp_path,
                                                                     no_leaked_plotters):
    path = tmp_path / "frown.png"
    wv_face.plot("frown", None, camera="upper_face", off_screen=True, screenshot=path,
                 window_size=(200, 160))
    assert path.is_file()
    plotter = wv_face.evaluate("frown").plot(None, return_plotter=True, off_screen=True)
    try:
        assert not plotter.actors["skin"].mapper.scalar_visibility
        assert plotter.renderer.lights[0].positional is False  # the key light, not the kit
    finally:
        plotter.close()


def test_plot_errors_close_their_plotter(wv_face, no_leaked_plotters):
    state = wv_face.evaluate("surprise")
    with pytest.raises(ValueError, match="belongs to one muscle"):
        state.plot("eps", off_screen=True)
    with pytest.raises(ValueError, match="plain skin"):
        state.plot(None, "corrugator_L", off_screen=True)
    with pytest.raises(KeyError, match="unknown field 'tau'"):
        state.plot("tau", "corrugator_L", off_screen=True)
    with pytest.raises(TypeError, match="FaceState"):
        plot_state(wv_face)


def test_a_static_image_in_a_notebook_closes_its_plotter(wv_face, monkeypatch,
                                                        no_leaked_plotters):
    monkeypatch.setattr(nbmod, "in_notebook", lambda: True)
    shown = []
    monkeypatch.setattr("IPython.display.display", shown.append)
    wv_face.plot("frown", "W", jupyter_backend="static", window_size=(160, 120))
    assert len(shown) == 1 and shown[0].size == (160, 120)  # a PIL image


# ---------------------------------------------------------------------- the widget
@pytest.fixture
def explorer(wv_face, no_leaked_plotters):
    ex = FaceExplorer(wv_face, "surprise", backend="static", window_size=(240, 200))
    yield ex
    ex.close()


def test_explorer_updates_the_drawn_mesh_in_place(explorer):
    mesh, actor = explorer.mesh, explorer.plotter.actors["skin"]
    image = bytes(explorer.view.value)
    explorer.set(intensity=0.4)
    explorer.set(expression="fear")
    assert explorer.mesh is mesh and explorer.plotter.actors["skin"] is actor
    assert (explorer.n_rebuilds, explorer.n_updates) == (1, 2)
    state = wv.datasets.load_face().evaluate("fear", 0.4)
    np.testing.assert_allclose(mesh.points, state.points)
    np.testing.assert_allclose(mesh.point_data["W"], state.W)
    lo, hi = actor.mapper.scalar_range
    assert hi == -lo == pytest.approx(np.abs(state.W).max())
    assert bytes(explorer.view.value) != image  # the image shown was rendered again


def test_explorer_keeps_the_camera_and_redraws_for_a_new_field(explorer):
    explorer.plotter.camera.azimuth = 30.0
    camera = explorer.plotter.camera_position
    explorer.set(field="gamma")  # a muscle's field: the expression's first muscle
    assert explorer.values["muscle"] == "frontalis_inner_L"
    assert "frontalis_inner_L__gamma" in explorer.mesh.point_data
    assert explorer.n_rebuilds == 2
    assert explorer.plotter.camera_position == camera
    explorer.set(field=None)
    assert not explorer.plotter.actors["skin"].mapper.scalar_visibility


def test_explorer_refined_frames_replace_the_mesh_under_the_same_actor(explorer):
    actor, coarse = explorer.plotter.actors["skin"], explorer.mesh.n_points
    explorer.set(refine=True)
    assert explorer.plotter.actors["skin"] is actor and explorer.n_rebuilds == 1
    assert explorer.mesh.n_points == explorer.state.n_points > coarse
    np.testing.assert_array_equal(explorer.mesh.point_data["W"], explorer.state.W)


def test_explorer_controls_and_fallback_image(explorer, wv_face):
    assert list(explorer.controls) == ["expression", "intensity", "field", "muscle", "refine"]
    assert explorer.controls["expression"].options == tuple(wv_face.expressions)
    with pytest.raises(KeyError, match="unknown control"):
        explorer.set(colour="red")
    explorer.controls["intensity"].value = 0.5  # as a user moves the slider
    assert explorer.n_updates == 1
    bundle = explorer._repr_mimebundle_()
    assert "application/vnd.jupyter.widget-view+json" in bundle
    assert base64.b64decode(bundle["image/png"]).startswith(b"\x89PNG")


def test_explorer_outside_a_notebook_shows_an_image(wv_face, no_leaked_plotters):
    ex = FaceExplorer(wv_face, backend="trame", window_size=(120, 100))
    try:
        assert ex.backend == "static" and bytes(ex.view.value).startswith(b"\x89PNG")
    finally:
        ex.close()


# ---------------------------------------------------------------------- notebooks
@pytest.fixture
def kernel_env(monkeypatch):
    """The kernel inherits this process's environment."""
    monkeypatch.setenv("JUPYTER_PLATFORM_DIRS", "1")
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")


def _client(nb, cwd, **kwargs):
    from nbclient import NotebookClient

    # "python3" is the kernel ipykernel installs into the venv; jupyter_client starts it with
    # this very interpreter (sys.executable), nothing is registered globally
    return NotebookClient(nb, kernel_name="python3", timeout=300,
                          resources={"metadata": {"path": str(cwd)}}, **kwargs)


def test_the_kernel_is_this_venv(kernel_env, tmp_path):
    import nbformat
    from nbformat.v4 import new_code_cell, new_notebook

    nb = new_notebook(cells=[new_code_cell("import sys; print(sys.executable)")])
    _client(nb, tmp_path).execute()
    assert nb.cells[0].outputs[0]["text"].strip() == sys.executable
    assert nbformat.validate(nb) is None


def test_there_are_example_notebooks():
    assert {p.name for p in NOTEBOOKS} >= {"tour.ipynb", "explorer.ipynb"}
    for path in NOTEBOOKS:  # kept without outputs: the tests make them
        nb = json.loads(path.read_text())
        assert all(not c.get("outputs") for c in nb["cells"] if c["cell_type"] == "code")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs_and_shows_images(path, kernel_env, monkeypatch, tmp_path):
    import nbformat

    monkeypatch.setenv(nbmod.BACKEND_VARIABLE, "static")
    nb = nbformat.read(path, as_version=4)
    _client(nb, tmp_path).execute()  # raises CellExecutionError on any error
    images = 0
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        outputs = cell.outputs
        assert not [o for o in outputs if o.output_type == "error"]
        stderr = "".join(o.text for o in outputs if o.get("name") == "stderr")
        assert "Warning" not in stderr and "Traceback" not in stderr, stderr
        pngs = [o for o in outputs if "image/png" in o.get("data", {})]
        if ".plot(" in cell.source or cell.source.rstrip().endswith("explorer"):
            assert pngs, f"no image from:\n{cell.source}"
        for o in pngs:
            assert base64.b64decode(o.data["image/png"]).startswith(b"\x89PNG")
        images += len(pngs)
    assert images >= 2


# ---------------------------------------------------------------------- the browser
def _coloured(image: np.ndarray, box) -> int:
    """How many pixels of the view above its scalar bar are strongly coloured (W's blues
    and reds on the skin).
    """
    x, y, w, h = box
    view = image[y:y + int(0.75 * h), x:x + w].astype(int)
    return int(((view.max(axis=2) - view.min(axis=2)) > 80).sum())


def _drawn(image: np.ndarray, box) -> float:
    """The fraction of the view that is not the white background."""
    x, y, w, h = box
    view = image[y:y + h, x:x + w].astype(int)
    assert view.size, (box, image.shape)
    return float((view.min(axis=2) < 235).mean())


async def _wait_until(browser, box, check, timeout=40.0):
    deadline = time.monotonic() + timeout
    while True:
        image = await browser.screenshot()
        if check(image) or time.monotonic() > deadline:
            return image
        await asyncio.sleep(0.5)


def test_trame_view_served_from_a_kernel_draws_in_headless_chromium(kernel_env, tmp_path):
    """face.plot(jupyter_backend="trame") and the FaceExplorer in a real kernel, their
    views loaded from the kernel's trame server by Chromium; the canvas shows the skin with
    W's colours, and the explorer's in-place update reaches the page.
    """
    chromium = find_chromium()
    from nbformat.v4 import new_code_cell, new_notebook

    cells = {
        "plot": "import wrinkle_vis as wv\nface = wv.datasets.load_face()\n"
                "view = face.plot('surprise', 'W', camera='forehead', window_size=(600, 500),"
                " jupyter_backend='trame', return_viewer=True)\nprint(view.src)",
        "explorer": "from wrinkle_vis.plotting import FaceExplorer\n"
                    "ex = FaceExplorer(face, camera='forehead', window_size=(600, 500))\n"
                    "print(ex.backend, ex.view.src)",
        "flat": "ex.set(intensity=0.0)",
    }
    nb = new_notebook(cells=[new_code_cell(src) for src in cells.values()])
    client = _client(nb, tmp_path)

    def stdout(i):
        return "".join(o.text for o in nb.cells[i].outputs if o.get("name") == "stdout")

    async def run():
        async with client.async_setup_kernel():
            await client.async_execute_cell(nb.cells[0], 0)
            url = stdout(0).split()[-1]
            assert url.startswith("http://localhost:")
            async with Browser(chromium) as browser:
                await browser.goto(url)
                box = await browser.view_box()
                image = await _wait_until(browser, box, lambda im: _coloured(im, box) > 2000)
                assert _drawn(image, box) > 0.3, "the skin is not drawn"
                assert _coloured(image, box) > 2000, "W's colours are not drawn"

                await client.async_execute_cell(nb.cells[1], 1)
                backend, url = stdout(1).split()
                assert backend == "trame"
                await browser.goto(url)
                box = await browser.view_box()
                image = await _wait_until(browser, box, lambda im: _coloured(im, box) > 2000)
                before = _coloured(image, box)
                assert before > 2000
                await client.async_execute_cell(nb.cells[2], 2)  # no wrinkles: W = 0
                image = await _wait_until(browser, box,
                                          lambda im: _coloured(im, box) < 0.1 * before)
                assert _coloured(image, box) < 0.1 * before, "the update did not arrive"
                assert _drawn(image, box) > 0.3

    asyncio.run(run())


# ---------------------------------------------------------------------- PyVista's conventions
def test_plot_passes_mesh_options_on_and_show_options_to_show(wv_face, tmp_path,
                                                               no_leaked_plotters):
    """As pyvista.plot: cmap and the like go to add_mesh, screenshot and the like to
    show; with return_plotter the options of show are refused, not dropped.
    """
    from matplotlib import colormaps

    state = wv_face.evaluate("surprise")
    path = tmp_path / "magma.png"
    state.plot("W", cmap="magma", off_screen=True, screenshot=path, window_size=(120, 100))
    assert path.is_file()
    plotter = state.plot("W", cmap="magma", opacity=0.5, return_plotter=True,
                         off_screen=True)
    try:
        actor = plotter.actors["skin"]
        table = np.asarray(actor.mapper.lookup_table.values[:, :3], float) / 255
        want = colormaps["magma"](np.linspace(0, 1, len(table)))[:, :3]
        np.testing.assert_allclose(table, want, atol=1 / 255)
        assert actor.prop.opacity == 0.5
    finally:
        plotter.close()
    with pytest.raises(TypeError, match="screenshot: options of Plotter.show"):
        state.plot("W", return_plotter=True, screenshot=path, off_screen=True)


def test_pyvista_set_jupyter_backend_is_honoured(wv_face, monkeypatch, no_leaked_plotters):
    import pyvista as pv

    monkeypatch.delenv(nbmod.BACKEND_VARIABLE, raising=False)
    assert default_backend() == "trame"
    monkeypatch.setattr(pv.global_theme, "jupyter_backend", "static")
    monkeypatch.setenv(nbmod.BACKEND_VARIABLE, "trame")  # PyVista's own setting wins
    assert default_backend() == "static"
    monkeypatch.setattr(nbmod, "in_notebook", lambda: True)
    shown = []
    monkeypatch.setattr("IPython.display.display", shown.append)
    wv_face.plot("frown", "W", window_size=(160, 120))
    assert len(shown) == 1 and shown[0].size == (160, 120)  # a PIL image, not a trame view


def test_an_interactive_view_is_output_with_an_image(kernel_env, monkeypatch, tmp_path):
    """With trame, an executed notebook keeps a PNG beside the view: nbconvert's HTML
    (no widget state) and GitHub show that.
    """
    from nbformat.v4 import new_code_cell, new_notebook

    monkeypatch.delenv(nbmod.BACKEND_VARIABLE, raising=False)
    monkeypatch.delenv("PYVISTA_JUPYTER_BACKEND", raising=False)
    nb = new_notebook(cells=[new_code_cell(
        "import wrinkle_vis as wv\n"
        "wv.datasets.load_face().plot('surprise', window_size=(200, 160))")])
    _client(nb, tmp_path).execute()
    shown = [o for o in nb.cells[0].outputs if o.output_type == "display_data"]
    assert len(shown) == 1, nb.cells[0].outputs
    data = shown[0]["data"]
    assert "application/vnd.jupyter.widget-view+json" in data  # the trame view
    png = base64.b64decode(data["image/png"])
    assert png.startswith(b"\x89PNG")
    from io import BytesIO

    from PIL import Image

    Image.open(BytesIO(png)).save(tmp_path / "fallback.png")
    image = np.asarray(Image.open(BytesIO(png)).convert("RGB")).astype(int)
    assert image.shape == (160, 200, 3)
    assert (image.min(axis=2) < 235).mean() > 0.2  # the skin
    assert ((image.max(axis=2) - image.min(axis=2)) > 80).sum() > 200  # W's colours


def test_the_notebooks_counts_are_the_faces():
    """Counts of muscles and expressions stated in a notebook's text are the built-in
    face's (the tour said 14 muscles and five expressions after the face grew).
    """
    import re

    face = wv.datasets.load_face()
    words = {"five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9, "ten": 10}
    found = 0
    for path in NOTEBOOKS:
        for cell in json.loads(path.read_text())["cells"]:
            if cell["cell_type"] != "markdown":
                continue
            text = "".join(cell["source"])
            for count, what in re.findall(r"\b(\d+|five|six|seven|eight|nine|ten) "
                                          r"(muscles|expressions)\b", text):
                n = words.get(count) or int(count)
                want = len(face.muscles) if what == "muscles" else len(face.expressions)
                assert n == want, f"{path.name}: '{count} {what}', the face has {want}"
                found += 1
    assert found >= 2
