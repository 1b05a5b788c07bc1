"""The signed distance fields of the built-in face's skin and skull (millimetres, y up,
face towards +z, x towards the subject's left, origin between the eyes' centres).

The skin is a cranium, a lower face, chin, cheekbones, brow ridge, nose, lips and neck
joined with smooth minima, with the orbits carved and eyeballs set in them and the mouth
line cut. The skull is the head without neck, eyes, lips and cartilage (the skin's cranium, face and
nasal bones) moved inwards by a regional soft-tissue depth, with the bone's own features:
orbits, the nasal aperture, zygomatic arches and the dental arch under the lips.

Soft-tissue depths follow the means of the large in-vivo adult tables (De Greef et al.,
"Large-scale in-vivo Caucasian facial soft tissue thickness database for craniofacial
reconstruction", Forensic Sci. Int. 159S (2006) S126-S146; Stephan and Simpson, "Facial
soft tissue depths in craniofacial identification", J. Forensic Sci. 53 (2008)): about
4-6 mm on the forehead and glabella, 6-7 mm at nasion and the orbital rims, 6-8 mm on the
zygoma, 10-13 mm at the philtrum, lips and chin, and 18-25 mm over the mid cheek.

The built-in face's muscle layout is shipped beside this module (:data:`BUILTIN_LAYOUT`,
written from :func:`~wrinkle_vis.datasets.face.builtin_layout`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .sdf import capsule, ellipsoid, mirrored, smooth_difference, smooth_union, sphere

#: The built-in face's layout file: its muscles, expressions, landmarks and track mapping.
BUILTIN_LAYOUT = Path(__file__).with_name("builtin_layout.json")

#: Regional tissue depth landmarks: name, position (mm, left side mirrored), depth (mm).
TISSUE_DEPTHS = (
    ("supraglabella", (0.0, 45.0, 92.0), 4.5),
    ("glabella", (0.0, 22.0, 94.0), 5.5),
    ("nasion", (0.0, 8.0, 90.0), 6.5),
    ("supraorbital", (30.0, 24.0, 90.0), 6.0),
    ("infraorbital", (30.0, -18.0, 80.0), 7.0),
    ("zygomatic", (46.0, -12.0, 70.0), 7.0),
    ("mid_cheek", (40.0, -45.0, 66.0), 21.0),
    ("mid_philtrum", (0.0, -44.0, 92.0), 11.5),
    ("upper_lip", (0.0, -52.0, 95.0), 12.0),
    ("lower_lip", (0.0, -66.0, 93.0), 13.0),
    ("mouth_corner", (24.0, -58.0, 84.0), 12.0),
    ("pogonion", (0.0, -95.0, 80.0), 11.0),
    ("menton", (0.0, -108.0, 60.0), 7.5),
    ("gonion", (48.0, -85.0, 15.0), 12.0),
)
#: Depth far from every landmark (the scalp), mm.
SCALP_DEPTH = 5.5

EYE_CENTER = (32.0, 0.0, 68.0)
EYE_RADIUS = 12.5


def _head(p: np.ndarray) -> np.ndarray:
    """Cranium, lower face, chin, cheekbones and brow ridge: what the skull follows."""
    d = ellipsoid(p, (0, 20, -5), (74, 100, 97))
    d = smooth_union(d, ellipsoid(p, (0, -45, 25), (55, 60, 62)), 18.0)
    d = smooth_union(d, ellipsoid(p, (0, -92, 62), (20, 14, 16)), 10.0)
    d = smooth_union(d, mirrored(ellipsoid, p, (45, -12, 62), (16, 12, 16)), 12.0)
    return smooth_union(d, mirrored(capsule, p, (6, 22, 86), (42, 19, 78), 7.0), 8.0)


def _nose_bridge(p: np.ndarray) -> np.ndarray:
    return capsule(p, (0, 8, 88), (0, -28, 104), 7.0)


def _lips(p: np.ndarray) -> np.ndarray:
    return smooth_union(ellipsoid(p, (0, -52, 88), (24, 7, 9)),
                        ellipsoid(p, (0, -66, 86), (21, 7, 9)), 4.0)


def skin_sdf(p: np.ndarray) -> np.ndarray:
    """``(n,)``: signed distance to the skin for ``(n, 3)`` points, mm."""
    d = smooth_union(_head(p), capsule(p, (0, -60, -15), (0, -170, -20), 52.0), 20.0)
    d = smooth_difference(d, mirrored(sphere, p, (32, 0, 86), 17.0), 8.0)
    d = smooth_union(d, mirrored(sphere, p, EYE_CENTER, EYE_RADIUS), 7.0)
    nose = smooth_union(_nose_bridge(p), sphere(p, (0, -29, 100), 10.5), 6.0)
    nose = smooth_union(nose, mirrored(ellipsoid, p, (12, -35, 90), (8, 7, 8)), 5.0)
    d = smooth_union(d, nose, 6.0)
    d = smooth_union(d, _lips(p), 6.0)
    return smooth_difference(d, capsule(p, (-23, -59, 96), (23, -59, 96), 1.5), 3.0)


def tissue_depth(p: np.ndarray, sigma: float = 14.0) -> np.ndarray:
    """``(n,)``: regional soft-tissue depth in mm, a Gaussian blend of :data:`TISSUE_DEPTHS`."""
    q = p.copy()
    q[:, 0] = np.abs(q[:, 0])
    num = np.full(len(p), 0.05 * SCALP_DEPTH)
    den = np.full(len(p), 0.05)
    for _, pos, depth in TISSUE_DEPTHS:
        w = np.exp(-np.sum((q - np.asarray(pos)) ** 2, axis=1) / (2 * sigma**2))
        num += w * depth
        den += w
    return num / den


def skull_sdf(p: np.ndarray) -> np.ndarray:
    """``(n,)``: signed distance to the skull for ``(n, 3)`` points, mm."""
    nasal_bones = capsule(p, (0, 8, 88), (0, -8, 95), 7.0)  # the bony upper third of the nose
    d = smooth_union(_head(p), nasal_bones, 6.0) + tissue_depth(p)
    d = smooth_union(d, ellipsoid(p, (0, -58, 68), (19, 15, 15)), 8.0)  # the dental arch
    d = smooth_union(d, mirrored(capsule, p, (50, -12, 52), (62, -8, 0), 4.0), 6.0)
    d = smooth_difference(d, mirrored(sphere, p, (32, 0, 78), 20.0), 4.0)
    d = smooth_difference(d, ellipsoid(p, (0, -26, 86), (10, 15, 22)), 4.0)
    return d
