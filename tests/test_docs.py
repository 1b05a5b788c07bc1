"""The documentation site: the whole Sphinx build with warnings as errors (in a copy of docs/,
so nothing is written into the work tree), its gallery, its API reference with the equations
typeset by the MathJax it serves itself, and no asset from a CDN.
"""

import asyncio
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from browser import Browser
from browser import chromium as find_chromium

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SCANS = ROOT.parent / "shared" / "realmeshes"
EXAMPLES = ("expressions", "fields", "refinement", "real_head", "plugin_muscle", "your_scan")
PAGES = ("index", "guide", "model", "face", "plugins", "benchmarks", "notebooks",
         "api/index", "api/equations", "api/face", "api/notebook", "auto_examples/index")


def _env(**extra):
    return {**{k: v for k, v in os.environ.items() if not k.startswith("PYTEST")}, **extra}


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built from a copy of docs/ (sphinx-gallery writes its pages into the
    source tree): (html folder, sphinx's output).
    """
    tmp = tmp_path_factory.mktemp("docs")
    src = tmp / "docs"
    shutil.copytree(DOCS, src, ignore=shutil.ignore_patterns("_build", "auto_examples",
                                                             ".ipynb_checkpoints"))
    html = tmp / "html"
    done = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q",
         "-d", str(tmp / "doctrees"), str(src), str(html)],
        capture_output=True, text=True, timeout=600, cwd=tmp,
        env=_env(WRINKLE_VIS_REALMESHES=str(SCANS)))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-6000:]
    return html, done.stdout + done.stderr


def test_the_site_builds_without_warnings(site):
    html, output = site
    assert "WARNING" not in output and "ERROR" not in output, output
    for page in PAGES:
        assert (html / f"{page}.html").is_file(), page
    # the Markdown pages' figures came along
    assert (html / "_images" / "before_after.png").is_file()


def test_the_gallery_shows_every_example(site):
    html, _ = site
    index = (html / "auto_examples" / "index.html").read_text()
    for name in EXAMPLES:
        page = html / "auto_examples" / f"plot_{name}.html"
        assert page.is_file() and f"plot_{name}.html" in index, name
        pattern = rf'src="(\.\./_images/sphx_glr_plot_{name}_\d+\.png)"'
        images = re.findall(pattern, page.read_text())
        assert images, f"the {name} example shows no scene"
        for image in images:
            assert (page.parent / image).resolve().stat().st_size > 5000


def test_the_api_reference_has_the_equations_and_local_mathjax(site):
    html, _ = site
    page = (html / "api" / "equations.html").read_text()
    for name in ("shape_function", "bulge_height", "anisotropy", "attenuation",
                 "compression"):
        assert f'id="wrinkle_vis.core.equations.{name}"' in page
    assert page.count('class="math') >= 10
    assert 'src="../_static/mathjax/tex-chtml.js' in page
    assert (html / "_static" / "mathjax" / "tex-chtml.js").is_file()
    assert (html / "_static" / "mathjax" / "output" / "chtml" / "fonts" / "woff-v2").is_dir()
    notebook = (html / "api" / "notebook.html").read_text()
    for name in ("plot_state", "plot_face", "FaceExplorer", "default_backend"):
        assert f'id="wrinkle_vis.plotting.notebook.{name}"' in notebook
    assert 'id="wrinkle_vis.core.face.FaceState.plot"' in (html / "api/face.html").read_text()


def test_no_page_loads_anything_from_another_site(site):
    html, _ = site
    remote = re.compile(r'<(?:script|link|img)[^>]*(?:src|href)="(?:https?:)?//', re.I)
    offending = [str(p.relative_to(html)) for p in html.rglob("*.html")
                 if remote.search(p.read_text())]
    assert not offending


def test_the_real_head_example_needs_no_scan(tmp_path):
    """The head is built in: the example runs anywhere (no $WRINKLE_VIS_REALMESHES)."""
    env = {k: v for k, v in _env(PYVISTA_OFF_SCREEN="true").items()
           if k != "WRINKLE_VIS_REALMESHES"}
    done = subprocess.run([sys.executable, str(DOCS / "gallery" / "plot_real_head.py")],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    assert "8844 vertices, 21 muscles, unit mm" in done.stdout


def _serve(folder: Path) -> tuple[subprocess.Popen, int]:
    """A static HTTP server of ``folder`` on a free localhost port, once it listens:
    ``(process, port)``; the caller terminates it.
    """
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind",
                               "127.0.0.1", "--directory", str(folder)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(100):  # until it listens
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                break
        time.sleep(0.1)
    return server, port


def test_the_equations_are_typeset_in_a_browser_without_network(site):
    """The built site served from this machine: MathJax typesets the API reference's
    equations and every resource the page loads comes from the same server.
    """
    html, _ = site
    chromium = find_chromium()
    server, port = _serve(html)

    async def run():
        async with Browser(chromium) as browser:
            await browser.goto(f"http://127.0.0.1:{port}/api/equations.html")
            for _ in range(120):
                typeset = await browser.evaluate(
                    "document.querySelectorAll('mjx-container').length")
                if typeset and typeset >= 10:
                    break
                await asyncio.sleep(0.25)
            assert typeset >= 10, "MathJax did not typeset the equations"
            elsewhere = await browser.evaluate(
                "performance.getEntriesByType('resource').map(r => r.name)"
                f".filter(n => !n.startsWith('http://127.0.0.1:{port}/'))")
            assert elsewhere == []

    try:
        asyncio.run(run())
    finally:
        server.terminate()
        server.wait(10)


def test_the_plugin_example_runs_without_the_test_plugin(tmp_path):
    """The gallery's plug-in example (downloadable as a script and a notebook) defines its
    muscle type itself: it runs in a clean install, where tests/plugins is not installed
    (here: the package wrinkle_vis_ring cannot be imported).
    """
    example = DOCS / "gallery" / "plot_plugin_muscle.py"
    code = ("import runpy, sys, warnings\n"
            "sys.modules['wrinkle_vis_ring'] = None  # not installed\n"
            "warnings.simplefilter('ignore')  # the registry's word on the broken plug-in\n"
            f"runpy.run_path({str(example)!r}, run_name='__main__')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path, env=_env(PYVISTA_OFF_SCREEN="true"))
    assert done.returncode == 0, done.stderr[-2000:]
    assert "example_ring" in done.stdout and "W != 0 at" in done.stdout


def test_the_site_links_to_no_page_it_does_not_have():
    """DESIGN.md lives beside the repository, not in the site: the docs and the
    docstrings the API reference shows do not point to it.
    """
    root = DOCS.parent
    sources = [*DOCS.rglob("*.md"), *DOCS.rglob("*.rst"), *DOCS.rglob("*.ipynb"),
               *(root / "wrinkle_vis").rglob("*.py"), *(root / "widgets").rglob("*.py"),
               *(root / "datasets").rglob("*.py")]
    offending = [str(p.relative_to(root)) for p in sources if "DESIGN.md" in p.read_text()]
    assert not offending


def test_wide_equations_scroll_instead_of_being_cut_off(site):
    """model.md has two display equations wider than the text column; the theme hides a
    div.math's overflow, so they were cut off: now they scroll.
    """
    html, _ = site
    chromium = find_chromium()
    server, port = _serve(html)
    measure = """(() => Array.from(document.querySelectorAll('mjx-container[display="true"]'))
      .map(el => { let a = el.parentElement;
        while (a && getComputedStyle(a).overflowX === 'visible') a = a.parentElement;
        const inner = el.firstElementChild.getBoundingClientRect();
        const box = a ? a.getBoundingClientRect() : {left: 0, right: innerWidth};
        return [inner.right - box.right > 1 || box.left - inner.left > 1,
                a ? getComputedStyle(a).overflowX : 'visible']; }))()"""

    async def run():
        async with Browser(chromium) as browser:
            await browser.goto(f"http://127.0.0.1:{port}/model.html")
            for _ in range(120):
                if await browser.evaluate(
                        "document.querySelectorAll('mjx-container').length") >= 10:
                    break
                await asyncio.sleep(0.25)
            return await browser.evaluate(measure)

    try:
        equations = asyncio.run(run())
    finally:
        server.terminate()
        server.wait(10)
    wide = [overflow for too_wide, overflow in equations if too_wide]
    assert len(equations) >= 5 and wide, "no equation is wider than its column here"
    assert all(overflow in ("auto", "scroll") for overflow in wide), wide
