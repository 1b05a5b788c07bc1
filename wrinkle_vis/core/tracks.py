r"""Recorded performances: facial action unit and blendshape tracks, and what they drive.

A :class:`Track` is a table of channels over time: ``times`` ``(n,)`` in seconds from the
first frame, ``channels`` (FACS action units as ``"AU01"``, ``"AU12"``, ...; ARKit
blendshapes by their ARKit names, ``"browInnerUp"``, ``"noseSneerLeft"``, ...) and
``values`` ``(n, c)``, every value an intensity in ``[0, 1]``. :func:`read_track` reads the
formats of :data:`TRACK_FORMATS`:

``openface``
    OpenFace 2.x ``FeatureExtraction`` CSV: ``timestamp`` (s), ``success`` (0 or 1),
    ``confidence`` and ``AUxx_r`` intensities on FACS' 0-5 scale (divided by 5 here).
    Column names may carry the leading space OpenFace writes after each comma. The
    ``AUxx_c`` presence columns, gaze, pose and landmark columns are not used.
``pyfeat``
    py-feat's CSV (a ``Fex`` table written with ``to_csv``): ``frame`` and ``AUxx`` on
    0-1. The frame rate comes from ``fps=...``, else from an ``approx_time`` column
    (``MM:SS.ss`` or seconds) or a ``time``/``timestamp`` column (seconds); a file with
    neither needs ``fps``.
``arkit``
    The ARKit / Live Link Face CSV: ``Timecode`` (``HH:MM:SS:FF`` or ``HH:MM:SS:FF.fff``,
    frame ``FF`` at ``fps``) and the 52 ARKit blendshapes (Live Link Face spells them with
    a capital, ``EyeBlinkLeft``; any case reads). Without ``fps`` the timecode's rate is the
    smallest of 24, 25, 30, 48, 50 and 60 frames a second above the highest frame number
    in the file (noted). ``BlendShapeCount`` and the head and eye rotations are not used.
``mediapipe``
    MediaPipe Face Landmarker's blendshapes, one row a frame: the 52 ARKit names as
    MediaPipe spells them (``browDownLeft``, ...; ``_neutral`` is not used) and a time
    column, ``timestamp_ms`` (milliseconds, MediaPipe's video-mode timestamps), ``time``
    or ``timestamp`` (seconds), or ``frame`` with ``fps``.

Documented handling of imperfect files (each is recorded in :attr:`Track.notes` and
issued once as a :class:`TrackWarning`, never silent):

- a frame the tracker marks as failed (OpenFace ``success`` 0) and an empty or NaN value:
  interpolated linearly in time from the nearest good frames of its channel, held at the
  ends;
- a gap (a time step over :data:`GAP_FACTOR` times the median step): interpolated across;
- a row repeating the previous row's time with the same values: dropped;
- values outside the scale (below 0, above 5 in OpenFace, above 1 elsewhere): clipped;
- columns the format does not know: ignored, listed in the note.

Errors (:class:`TrackError`, one line naming the file and the row or column and the way
out): a row whose time goes back, a repeated time with other values (two faces in one
file), a missing, non-numeric or NaN time, a non-numeric value, a channel with no value in
any frame, an empty file, a file of another kind, and a file over ``max_bytes``
(:data:`MAX_TRACK_BYTES`).

A :class:`TrackMapping` turns channels into muscle activations: per channel, the muscles
it drives with a weight each, and a response curve (piecewise linear in ``[0, 1]``):

.. math::

    a_m(t) = \operatorname{clip}\Big(\sum_c w_{mc}\, f_c\big(x_c(t)\big), 0, 1\Big).

:func:`default_mapping` is grounded in FACS (Ekman, Friesen and Hager, *Facial Action
Coding System*, 2002: which muscle produces which action unit) on the built-in faces'
muscle names; a layout file keeps its own under ``"mapping"``.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
import re
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .expressions import Expression
from .files import atomic_write_text

__all__ = ["ARKIT_BLENDSHAPES", "MAX_TRACK_BYTES", "TRACK_FORMATS", "ChannelMap",
           "Performance", "Track", "TrackError", "TrackMapping", "TrackWarning",
           "default_mapping", "performance", "read_track", "write_track"]

#: The formats :func:`read_track` reads.
TRACK_FORMATS = ("openface", "pyfeat", "arkit", "mediapipe")
#: Files larger than this are refused (bytes; pass ``max_bytes`` to read a larger one).
MAX_TRACK_BYTES = 64 * 2**20
#: A time step this many times the median step is a gap (noted, interpolated across).
GAP_FACTOR = 3.0
#: The 52 ARKit face blendshapes (``ARFaceAnchor.BlendShapeLocation``), as MediaPipe names
#: them too.
ARKIT_BLENDSHAPES = (
    "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
    "eyeBlinkLeft", "eyeBlinkRight", "eyeLookDownLeft", "eyeLookDownRight", "eyeLookInLeft",
    "eyeLookInRight", "eyeLookOutLeft", "eyeLookOutRight", "eyeLookUpLeft", "eyeLookUpRight",
    "eyeSquintLeft", "eyeSquintRight", "eyeWideLeft", "eyeWideRight",
    "jawForward", "jawLeft", "jawOpen", "jawRight",
    "mouthClose", "mouthDimpleLeft", "mouthDimpleRight", "mouthFrownLeft", "mouthFrownRight",
    "mouthFunnel", "mouthLeft", "mouthLowerDownLeft", "mouthLowerDownRight",
    "mouthPressLeft", "mouthPressRight", "mouthPucker", "mouthRight", "mouthRollLower",
    "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthSmileLeft",
    "mouthSmileRight", "mouthStretchLeft", "mouthStretchRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
)
_BLEND = {name.lower(): name for name in ARKIT_BLENDSHAPES}
_TIMECODE_RATES = (24, 25, 30, 48, 50, 60)
_FORMAT_NAMES = {"openface": "an OpenFace 2.x CSV", "pyfeat": "a py-feat CSV",
                 "arkit": "an ARKit / Live Link Face CSV",
                 "mediapipe": "a MediaPipe blendshape CSV"}
#: Columns each format knows and does not use (regular expressions, case-insensitive).
_KNOWN = {
    "openface": r"frame|face_id|confidence|success|timestamp|gaze_.*|pose_.*|[xyzXYZ]_\d+|p_\w+|"
                r"eye_lmk_.*|au\d+_c",
    "pyfeat": r"frame|approx_time|time|timestamp|input|facerect.*|facescore|[xyz]_\d+|pitch|"
              r"roll|yaw|anger|disgust|fear|happiness|sadness|surprise|neutral|identity|"
              r"face_?id|unnamed: ?0|",
    "arkit": r"timecode|blendshapecount|headyaw|headpitch|headroll|lefteye(yaw|pitch|roll)|"
             r"righteye(yaw|pitch|roll)",
    "mediapipe": r"timestamp_ms|time|timestamp|frame|_neutral",
}


class TrackError(ValueError):
    """A track that cannot be read; one line naming the file, the row or column and the
    way out.
    """


class TrackWarning(UserWarning):
    """Something :func:`read_track` handled as documented (interpolated, dropped, clipped
    or ignored); the same text is in :attr:`Track.notes`.
    """


# ---------------------------------------------------------------------------- the track
@dataclass(frozen=True, eq=False)
class Track:
    """Channels over time, every value an intensity in ``[0, 1]``.

    Parameters
    ----------
    times : (n,) float
        Seconds from the first frame (``times[0] == 0``), strictly increasing.
    channels : sequence of str
        Channel names: ``"AU01"``... or ARKit blendshape names.
    values : (n, c) float
        Intensities in ``[0, 1]``, no NaN.
    format : str
        The format read (:data:`TRACK_FORMATS`), or ``""``.
    source : str
        The file read, or ``""``.
    start_s : float
        The file's time of the first frame, seconds.
    notes : tuple of str
        What was handled as documented while reading (interpolated, dropped, ...).
    """

    times: np.ndarray
    channels: tuple
    values: np.ndarray
    format: str = ""
    source: str = ""
    start_s: float = 0.0
    notes: tuple = ()

    def __post_init__(self):
        times = np.asarray(self.times, float).reshape(-1)
        values = np.asarray(self.values, float).reshape(len(times), -1)
        channels = tuple(str(c) for c in self.channels)
        if values.shape[1] != len(channels):
            raise ValueError(f"{values.shape[1]} value columns for {len(channels)} channels")
        if len(times) == 0:
            raise ValueError("a track needs at least one frame")
        if len(set(channels)) != len(channels):
            raise ValueError(f"channel names repeat: {channels}")
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
            raise ValueError("times must be finite and strictly increasing")
        if not np.all(np.isfinite(values)) or values.min(initial=0) < 0 or \
                values.max(initial=0) > 1:
            raise ValueError("values must be finite and in [0, 1]")
        times.flags.writeable = values.flags.writeable = False
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return len(self.times)

    @property
    def duration_s(self) -> float:
        """Seconds from the first frame to the last."""
        return float(self.times[-1] - self.times[0])

    @property
    def fps(self) -> float:
        """The median frame rate (1 / the median step); 0 for one frame."""
        return 0.0 if self.n_frames < 2 else float(1.0 / np.median(np.diff(self.times)))

    def channel(self, name: str) -> np.ndarray:
        """``(n,)``: one channel's values; ``KeyError`` lists the channels."""
        if name not in self.channels:
            raise KeyError(f"no channel {name!r}; the track has: {', '.join(self.channels)}")
        return self.values[:, self.channels.index(name)]

    def at(self, t) -> np.ndarray:
        """``(c,)`` at a time ``t`` (s), or ``(m, c)`` at ``(m,)`` times: linear
        interpolation between frames, the first and last frame held outside.
        """
        t = np.asarray(t, float)
        flat = np.atleast_1d(t)
        out = np.empty((len(flat), len(self.channels)))
        for j in range(len(self.channels)):
            out[:, j] = np.interp(flat, self.times, self.values[:, j])
        return out[0] if t.ndim == 0 else out

    def frame_times(self, fps: float) -> np.ndarray:
        """``(k,)``: frame times at ``fps`` from 0 to the end, ``k = floor(duration fps) + 1``."""
        fps = float(fps)
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps = {fps:g} must be a positive number")
        return np.arange(int(np.floor(self.duration_s * fps + 1e-9)) + 1) / fps

    def resampled(self, fps: float, smooth_s: float = 0.0) -> Track:
        r"""The track at ``fps`` frames a second (:meth:`frame_times`, values by :meth:`at`),
        smoothed by a Gaussian of standard deviation ``smooth_s`` seconds
        (:math:`\sigma = ` ``smooth_s * fps`` frames, edges held) when ``smooth_s > 0``.
        """
        smooth_s = float(smooth_s)
        if not (math.isfinite(smooth_s) and smooth_s >= 0):
            raise ValueError(f"smooth_s = {smooth_s:g} must be >= 0 seconds")
        times = self.frame_times(fps)
        values = self.at(times)
        if smooth_s > 0 and len(times) > 1:
            from scipy.ndimage import gaussian_filter1d

            values = np.clip(gaussian_filter1d(values, smooth_s * float(fps), axis=0,
                                               mode="nearest"), 0.0, 1.0)
        return Track(times, self.channels, values, self.format, self.source, self.start_s,
                     self.notes)

    def __eq__(self, other) -> bool:
        """Equal channels, times and values (format, source and notes aside)."""
        return (isinstance(other, Track) and self.channels == other.channels
                and np.array_equal(self.times, other.times)
                and np.array_equal(self.values, other.values))

    __hash__ = None  # type: ignore[assignment]  # equal by value, so unhashable


