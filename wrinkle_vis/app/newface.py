"""The New-face flow without Qt: a scan, its nine landmarks picked one at a time, the muscles
moved onto it, and the layout that names the mesh file and the landmarks.

:class:`LandmarkPicker` is the flow's state: which landmark comes next, the ones placed (each
snapped onto the skin), undo, and once all are placed the face with the muscles transferred
(:func:`~wrinkle_vis.datasets.scans.transfer_layout`) and its :class:`~wrinkle_vis.core.Layout`.
The window (``window.py``) only turns clicks into :meth:`LandmarkPicker.add` calls and shows
what the picker says. :func:`landmark_picture` draws where a landmark goes, on the built-in
face, for the panel.
"""

from __future__ import annotations

import dataclasses
import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..core.face import FaceModel
from ..core.layout import Layout
from ..core.mesh import TriangleSurface, closest_points

__all__ = ["DESCRIPTIONS", "MESH_FILTER", "MISFIT", "LandmarkPicker", "landmark_picture",
           "scan_only_face"]

#: Where each landmark goes, in words for the panel (L: the subject's left, +x).
DESCRIPTIONS = {
    "nasion": "the deepest point of the bridge of the nose, between the eyes",
    "nose_tip": "the tip of the nose, its most forward point",
    "chin": "the lowest point of the chin, on the midline",
    "eye_inner_L": "the inner corner of the subject's left eye (on your right as you face "
                   "them)",
    "eye_inner_R": "the inner corner of the subject's right eye (on your left as you face "
                   "them)",
    "eye_outer_L": "the outer corner of the subject's left eye (on your right)",
    "eye_outer_R": "the outer corner of the subject's right eye (on your left)",
    "mouth_corner_L": "the corner of the mouth on the subject's left (on your right)",
    "mouth_corner_R": "the corner of the mouth on the subject's right (on your left)",
}

#: The largest misfit of the landmarks that :meth:`LandmarkPicker.check` accepts.
MISFIT = 0.15

#: The file dialog's filter: every format :func:`~wrinkle_vis.datasets.read_surface` reads.
MESH_FILTER = ("Meshes (*.obj *.ply *.stl *.vtp *.vtk *.gltf *.glb);;All files (*)")


def scan_only_face(skin: TriangleSurface, name: str = "scan",
                   unit: str | None = None) -> FaceModel:
    """A face of ``skin`` alone (no skull, no muscles, the neutral expression, lengths in
    ``unit``): what the views show while the landmarks are picked.
    """
    from ..core.expressions import paper_expressions

    return FaceModel(skin, None, (), {"neutral": paper_expressions()["neutral"]},
                     name=name, unit=unit)


