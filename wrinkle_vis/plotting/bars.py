"""Scalar bars whose text stays readable: fixed font sizes, and tick labels fitted to the
bar as drawn (fewer, or shorter, until they keep apart), so that neither the labels nor the
title overlap and nothing jumps from frame to frame. Used by the app's views and by every
off-screen render (:func:`~wrinkle_vis.plotting.add_skin`).
"""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import pyvista as pv
import vtkmodules.vtkRenderingFreeType  # noqa: F401 (the text renderer's implementation)
from vtkmodules.vtkCommonCore import VTK_FONT_FILE
from vtkmodules.vtkRenderingCore import vtkTextRenderer

__all__ = ["BAR_LABELS", "add_field_bar", "bar_label_spans", "field_bar_args",
           "fit_bar_labels", "show_bar_title", "symbol_font"]

#: Tick labels of a field's scalar bar, the first that keeps them apart on the bar as
#: drawn: (number of labels, printf format). None fitting, the bar has no tick labels.
BAR_LABELS = ((3, "%.3g"), (3, "%.2g"), (2, "%.3g"), (2, "%.2g"))
BAR_GAP_PX = 8  # at least this much space between two labels
BAR_FONT_PX, BAR_TITLE_PX = 12, 13  # fixed sizes, so that the labels can be measured
BAR_BOTTOM_PX = 20  # the bar's frame at least this far above the view's bottom
BAR_FRAME_PX, BAR_PX = 44, 9  # the frame of bar, labels and title; the colour bar
_TEXT = vtkTextRenderer()


def field_bar_args(title: str, nan: bool = True) -> dict:
    """``add_scalar_bar`` arguments of a field's horizontal bar under the view: fixed font
    sizes (:data:`BAR_FONT_PX`, :data:`BAR_TITLE_PX`; VTK's fitted sizes change with the
    labels' text and squeeze the title onto them) and the first labels of
    :data:`BAR_LABELS`.
    """
    return {"title": title, "n_labels": BAR_LABELS[0][0], "fmt": BAR_LABELS[0][1],
            "nan_annotation": nan, "vertical": False, "position_x": 0.2, "position_y": 0.07,
            "width": 0.6, "height": 0.06, "label_font_size": BAR_FONT_PX,
            "title_font_size": BAR_TITLE_PX, "unconstrained_font_size": True}


def add_field_bar(plotter: pv.Plotter, mapper, title: str, shown: str | None = None):
    """Add the horizontal scalar bar of a field (``undefined`` for NaN) under the view; its
    tick labels are fitted to the bar by :func:`fit_bar_labels`. The bar is known by
    ``title`` (``plotter.scalar_bars[title]``) and shows ``shown`` (default the title; see
    :func:`show_bar_title`).
    """
    bar = plotter.add_scalar_bar(mapper=mapper, render=False, **field_bar_args(title))
    bar.SetNanAnnotation("undefined")
    if shown is not None:
        show_bar_title(bar, shown)
    fit_bar_labels(bar, plotter.renderer)
    return bar


def symbol_font() -> str | None:
    """A font file with Greek letters, subscripts and superscripts, which VTK's own fonts
    lack (they draw nothing for ``λ``): matplotlib's DejaVu Sans (PyVista brings
    matplotlib); None when it is not there.
    """
    try:
        import matplotlib
    except ImportError:  # pragma: no cover (a dependency of PyVista)
        return None
    path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
    return str(path) if path.is_file() else None


def show_bar_title(bar, text: str) -> None:
    """Show ``text`` as scalar bar ``bar``'s title (the plotter still knows the bar by the
    title it was added with): ASCII in VTK's own font, anything else (``λ, corrugator_L``)
    in :func:`symbol_font`, and where there is no such font the title stays as it was.
    """
    old = bar.GetTitle() or ""
    text += old[len(old.rstrip("\n")):]  # the new lines PyVista puts under a title
    if text.isascii():
        bar.SetTitle(text)
        return
    font = symbol_font()
    if font is None:
        return
    prop = bar.GetTitleTextProperty()
    prop.SetFontFamily(VTK_FONT_FILE)
    prop.SetFontFile(font)
    bar.SetTitle(text)