# ---------------------------------------------------------------------------- reading
def read_track(path: str | os.PathLike, format: str | None = None, fps: float | None = None,
               *, max_bytes: int = MAX_TRACK_BYTES) -> Track:
    """Read a recorded track (see the module's documentation for the formats and the
    handling of imperfect files).

    Parameters
    ----------
    path : path
        A CSV file.
    format : str, optional
        One of :data:`TRACK_FORMATS`; default: recognised from the header.
    fps : float, optional
        Frames a second, for formats whose time is a frame number (py-feat, ARKit
        timecodes, MediaPipe's ``frame``).
    max_bytes : int
        The largest file read.

    Raises
    ------
    TrackError
        One line naming the file, the row or column, and the way out.
    FileNotFoundError
        Naming the path.
    """
    path = Path(path)
    name = str(path)
    if format is not None and format not in TRACK_FORMATS:
        raise TrackError(f"{name}: unknown track format {format!r}; choose one of "
                         f"{', '.join(TRACK_FORMATS)} or leave it out to recognise it")
    if fps is not None and not (isinstance(fps, (int, float)) and math.isfinite(fps)
                                and fps > 0):
        raise TrackError(f"{name}: fps = {fps!r} must be a positive number of frames a second")
    header, rows = _read_table(path, max_bytes)
    fmt = format or _recognise(name, header)
    _check_rows(name, header, rows)
    notes: list[str] = []
    reader = {"openface": _openface, "pyfeat": _pyfeat, "arkit": _arkit,
              "mediapipe": _mediapipe}[fmt]
    times, lines, channels, raw, failed = reader(name, header, rows, fps, notes)
    track = _assemble(name, fmt, times, lines, channels, raw, failed, notes)
    for note in track.notes:
        warnings.warn(f"{name}: {note}", TrackWarning, stacklevel=2)
    return track