@dataclasses.dataclass
class LandmarkPicker:
    """The landmarks of a scan, picked one at a time in :attr:`order`.

    Parameters
    ----------
    skin : TriangleSurface
        The scan's skin (as :func:`~wrinkle_vis.datasets.read_surface` read it).
    mesh_path : path
        The scan's file; the layout names it.
    source : Layout, optional
        The layout to move onto the scan, with its own landmarks; default the built-in
        face's. Picking again on a face from a scan passes that face's layout, so that its
        edited muscles move with the new landmarks.
    previous : dict of str to (3,) float, optional
        Landmarks picked before (picking again): shown as hints, and :meth:`keep` takes
        one as it was.
    order : tuple of str
        The landmarks to ask for (default :data:`~wrinkle_vis.datasets.scans.LANDMARKS`).
    unit : str, optional
        The unit of the scan's coordinates (:data:`~wrinkle_vis.core.units.LENGTH_UNITS`);
        default :meth:`guessed_unit`.
    """

    skin: TriangleSurface
    mesh_path: Path
    source: Layout | None = None
    previous: dict = dataclasses.field(default_factory=dict)
    order: tuple = ()
    unit: str | None = None
    picked: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        from wrinkle_vis.datasets.scans import LANDMARKS

        self.mesh_path = Path(self.mesh_path).resolve()
        self.order = tuple(self.order) or LANDMARKS
        self.previous = {k: tuple(map(float, v)) for k, v in self.previous.items()}

    # ------------------------------------------------------------------ the steps
    @property
    def current(self) -> str | None:
        """The landmark to place next (None once all are placed)."""
        return next((n for n in self.order if n not in self.picked), None)

    @property
    def step(self) -> int:
        """How many landmarks are placed (the current one is number ``step + 1``)."""
        return len(self.picked)

    @property
    def done(self) -> bool:
        """Whether every landmark is placed."""
        return self.current is None

    def add(self, point) -> tuple[str, tuple]:
        """Place the current landmark at ``point`` ``(3,)``, snapped onto the skin (the
        closest point of its triangles); returns its name and where it went.

        Raises
        ------
        ValueError
            When every landmark is placed already, or ``point`` is not three finite
            numbers.
        """
        name = self.current
        if name is None:
            raise ValueError("every landmark is placed already; undo one to place it again")
        p = np.asarray(point, float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"a landmark is a point (x, y, z) of finite numbers; got {point!r}")
        on_skin = tuple(float(x) for x in closest_points(self.skin, p[None])[0])
        self.picked[name] = on_skin
        return name, on_skin

    def keep(self) -> tuple[str, tuple]:
        """Place the current landmark exactly where it was before (picking again)."""
        name = self.current
        if name is None or name not in self.previous:
            raise ValueError(f"landmark {name!r} has no earlier position to keep")
        self.picked[name] = self.previous[name]
        return name, self.picked[name]

    def undo(self) -> str | None:
        """Take back the last landmark placed; returns its name (None: none was placed)."""
        if not self.picked:
            return None
        name = next(reversed(self.picked))
        del self.picked[name]
        return name

    # ------------------------------------------------------------------ the result
    def guessed_unit(self) -> str:
        """The unit in which the scan's height is a human head's
        (:func:`~wrinkle_vis.core.units.guess_unit`), else millimetres.
        """
        from ..core.units import DEFAULT_UNIT, guess_unit

        lo, hi = self.skin.bounds()
        return guess_unit(float(hi[1] - lo[1])) or DEFAULT_UNIT

    def face(self) -> FaceModel:
        """The scan with the muscles moved onto it from the landmarks: the built-in layout
        (through :func:`~wrinkle_vis.datasets.load_face`, skull and all), or :attr:`source`
        moved by the similarity between its landmarks and the new ones.

        Raises
        ------
        ValueError
            While a landmark is still missing, naming it.
        """
        from wrinkle_vis.datasets import load_face
        from wrinkle_vis.datasets.scans import transfer_layout

        if not self.done:
            raise ValueError(f"landmark {self.current!r} is not placed yet "
                             f"({self.step} of {len(self.order)})")
        self.check()
        built = load_face(skin=self.skin, landmarks=self.picked,
                          unit=self.unit or self.guessed_unit())
        if self.source is None:
            return built
        moved = transfer_layout(self.source, self.skin, self.picked, built.skull)
        return FaceModel(self.skin, built.skull, moved.muscles, moved.expressions,
                         name=self.source.name, landmarks=self.picked, unit=built.unit)

    def check(self, tolerance: float = MISFIT) -> None:
        r"""Refuse landmarks that cannot be the face's: two at one place, or an arrangement
        that no similarity takes the source's landmarks onto (left and right swapped, one
        in the wrong place).

        The misfit is the RMS distance between the landmarks and the source's moved by the
        least-squares similarity, over the span between the outer eye corners:
        :math:`\sqrt{\tfrac1k \sum_i \lVert s R x_i + t - y_i \rVert^2} / \lVert
        y_{eo,L} - y_{eo,R} \rVert`; a careful picking on a real scan gives under 0.1.

        Raises
        ------
        ValueError
            Naming the landmarks at fault and the way out.
        """
        from wrinkle_vis.datasets import builtin_landmarks
        from wrinkle_vis.datasets.scans import similarity_transform

        names = list(self.picked)
        y = np.array([self.picked[n] for n in names])
        span = float(np.linalg.norm(np.subtract(self.picked.get("eye_outer_L", y[0]),
                                                self.picked.get("eye_outer_R", y[-1]))))
        gaps = np.linalg.norm(y[:, None] - y[None], axis=2)
        np.fill_diagonal(gaps, np.inf)
        i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
        if not span > 0 or gaps[i, j] < 0.02 * span:
            raise ValueError(f"{names[i]} and {names[j]} are at the same place; undo and "
                             "place them where the pictures show")
        source = self.source.landmarks if self.source is not None else builtin_landmarks()
        x = np.array([source[n] for n in names])
        rot, scale, shift = similarity_transform(x, y)
        off = np.linalg.norm(scale * x @ rot.T + shift - y, axis=1) / span
        misfit = float(np.sqrt(np.mean(off**2)))
        if misfit > tolerance:
            worst = names[int(np.argmax(off))]
            raise ValueError(
                f"the landmarks do not make a face (misfit {misfit:.2f} of the eye span, "
                f"worst {worst}); _L is the subject's left, on your right as you face them: "
                "undo and place them where the pictures show")

    def layout(self, face: FaceModel) -> Layout:
        """``face`` as a layout that names the mesh file (its name: a path relative to the
        mesh's own folder, where :attr:`folder` says it starts) and the landmarks.
        """
        return Layout(name=face.name, muscles=face.muscles, expressions=face.expressions,
                      skin=self.mesh_path.name, landmarks=dict(self.picked), unit=face.unit)

    @property
    def folder(self) -> Path:
        """Where the layout's mesh path starts (the mesh's folder)."""
        return self.mesh_path.parent