def bar_label_spans(bar, renderer, n: int | None = None, fmt: str | None = None,
                    bar_px: tuple[float, float] | None = None) -> list[tuple[float, float]]:
    """Where the tick labels of horizontal scalar bar ``bar`` lie, in pixels: ``(x0, x1)``
    of each, centred on its value along the bar (VTK's layout).

    ``n`` and ``fmt`` default to the bar's own; ``bar_px`` ``(x, width)`` of the colour bar
    to the rectangle VTK drew it in at the last render.
    """
    n = bar.GetNumberOfLabels() if n is None else n
    fmt = bar.GetLabelFormat() if fmt is None else fmt
    if bar_px is None:
        rect = [0, 0, 0, 0]
        bar.GetScalarBarRect(rect, renderer)
        bar_px = (rect[0], rect[2])
    x, width = bar_px
    lo, hi = bar.GetLookupTable().GetRange()
    dpi = renderer.GetRenderWindow().GetDPI() if renderer.GetRenderWindow() else 72
    spans = []
    for i in range(n):
        value = lo + (hi - lo) * i / max(n - 1, 1)
        box = [0, 0, 0, 0]
        _TEXT.GetBoundingBox(bar.GetLabelTextProperty(), fmt % value, box, dpi)
        centre, half = x + width * i / max(n - 1, 1), 0.5 * (box[1] - box[0])
        spans.append((centre - half, centre + half))
    return spans


def fit_bar_labels(bar, renderer) -> int:
    """Choose the tick labels of ``bar`` (:data:`BAR_LABELS`) that keep at least
    :data:`BAR_GAP_PX` apart on the bar at the view's present size; returns their number
    (0: the bar shows none, it is too narrow for two). The bar keeps at least
    :data:`BAR_BOTTOM_PX` above the view's bottom, room for its ``undefined`` label, a
    frame of :data:`BAR_FRAME_PX` for title, labels and bar, and a line's room between
    its title and its labels.
    """
    height_px = renderer.GetSize()[1]
    if height_px > 0:  # room for the title, the labels and the bar, whatever the size
        bar.SetPosition(bar.GetPosition()[0], max(0.07, BAR_BOTTOM_PX / height_px))
        bar.SetHeight(max(0.06, BAR_FRAME_PX / height_px))
        bar.SetBarRatio(min(0.375, BAR_PX / (bar.GetHeight() * height_px)))
    title = bar.GetTitle() or ""
    if title and not title.endswith("\n"):  # a line's room between title and labels
        bar.SetTitle(title + "\n")  # (a horizontal bar ignores VTK's title separation)
    frame_px = bar.GetWidth() * renderer.GetSize()[0]
    rect = [0, 0, 0, 0]
    bar.GetScalarBarRect(rect, renderer)  # as drawn at the last render, if any
    last_frame = getattr(bar, "_fitted_frame_px", 0.0)
    ratio = rect[2] / last_frame if 0 < rect[2] <= last_frame else 0.75
    bar._fitted_frame_px = frame_px
    bar_px = (0.0, 0.95 * ratio * frame_px)  # the colour bar is 0.75 to 0.9 of its frame
    for n, fmt in BAR_LABELS:
        spans = bar_label_spans(bar, renderer, n, fmt, bar_px)
        if all(b[0] - a[1] >= BAR_GAP_PX for a, b in pairwise(spans)):
            if (n, fmt) != (bar.GetNumberOfLabels(), bar.GetLabelFormat()):
                bar.SetNumberOfLabels(n)
                bar.SetLabelFormat(fmt)
            bar.SetDrawTickLabels(True)
            return n
    bar.SetDrawTickLabels(False)
    return 0