def _read_table(path: Path, max_bytes: int) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """The stripped header and the ``(line number, fields)`` of every non-blank row."""
    name = str(path)
    if not path.is_file():
        what = "is a folder, not a track file" if path.is_dir() else "no such file"
        raise FileNotFoundError(f"{name}: {what}; check the path")
    size = path.stat().st_size
    if size > max_bytes:
        raise TrackError(f"{name}: the file is {size / 2**20:.1f} MiB, more than the "
                         f"{max_bytes / 2**20:.0f} MiB a track may be; cut it into shorter "
                         "takes or pass max_bytes=... (--max-mb) to read it")
    raw = path.read_bytes()
    if not raw.strip():
        raise TrackError(f"{name}: the file is empty; give a CSV track with a header and one "
                         "row a frame")
    if b"\0" in raw[:4096]:
        raise TrackError(f"{name}: a binary file, not a CSV track; export the track as CSV")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise TrackError(f"{name}: line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x}); "
                         "save the track as UTF-8 CSV") from None
    del raw
    try:
        reader = csv.reader(io.StringIO(text))
        header = [h.strip() for h in next(reader)]
        used = [i for i, h in enumerate(header) if _MAYBE_USED.fullmatch(h)
                or h.lower() in _BLEND]
        rows = [(reader.line_num, _slim(r, used)) for r in reader if any(f.strip() for f in r)]
    except csv.Error as exc:
        raise TrackError(f"{name}: line {reader.line_num}: not CSV ({exc})") from None
    return header, rows


#: Columns some reader may read (the others are kept as empty cells, to save memory).
_MAYBE_USED = re.compile(r"au\d+(_r)?|timestamp(_ms)?|time|frame|success|approx_time|"
                         r"timecode", re.IGNORECASE)


def _slim(row: list[str], used: list[int]) -> list[str]:
    """``row`` with only the ``used`` cells (the others empty), its length kept."""
    out = [""] * len(row)
    for i in used:
        if i < len(row):
            out[i] = row[i]
    return out


def _check_rows(name: str, header: list[str], rows) -> None:
    for line, row in rows:
        if len(row) != len(header):
            raise TrackError(f"{name}: line {line}: {len(row)} fields under a header of "
                             f"{len(header)}; every row needs one value per column")
    if not rows:
        raise TrackError(f"{name}: a header and no frames; the track needs one row a frame")


def _recognise(name: str, header: list[str]) -> str:
    lower = {h.lower() for h in header}
    if "timestamp" in lower and any(re.fullmatch(r"au\d+_r", h) for h in lower):
        return "openface"
    if any(re.fullmatch(r"au\d+", h) for h in lower):
        return "pyfeat"
    blends = lower & set(_BLEND)
    if blends and "timecode" in lower:
        return "arkit"
    if blends:
        return "mediapipe"
    shown = ", ".join(header[:6]) + (", ..." if len(header) > 6 else "")
    raise TrackError(f"{name}: not a track this reads (its header: {shown}): expected "
                     "OpenFace (timestamp, AUxx_r), py-feat (frame, AUxx), ARKit / Live Link "
                     "Face (Timecode and blendshapes) or MediaPipe blendshape columns; "
                     "pass format=... (--format) if it is one of them")


def _column(name: str, header: list[str], rows, key: str, fmt: str) -> np.ndarray:
    """``(n,)`` floats of column ``key`` (case-insensitive); NaN for an empty cell."""
    index = [h.lower() for h in header].index(key.lower())
    return _numbers(name, rows, index, header[index], fmt)