def relative_mesh_path(mesh: str | os.PathLike, layout_folder: str | os.PathLike) -> str:
    """The path of ``mesh`` relative to ``layout_folder`` (absolute on another drive)."""
    try:
        return os.path.relpath(Path(mesh).resolve(), Path(layout_folder).resolve())
    except ValueError:
        return str(Path(mesh).resolve())


# ---------------------------------------------------------------------- the pictures
#: The built-in face the landmark pictures are drawn on (its own landmarks).
PICTURE_FACE = "lee_perry_smith"


def landmark_picture(name: str, size: int = 180) -> np.ndarray:
    """``(size, size, 3)`` uint8: where landmark ``name`` goes, drawn once per process on
    the built-in face :data:`PICTURE_FACE` (front view, the landmark a red ball, the others
    small grey ones).
    """
    return _picture(name, int(size)).copy()


@lru_cache(maxsize=32)
def _picture(name: str, size: int) -> np.ndarray:
    import pyvista as pv

    from wrinkle_vis.datasets import load_face

    from ..plotting.polydata import to_surface_polydata

    face = load_face(PICTURE_FACE)
    marks = {k: np.asarray(v, float) for k, v in face.landmarks.items()}
    if name not in marks:
        raise KeyError(f"unknown landmark {name!r}; landmarks: {', '.join(marks)}")
    span = float(np.linalg.norm(marks["eye_outer_L"] - marks["eye_outer_R"]))
    pl = pv.Plotter(off_screen=True, window_size=[size, size])
    try:
        pl.background_color = "white"
        pl.add_mesh(to_surface_polydata(face.skin), color="#e8c4a8", smooth_shading=True)
        others = np.array([v for k, v in marks.items() if k != name])
        pl.add_mesh(pv.PolyData(others).glyph(geom=pv.Sphere(radius=0.04 * span),
                                              scale=False, orient=False), color="#909090")
        pl.add_mesh(pv.Sphere(radius=0.09 * span, center=marks[name]), color="#e00000")
        centre = 0.5 * marks["nasion"] + 0.5 * marks["chin"]
        centre[0] = 0.5 * (marks["eye_outer_L"][0] + marks["eye_outer_R"][0])
        centre[2] = marks["nose_tip"][2] - 0.5 * span
        pl.camera_position = [tuple(centre + [0.0, 0.25 * span, 4.4 * span]),
                              tuple(centre), (0.0, 1.0, 0.0)]
        pl.camera.view_angle = 30.0
        pl.reset_camera_clipping_range()
        image = pl.screenshot(return_img=True)
    finally:
        pl.close()
    return np.ascontiguousarray(image[:, :, :3])
