"""A pytest plugin for off-screen image tests of wrinkle fields (entry point ``pytest11``).

Installed with wrinkle-vis, it gives every test session these fixtures (the image
comparison, ``verify_image_cache``, is pytest-pyvista's: ``pip install
"wrinkle-vis[testing]"`` brings it):

``wv_face``
    The built-in face (4,500 triangles), built once per session.
``wv_plotter``
    An off-screen ``pyvista.Plotter`` with :func:`~wrinkle_vis.plotting.testing_theme`
    (fixed window size, no multisampling), closed after the test.
``wv_render``
    ``wv_render(plotter, face, expression, field="W", muscle=None, layers=("skin",),
    camera="front")`` draws a field into ``plotter``; call ``plotter.show()`` afterwards
    so that pytest-pyvista's ``verify_image_cache`` compares it with the cached image.

Example::

    def test_forehead(verify_image_cache, wv_face, wv_plotter, wv_render):
        wv_render(wv_plotter, wv_face, "surprise", "W", camera="forehead")
        wv_plotter.show()
"""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def wv_face():
    """The built-in face at the paper's resolution."""
    from wrinkle_vis.datasets import load_face

    return load_face()


@pytest.fixture
def wv_plotter():
    """An off-screen plotter with the fixed testing theme; closed after the test."""
    import pyvista as pv

    from wrinkle_vis.plotting import testing_theme

    plotter = pv.Plotter(off_screen=True, theme=testing_theme())
    yield plotter
    plotter.close()


def render_into(plotter, face, expression="surprise", field="W", muscle=None,
                layers=("skin",), camera="front", intensity=1.0):
    """Draw a field of an expression into ``plotter`` (see ``render_field``)."""
    from wrinkle_vis.plotting import render_field

    return render_field(face, expression, field, muscle, layers=layers, camera=camera,
                        intensity=intensity, plotter=plotter)


@pytest.fixture
def wv_render():
    """The :func:`render_into` helper, as a fixture."""
    return render_into