def _numbers(name: str, rows, index: int, title: str, fmt: str) -> np.ndarray:
    out = np.empty(len(rows))
    for i, (line, row) in enumerate(rows):
        cell = row[index].strip()
        try:
            out[i] = float(cell) if cell else math.nan
        except ValueError:
            raise TrackError(f"{name}: line {line}, column {title!r}: {cell[:20]!r} is not a "
                             f"number; fix the cell (is this {_FORMAT_NAMES[fmt]}?)") from None
    return out


def _has(header: list[str], key: str) -> bool:
    return key.lower() in (h.lower() for h in header)


def _require(name: str, header: list[str], keys: Sequence[str], fmt: str, way: str) -> None:
    for key in keys:
        if not _has(header, key):
            raise TrackError(f"{name}: not {_FORMAT_NAMES[fmt]}: no {key!r} column; {way}")


def _unknown(header: list[str], used: set[str], fmt: str, notes: list[str]) -> None:
    known = re.compile(_KNOWN[fmt], re.IGNORECASE)
    unknown = [h for h in header if h not in used and not known.fullmatch(h)]
    if unknown:
        shown = ", ".join(unknown[:5]) + (f" and {len(unknown) - 5} more"
                                          if len(unknown) > 5 else "")
        notes.append(f"ignored {len(unknown)} column(s) {_FORMAT_NAMES[fmt]} does not "
                     f"define: {shown}")


def _openface(name, header, rows, fps, notes):
    _require(name, header, ("timestamp",), "openface",
             "OpenFace's FeatureExtraction writes frame, timestamp, confidence, success, ...")
    aus = [h for h in header if re.fullmatch(r"AU\d+_r", h, re.IGNORECASE)]
    if not aus:
        raise TrackError(f"{name}: not an OpenFace 2.x CSV: no AUxx_r intensity columns; run "
                         "FeatureExtraction with -aus")
    if fps is not None:
        notes.append(f"fps = {fps:g} is not used: OpenFace files carry their timestamps")
    times = _column(name, header, rows, "timestamp", "openface")
    failed = np.zeros(len(rows), bool)
    if _has(header, "success"):
        failed = _column(name, header, rows, "success", "openface") == 0
    raw = np.column_stack([_column(name, header, rows, h, "openface") for h in aus]) / 5.0
    channels = [f"AU{int(h[2:-2]):02d}" for h in aus]
    _unknown(header, set(aus), "openface", notes)
    return times, [r[0] for r in rows], channels, raw, failed


def _pyfeat(name, header, rows, fps, notes):
    aus = [h for h in header if re.fullmatch(r"AU\d+", h, re.IGNORECASE)]
    if not aus:
        raise TrackError(f"{name}: not a py-feat CSV: no AUxx columns")
    if fps is not None:
        _require(name, header, ("frame",), "pyfeat", "give times another way or add frame")
        times = _column(name, header, rows, "frame", "pyfeat") / float(fps)
    elif _has(header, "approx_time"):
        index = [h.lower() for h in header].index("approx_time")
        times = np.array([_clock(name, line, row[index]) for line, row in rows])
    elif _has(header, "time") or _has(header, "timestamp"):
        times = _column(name, header, rows, "time" if _has(header, "time") else "timestamp",
                        "pyfeat")
    else:
        raise TrackError(f"{name}: the py-feat file gives frames but no frame rate; pass "
                         "fps=... (--fps-in) with the video's frames a second")
    raw = np.column_stack([_column(name, header, rows, h, "pyfeat") for h in aus])
    _unknown(header, set(aus), "pyfeat", notes)
    return times, [r[0] for r in rows], [f"AU{int(h[2:]):02d}" for h in aus], raw, \
        np.zeros(len(rows), bool)


def _clock(name: str, line: int, text: str) -> float:
    """Seconds of ``SS.s``, ``MM:SS.s`` or ``HH:MM:SS.s``."""
    try:
        parts = [float(p) for p in text.strip().split(":")]
        if not 1 <= len(parts) <= 3:
            raise ValueError
    except ValueError:
        raise TrackError(f"{name}: line {line}: time {text.strip()[:20]!r} is not seconds, "
                         "MM:SS.ss or HH:MM:SS.ss; fix the cell or pass fps=...") from None
    return float(sum(p * 60.0**k for k, p in enumerate(reversed(parts))))


def _blend_columns(header: list[str]) -> tuple[list[str], list[str]]:
    cols = [h for h in header if h.lower() in _BLEND]
    return cols, [_BLEND[h.lower()] for h in cols]


def _arkit(name, header, rows, fps, notes):
    _require(name, header, ("timecode",), "arkit",
             "Live Link Face writes Timecode, BlendShapeCount, EyeBlinkLeft, ...")
    cols, channels = _blend_columns(header)
    if not cols:
        raise TrackError(f"{name}: not an ARKit / Live Link Face CSV: no blendshape columns")
    index = [h.lower() for h in header].index("timecode")
    codes = [_timecode(name, line, row[index]) for line, row in rows]
    if fps is None:
        top = max(c[1] for c in codes)
        fps = next((r for r in _TIMECODE_RATES if r > top), None)
        if fps is None:
            raise TrackError(f"{name}: timecode frame numbers reach {top:g}; pass fps=... "
                             "(--fps-in) with the recording's timecode rate")
        notes.append(f"the timecode rate is taken as {fps} frames a second (the smallest "
                     f"standard rate above frame {top:g}); pass fps=... to say")
    times = np.array([s + f / float(fps) for s, f in codes])
    raw = np.column_stack([_column(name, header, rows, h, "arkit") for h in cols])
    _unknown(header, set(cols), "arkit", notes)
    return times, [r[0] for r in rows], channels, raw, np.zeros(len(rows), bool)


def _timecode(name: str, line: int, text: str) -> tuple[float, float]:
    """``(seconds, frame)`` of ``HH:MM:SS:FF`` or ``HH:MM:SS:FF.fff`` (a fraction of a
    frame after the dot).
    """
    m = re.fullmatch(r"\s*(\d+):(\d+):(\d+)[:;](\d+(?:\.\d*)?)\s*", text)
    if m is None:
        raise TrackError(f"{name}: line {line}: timecode {text.strip()[:20]!r} is not "
                         "HH:MM:SS:FF(.fff); fix the cell")
    h, mi, s, f = m.groups()
    return 3600.0 * int(h) + 60.0 * int(mi) + int(s), float(f)


def _mediapipe(name, header, rows, fps, notes):
    cols, channels = _blend_columns(header)
    if not cols:
        raise TrackError(f"{name}: not a MediaPipe blendshape CSV: no blendshape columns")
    if _has(header, "timestamp_ms"):
        times = _column(name, header, rows, "timestamp_ms", "mediapipe") / 1000.0
    elif _has(header, "time") or _has(header, "timestamp"):
        times = _column(name, header, rows, "time" if _has(header, "time") else "timestamp",
                        "mediapipe")
    elif _has(header, "frame") and fps is not None:
        times = _column(name, header, rows, "frame", "mediapipe") / float(fps)
    else:
        raise TrackError(f"{name}: the MediaPipe file has no timestamp_ms, time or timestamp "
                         "column; add one, or a frame column and pass fps=...")
    raw = np.column_stack([_column(name, header, rows, h, "mediapipe") for h in cols])
    _unknown(header, set(cols), "mediapipe", notes)
    return times, [r[0] for r in rows], channels, raw, np.zeros(len(rows), bool)


def _assemble(name, fmt, times, lines, channels, raw, failed, notes) -> Track:
    """Check the time axis, drop exact repeats, fill failed and missing values, clip."""
    bad = np.flatnonzero(~np.isfinite(times))
    if len(bad):
        raise TrackError(f"{name}: line {lines[bad[0]]}: no time (empty or NaN); every row "
                         "needs its time")
    if len(set(channels)) != len(channels):
        raise TrackError(f"{name}: a channel appears twice in the header; keep one column "
                         "per channel")
    keep = np.ones(len(times), bool)
    step = np.diff(times)
    for i in np.flatnonzero(step <= 0):
        a, b = lines[i], lines[i + 1]
        if step[i] < 0:
            raise TrackError(f"{name}: line {b}: time {times[i + 1]:g} s comes before line "
                             f"{a}'s {times[i]:g} s; sort the rows by time")
        same = np.array_equal(raw[i], raw[i + 1], equal_nan=True) and failed[i] == failed[i + 1]
        if not same:
            raise TrackError(f"{name}: line {b}: time {times[i]:g} s repeats line {a}'s with "
                             "other values (two faces in one file?); keep one row a frame")
        keep[i + 1] = False
    if not keep.all():
        first = lines[int(np.flatnonzero(~keep)[0])]
        notes.append(f"dropped {int((~keep).sum())} row(s) repeating the previous row's time "
                     f"and values (first at line {first})")
    times, raw, failed = times[keep], raw[keep].copy(), failed[keep]
    lines = [ln for ln, k in zip(lines, keep, strict=True) if k]
    if failed.all():
        raise TrackError(f"{name}: every frame is marked as failed (success = 0); the tracker "
                         "found no face")
    if failed.any():
        notes.append(f"{int(failed.sum())} frame(s) the tracker marked as failed (success = "
                     f"0; first at line {lines[int(np.flatnonzero(failed)[0])]}): their values "
                     "are interpolated from the nearest good frames")
    raw[failed] = np.nan
    _fill(name, times, raw, channels, failed, lines, notes)
    _gaps(times, lines, notes)
    scale = 5.0 if fmt == "openface" else 1.0
    out = (raw < 0) | (raw > 1)
    if out.any():
        notes.append(f"clipped {int(out.sum())} value(s) outside 0..{scale:g} (first at line "
                     f"{lines[int(np.argwhere(out)[0, 0])]})")
    values = np.clip(raw, 0.0, 1.0)
    start = float(times[0])
    return Track(times - start, channels, values, fmt, name, start, tuple(notes))


def _fill(name, times, raw, channels, failed, lines, notes) -> None:
    """Interpolate NaN values (and failed frames) per channel, in place; ends held."""
    missing = np.isnan(raw) & ~failed[:, None]
    for j, channel in enumerate(channels):
        nan = np.isnan(raw[:, j])
        if nan.all():
            raise TrackError(f"{name}: channel {channel}: no frame has a value; remove the "
                             "column or fill it")
        if nan.any():
            raw[nan, j] = np.interp(times[nan], times[~nan], raw[~nan, j])
    if missing.any():
        row = int(np.argwhere(missing)[0, 0])
        notes.append(f"{int(missing.sum())} empty or NaN value(s) (first at line {lines[row]}, "
                     f"{channels[int(np.argwhere(missing)[0, 1])]}): interpolated in time")


def _gaps(times, lines, notes) -> None:
    if len(times) < 3:
        return
    step = np.diff(times)
    gaps = np.flatnonzero(step > GAP_FACTOR * np.median(step))
    if len(gaps):
        i = int(gaps[0])
        notes.append(f"{len(gaps)} gap(s) in time (first {step[i]:.3g} s between lines "
                     f"{lines[i]} and {lines[i + 1]}, the median step is "
                     f"{np.median(step):.3g} s): interpolated across")


# ---------------------------------------------------------------------------- writing
def write_track(track: Track, path: str | os.PathLike, format: str = "openface") -> Path:
    """Write ``track`` in ``format``'s schema, atomically (times from 0; OpenFace values
    times 5, ARKit timecodes at 60 frames a second from 00:00:00:00).
    """
    if format not in TRACK_FORMATS:
        raise ValueError(f"unknown track format {format!r}; choose one of "
                         f"{', '.join(TRACK_FORMATS)}")
    is_au = [re.fullmatch(r"AU\d\d", c) is not None for c in track.channels]
    if format in ("openface", "pyfeat") and not all(is_au):
        raise ValueError(f"{format} writes action units (AUxx); this track has "
                         f"{', '.join(track.channels)}")
    if format in ("arkit", "mediapipe") and any(c not in ARKIT_BLENDSHAPES
                                                for c in track.channels):
        raise ValueError(f"{format} writes ARKit blendshapes; this track has "
                         f"{', '.join(track.channels)}")
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    t, v = track.times, track.values
    if format == "openface":
        writer.writerow(["frame", " timestamp", " confidence", " success",
                         *(f" {c}_r" for c in track.channels)])
        for i in range(len(t)):
            writer.writerow([i + 1, repr(float(t[i])), 0.98, 1,
                             *(repr(5 * float(x)) for x in v[i])])
    elif format == "pyfeat":
        writer.writerow(["frame", "approx_time", *track.channels])
        for i in range(len(t)):
            writer.writerow([i, repr(float(t[i])), *(repr(float(x)) for x in v[i])])
    elif format == "arkit":
        writer.writerow(["Timecode", "BlendShapeCount",
                         *(c[0].upper() + c[1:] for c in track.channels)])
        for i in range(len(t)):
            s, f = divmod(round(float(t[i]) * 60.0, 6), 60.0)
            s = int(s)
            writer.writerow([f"{s // 3600:02d}:{s // 60 % 60:02d}:{s % 60:02d}:{f:.6f}",
                             len(track.channels), *(repr(float(x)) for x in v[i])])
    else:
        writer.writerow(["timestamp_ms", *track.channels])
        for i in range(len(t)):
            writer.writerow([repr(1000.0 * float(t[i])), *(repr(float(x)) for x in v[i])])
    return atomic_write_text(path, out.getvalue())


# ---------------------------------------------------------------------------- mapping
@dataclass(frozen=True)
class ChannelMap:
    """What one channel drives: muscle weights and a response curve.

    Parameters
    ----------
    muscles : mapping of str to float
        Muscle name to weight in ``[0, 1]``.
    curve : sequence of (x, y)
        Knots of the piecewise-linear response :math:`f`, ``x`` increasing from 0 to 1,
        ``y`` in ``[0, 1]``; default the identity ``((0, 0), (1, 1))``.
    """

    muscles: Mapping[str, float] = field(default_factory=dict)
    curve: tuple = ((0.0, 0.0), (1.0, 1.0))

    def __post_init__(self):
        muscles = {}
        for m, w in dict(self.muscles).items():
            w = float(w)
            if not 0.0 <= w <= 1.0:
                raise ValueError(f"weight of {m!r} = {w:g} is outside [0, 1]")
            muscles[str(m)] = w
        curve = tuple((float(x), float(y)) for x, y in self.curve)
        xs = [x for x, _ in curve]
        ys = [y for _, y in curve]
        if len(curve) < 2 or xs[0] != 0.0 or xs[-1] != 1.0 or np.any(np.diff(xs) <= 0) or \
                not all(0.0 <= y <= 1.0 for y in ys):
            raise ValueError("the curve needs knots [x, y] with x increasing from 0 to 1 and "
                             "y in [0, 1]")
        object.__setattr__(self, "muscles", muscles)
        object.__setattr__(self, "curve", curve)

    def response(self, x) -> np.ndarray:
        """``f(x)``, the curve's piecewise-linear interpolation."""
        xs, ys = zip(*self.curve, strict=True)
        return np.interp(np.asarray(x, float), xs, ys)

    def to_dict(self) -> dict:
        """JSON-ready: ``{"muscles": {...}}``, with ``"curve"`` when not the identity."""
        out: dict = {"muscles": dict(self.muscles)}
        if self.curve != ((0.0, 0.0), (1.0, 1.0)):
            out["curve"] = [list(k) for k in self.curve]
        return out


@dataclass(frozen=True)
class TrackMapping:
    """Channels to muscle activations (see the module's documentation for the sum).

    Parameters
    ----------
    channels : mapping of str to ChannelMap
        Per channel name (``"AU01"``, ``"browInnerUp"``, ...), what it drives.
    """

    channels: Mapping[str, ChannelMap] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "channels", {str(k): v if isinstance(v, ChannelMap) else
                                              ChannelMap(**v) for k, v in
                                              dict(self.channels).items()})

    @property
    def muscle_names(self) -> tuple[str, ...]:
        """Every muscle some channel drives, sorted."""
        return tuple(sorted({m for c in self.channels.values() for m in c.muscles}))

    def drives(self, channel: str) -> dict[str, float]:
        """The muscles ``channel`` drives and their weights (empty: none)."""
        c = self.channels.get(channel)
        return {} if c is None else dict(c.muscles)

    def restricted(self, muscles: Sequence[str]) -> TrackMapping:
        """The mapping with only the muscles in ``muscles`` (a face without some)."""
        keep = set(muscles)
        return TrackMapping({k: ChannelMap({m: w for m, w in c.muscles.items() if m in keep},
                                           c.curve) for k, c in self.channels.items()})

    def activations(self, track: Track, muscles: Sequence[str], times=None) -> np.ndarray:
        r"""``(k, M)``: the activations of ``muscles`` at ``times`` (default the track's
        frames): :math:`a_m = \mathrm{clip}(\sum_c w_{mc} f_c(x_c), 0, 1)`; a muscle no
        channel drives stays 0, a muscle the mapping names that is not in ``muscles`` is
        left out.
        """
        x = track.values if times is None else np.atleast_2d(track.at(times))
        index = {m: j for j, m in enumerate(muscles)}
        out = np.zeros((len(x), len(muscles)))
        for c, name in enumerate(track.channels):
            cmap = self.channels.get(name)
            if cmap is None:
                continue
            f = cmap.response(x[:, c])
            for m, w in cmap.muscles.items():
                if m in index:
                    out[:, index[m]] += w * f
        return np.clip(out, 0.0, 1.0)

    def to_dict(self) -> dict:
        """JSON-ready: ``{channel: {"muscles": {...}, "curve": [[x, y], ...]}}``."""
        return {k: c.to_dict() for k, c in self.channels.items()}

    @classmethod
    def from_dict(cls, data: Mapping) -> TrackMapping:
        """Inverse of :meth:`to_dict`; ``ValueError`` names the bad channel."""
        out = {}
        for key, item in dict(data).items():
            if not isinstance(item, Mapping) or set(item) - {"muscles", "curve"}:
                raise ValueError(f"channel {key!r}: expected {{\"muscles\": {{name: weight}}, "
                                 "\"curve\": [[x, y], ...]}")
            try:
                out[key] = ChannelMap(item.get("muscles", {}),
                                      item.get("curve", ((0.0, 0.0), (1.0, 1.0))))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"channel {key!r}: {exc}") from None
        return cls(out)


def _both(prefix: str, w: float = 1.0) -> dict[str, float]:
    return {f"{prefix}_L": w, f"{prefix}_R": w}


#: FACS action units and the muscles that produce them (Ekman, Friesen and Hager 2002),
#: on the built-in muscle names: ``(AU, muscles, curve or None, FACS name)``.
FACS_DEFAULT = (
    ("AU01", {**_both("frontalis_inner"), **_both("frontalis_major", 0.5)}, None,
     "inner brow raiser: frontalis, pars medialis"),
    ("AU02", {**_both("frontalis_outer"), **_both("frontalis_major", 0.5)}, None,
     "outer brow raiser: frontalis, pars lateralis"),
    ("AU04", {**_both("corrugator"), "procerus": 1.0}, None,
     "brow lowerer: corrugator supercilii, depressor supercilii, procerus"),
    ("AU06", _both("orbicularis_oculi"), None,
     "cheek raiser: orbicularis oculi, pars orbitalis"),
    ("AU07", _both("orbicularis_oculi", 0.5), None,
     "lid tightener: orbicularis oculi, pars palpebralis"),
    ("AU09", _both("levator_labii_superioris_alaeque_nasi"), None,
     "nose wrinkler: levator labii superioris alaeque nasi"),
    ("AU10", _both("levator_labii_superioris"), ((0.0, 0.0), (1.0, 0.6)),
     "upper lip raiser: levator labii superioris (curve to 0.6: the built-in faces' limit)"),
    ("AU12", _both("zygomaticus_major"), None, "lip corner puller: zygomaticus major"),
    ("AU15", _both("depressor_anguli_oris"), None,
     "lip corner depressor: depressor anguli oris (triangularis)"),
    ("AU17", {"mentalis": 1.0}, None, "chin raiser: mentalis"),
    ("AU18", {"orbicularis_oris": 1.0}, None,
     "lip pucker: incisivii labii superioris and inferioris (orbicularis oris)"),
    ("AU22", {"orbicularis_oris": 0.5}, None, "lip funneler: orbicularis oris"),
    ("AU23", {"orbicularis_oris": 1.0}, None, "lip tightener: orbicularis oris"),
    ("AU24", {"orbicularis_oris": 0.5}, None, "lip pressor: orbicularis oris"),
)


def _sided(name: str, muscles: Mapping[str, float]) -> dict[str, dict[str, float]]:
    """``{nameLeft: the _L muscles, nameRight: the _R ones}`` (unsided muscles on both)."""
    out = {}
    for side, own in (("Left", "_L"), ("Right", "_R")):
        out[name + side] = {(m[:-2] + own if m.endswith(("_L", "_R")) else m): w
                            for m, w in muscles.items() if not m.endswith(("_L", "_R"))
                            or m.endswith("_L")}
    return out


def _blendshape_default() -> dict[str, ChannelMap]:
    """ARKit blendshapes by the action unit each is (Left: the subject's left, ``_L``)."""
    au = {a: (m, c) for a, m, c, _ in FACS_DEFAULT}
    out: dict[str, ChannelMap] = {"browInnerUp": ChannelMap(au["AU01"][0])}
    half = ((0.0, 0.0), (1.0, 0.5))
    for name, a, curve in (("browOuterUp", "AU02", None), ("cheekSquint", "AU06", None),
                           ("eyeSquint", "AU07", None), ("noseSneer", "AU09", None),
                           ("mouthUpperUp", "AU10", None), ("mouthSmile", "AU12", None),
                           ("mouthFrown", "AU15", None), ("mouthPress", "AU24", None)):
        muscles, own = au[a]
        for key, ms in _sided(name, muscles).items():
            out[key] = ChannelMap(ms, own or curve or ((0.0, 0.0), (1.0, 1.0)))
    for key, ms in _sided("browDown", {"corrugator_L": 1.0, "procerus": 0.5}).items():
        out[key] = ChannelMap(ms)  # AU4 by side: that side's corrugator, half the procerus
    out["mouthShrugLower"] = ChannelMap({"mentalis": 1.0})  # AU17
    out["mouthPucker"] = ChannelMap({"orbicularis_oris": 1.0})  # AU18
    out["mouthFunnel"] = ChannelMap({"orbicularis_oris": 1.0}, half)  # AU22
    return out


def default_mapping() -> TrackMapping:
    """The default mapping: the action units of :data:`FACS_DEFAULT` and the ARKit
    blendshapes that are those action units (``browInnerUp`` AU1, ``browOuterUp*`` AU2,
    ``browDown*`` AU4, ``cheekSquint*`` AU6, ``eyeSquint*`` AU7, ``noseSneer*`` AU9,
    ``mouthUpperUp*`` AU10, ``mouthSmile*`` AU12, ``mouthFrown*`` AU15,
    ``mouthShrugLower`` AU17, ``mouthPucker`` AU18, ``mouthFunnel`` AU22, ``mouthPress*``
    AU24). Action units with no muscle on the built-in faces (AU5 the lids, AU14 the
    buccinator, AU20 risorius, AU25-27 and the jaw, AU45 the blink) drive nothing.
    """
    channels = {a: ChannelMap(m, c or ((0.0, 0.0), (1.0, 1.0))) for a, m, c, _ in FACS_DEFAULT}
    channels.update(_blendshape_default())
    return TrackMapping(channels)


# ---------------------------------------------------------------------------- playing
@dataclass(frozen=True)
class Performance(Expression):
    """A track played on a face: an :class:`Expression` whose :meth:`at` follows the
    track (linear between its frames) and whose ``activations`` are each muscle's peak.

    ``onset_s`` and ``release_s`` are 0 and ``hold_s`` the track's duration, so
    :attr:`duration_s` is the track's.

    Parameters
    ----------
    times : (k,) float
        The frames' times, seconds from the first.
    table : (k, M) float
        The activations of ``muscle_order`` at ``times``.
    muscle_order : tuple of str
        The ``M`` muscles of ``table``'s columns.
    track, mapping : Track and TrackMapping, optional
        What ``table`` was made from (:func:`performance`), for :meth:`remapped`.
    """

    times: np.ndarray = field(default_factory=lambda: np.zeros(1))
    table: np.ndarray = field(default_factory=lambda: np.zeros((1, 0)))
    muscle_order: tuple = ()
    track: Track | None = field(default=None, repr=False, compare=False)
    mapping: TrackMapping | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        super().__post_init__()
        times = np.array(self.times, float).reshape(-1)
        table = np.array(self.table, float).reshape(len(times), len(self.muscle_order))
        times.flags.writeable = table.flags.writeable = False
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "muscle_order", tuple(self.muscle_order))

    def at(self, t: float, intensity: float = 1.0) -> dict[str, float]:
        """Activations at ``t`` seconds from the first frame (first and last held)."""
        k = float(intensity)
        if not 0.0 <= k <= 1.0:
            raise ValueError(f"intensity = {k:g} is outside [0, 1]")
        t = float(t)
        i = int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0,
                        len(self.times) - 1))
        if i + 1 < len(self.times) and t > self.times[i]:
            s = (t - self.times[i]) / (self.times[i + 1] - self.times[i])
            row = (1.0 - s) * self.table[i] + s * self.table[i + 1]
        else:
            row = self.table[i]
        return {m: k * float(v) for m, v in zip(self.muscle_order, row, strict=True)}

    def envelope(self, t: float) -> float:
        """1: the track itself rises and falls."""
        return 1.0

    def remapped(self, mapping: TrackMapping) -> Performance:
        """The same track through ``mapping`` (same name, frames and muscles); this one
        when ``mapping`` is the one it was made with, or when it keeps no track.
        """
        if self.track is None or mapping is self.mapping or mapping == self.mapping:
            return self
        out = performance(self.track, mapping, self.muscle_order, name=self.name)
        return dataclasses.replace(out, description=self.description)

    def __eq__(self, other) -> bool:
        """The same expression fields, muscles, times and activations."""
        return (isinstance(other, Performance) and self.to_dict() == other.to_dict()
                and self.muscle_order == other.muscle_order
                and np.array_equal(self.times, other.times)
                and np.array_equal(self.table, other.table))

    __hash__ = None  # type: ignore[assignment]  # equal by value, so unhashable


def performance(track: Track, mapping: TrackMapping, muscles: Sequence[str], *,
                fps: float | None = None, smooth_s: float = 0.0,
                name: str | None = None) -> Performance:
    """``track`` through ``mapping`` on ``muscles``, at its own frames or resampled to
    ``fps`` (with ``smooth_s``, :meth:`Track.resampled`).
    """
    if fps is not None:
        track = track.resampled(fps, smooth_s)
    elif smooth_s:
        raise ValueError("smoothing needs a frame rate: pass fps=... with smooth_s")
    muscles = tuple(muscles)
    acts = mapping.activations(track, muscles)
    peak = {m: float(acts[:, j].max()) for j, m in enumerate(muscles) if acts[:, j].max() > 0}
    label = name or (Path(track.source).stem if track.source else "track")
    return Performance(label, peak, onset_s=0.0, hold_s=track.duration_s, release_s=0.0,
                       description=f"{track.format or 'recorded'} track, {track.n_frames} "
                                   f"frames", times=track.times, table=acts,
                       muscle_order=muscles, track=track, mapping=mapping)


def iter_activations(track: Track, mapping: TrackMapping, muscles: Sequence[str], *,
                     fps: float | None = None,
                     smooth_s: float = 0.0) -> Iterator[tuple[float, dict[str, float]]]:
    """``(t, {muscle: activation})`` for every frame (the track's, or at ``fps``)."""
    perf = performance(track, mapping, muscles, fps=fps, smooth_s=smooth_s)
    for t, row in zip(perf.times, perf.table, strict=True):
        yield float(t), dict(zip(perf.muscle_order, map(float, row), strict=True))
