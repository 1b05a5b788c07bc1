"""Recorded tracks: the four readers, the documented handling of imperfect files, the
mapping from channels to muscles and a track played on the built-in faces.
"""

import csv
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import wrinkle_vis as wv
from wrinkle_vis.core.tracks import (
    ARKIT_BLENDSHAPES,
    ChannelMap,
    Track,
    TrackError,
    TrackMapping,
    TrackWarning,
    default_mapping,
    performance,
    read_track,
    write_track,
)

OPENFACE = Path(__file__).resolve().parents[1].parent / "shared" / "tracks" / \
    "openface_test.csv"
LLSAN = "levator_labii_superioris_alaeque_nasi"


def _quiet(path, *args, **kwargs):
    """read_track that expects no note at all (warnings are errors in this suite)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", TrackWarning)
        return read_track(path, *args, **kwargs)


def _one_line(exc_info) -> str:
    text = str(exc_info.value)
    assert "\n" not in text and text
    return text


# ---------------------------------------------------------------------------- readers
def _sample_track(channels, n=7, seed=0) -> Track:
    rng = np.random.default_rng(seed)
    times = np.cumsum(np.r_[0.0, rng.uniform(0.02, 0.05, n - 1)])
    return Track(times, channels, rng.uniform(0, 1, (n, len(channels))))


@pytest.mark.parametrize("fmt, channels", [
    ("openface", ("AU01", "AU04", "AU12")),
    ("pyfeat", ("AU01", "AU02", "AU17")),
    ("arkit", ARKIT_BLENDSHAPES),
    ("mediapipe", ("browInnerUp", "noseSneerLeft", "mouthSmileRight")),
])
def test_every_format_round_trips(tmp_path, fmt, channels):
    track = _sample_track(channels)
    path = tmp_path / f"{fmt}.csv"
    write_track(track, path, fmt)
    back = _quiet(path, fps=60 if fmt == "arkit" else None)
    assert back.format == fmt and back.channels == track.channels
    assert np.allclose(back.times, track.times, atol=1e-9)
    assert np.allclose(back.values, track.values, atol=1e-12)


def test_each_format_is_recognised_from_its_header(tmp_path):
    for fmt, channels in (("openface", ("AU01",)), ("pyfeat", ("AU01",)),
                          ("arkit", ("browInnerUp",)), ("mediapipe", ("browInnerUp",))):
        path = tmp_path / f"{fmt}.csv"
        write_track(_sample_track(channels), path, fmt)
        if fmt == "arkit":
            with pytest.warns(TrackWarning, match="timecode rate is taken as 24"):
                assert read_track(path).format == fmt
        else:
            assert _quiet(path).format == fmt


def test_live_link_face_schema_with_head_rotation_and_timecodes(tmp_path):
    """Live Link Face's header (capitalised names, BlendShapeCount, head and eye angles)
    and HH:MM:SS:FF.fff timecodes at 60 frames a second.
    """
    names = [n[0].upper() + n[1:] for n in ARKIT_BLENDSHAPES]
    extra = ["HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll",
             "RightEyeYaw", "RightEyePitch", "RightEyeRoll"]
    rows = [["Timecode", "BlendShapeCount", *names, *extra]]
    codes = ["17:58:46:58.500", "17:58:46:59.500", "17:58:47:00.500", "17:58:47:01.500"]
    for k, code in enumerate(codes):
        rows.append([code, 61, *[0.01 * k] * 52, *[0.3] * 9])
    path = tmp_path / "take.csv"
    with path.open("w", newline="") as f:
        csv.writer(f).writerows(rows)
    track = _quiet(path, fps=60)
    assert track.format == "arkit" and track.channels == ARKIT_BLENDSHAPES
    assert np.allclose(track.times, np.arange(4) / 60)
    assert track.start_s == pytest.approx(17 * 3600 + 58 * 60 + 46 + 58.5 / 60)
    assert np.allclose(track.channel("browInnerUp"), 0.01 * np.arange(4))


def test_pyfeat_frames_need_a_rate(tmp_path):
    path = tmp_path / "fex.csv"
    path.write_text("frame,FaceScore,AU01,AU12,happiness\n0,0.99,0.1,0.5,0.7\n"
                    "1,0.99,0.2,0.6,0.7\n2,0.99,0.3,0.7,0.7\n")
    with pytest.raises(TrackError) as exc:
        read_track(path)
    assert "fps" in _one_line(exc)
    track = _quiet(path, fps=25)
    assert np.allclose(track.times, [0, 0.04, 0.08]) and track.channels == ("AU01", "AU12")
    assert np.allclose(track.channel("AU12"), [0.5, 0.6, 0.7])


def test_the_real_openface_file(tmp_path):
    """100 frames, times and AU intensities as the csv module reads them (divided by 5)."""
    track = _quiet(OPENFACE)
    with OPENFACE.open(newline="") as f:
        rows = list(csv.reader(f))
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    assert track.format == "openface" and track.n_frames == len(body) == 100
    stamps = np.array([float(r[header.index("timestamp")]) for r in body])
    assert np.allclose(track.times, stamps - stamps[0]) and track.start_s == stamps[0]
    assert track.duration_s == pytest.approx(0.099)
    aus = [h for h in header if h.startswith("AU") and h.endswith("_r")]
    assert track.channels == tuple(h[:4] for h in aus) and len(aus) == 17
    for h in aus:
        expected = np.array([float(r[header.index(h)]) for r in body]) / 5.0
        assert np.allclose(track.channel(h[:4]), expected), h
    assert track.channel("AU01")[0] == pytest.approx(0.6773 / 5)


# ---------------------------------------------------------------------------- imperfect
HEAD = "frame, timestamp, confidence, success, AU01_r, AU12_r\n"


def _openface(tmp_path, body: str, name="of.csv") -> Path:
    path = tmp_path / name
    path.write_text(HEAD + body)
    return path


def test_failed_frames_are_interpolated_and_noted(tmp_path):
    path = _openface(tmp_path, "1, 0.0, 0.9, 1, 1.0, 0\n2, 0.1, 0.1, 0, 4.9, 5\n"
                               "3, 0.2, 0.9, 1, 2.0, 0\n")
    with pytest.warns(TrackWarning, match="1 frame.*failed.*line 3"):
        track = read_track(path)
    assert np.allclose(track.channel("AU01"), [0.2, 0.3, 0.4])
    assert np.allclose(track.channel("AU12"), 0.0)
    assert any("failed" in n for n in track.notes)


def test_nan_and_empty_values_are_interpolated_and_held_at_the_ends(tmp_path):
    path = _openface(tmp_path, "1, 0.0, 0.9, 1, , 1\n2, 0.1, 0.9, 1, 1.0, nan\n"
                               "3, 0.2, 0.9, 1, 3.0, 3\n")
    with pytest.warns(TrackWarning, match="2 empty or NaN"):
        track = read_track(path)
    assert np.allclose(track.channel("AU01"), [0.2, 0.2, 0.6])
    assert np.allclose(track.channel("AU12"), [0.2, 0.4, 0.6])


def test_gaps_are_interpolated_across_and_noted(tmp_path):
    path = _openface(tmp_path, "".join(f"{i}, {t}, 0.9, 1, {t}, 0\n" for i, t in
                                       enumerate([0.0, 0.1, 0.2, 1.0, 1.1])))
    with pytest.warns(TrackWarning, match="gap.*0.8 s between lines 4 and 5"):
        track = read_track(path)
    assert track.at(0.6)[0] == pytest.approx(0.12)


def test_repeated_rows_are_dropped_conflicting_ones_refused(tmp_path):
    same = _openface(tmp_path, "1, 0.0, 0.9, 1, 1, 0\n1, 0.0, 0.9, 1, 1, 0\n"
                               "2, 0.1, 0.9, 1, 2, 0\n")
    with pytest.warns(TrackWarning, match="dropped 1 row.*line 3"):
        assert read_track(same).n_frames == 2
    other = _openface(tmp_path, "1, 0.0, 0.9, 1, 1, 0\n1, 0.0, 0.9, 1, 4, 0\n", "b.csv")
    with pytest.raises(TrackError) as exc:
        read_track(other)
    assert "line 3" in _one_line(exc) and "two faces" in str(exc.value)


def test_time_going_back_is_refused_naming_the_row(tmp_path):
    path = _openface(tmp_path, "1, 0.0, 0.9, 1, 1, 0\n2, 0.2, 0.9, 1, 1, 0\n"
                               "3, 0.1, 0.9, 1, 1, 0\n")
    with pytest.raises(TrackError) as exc:
        read_track(path)
    assert "line 4" in _one_line(exc) and "sort the rows by time" in str(exc.value)


def test_unknown_columns_are_ignored_and_noted(tmp_path):
    path = tmp_path / "extra.csv"
    path.write_text("frame, timestamp, success, AU01_r, my_notes\n1, 0.0, 1, 1, hi\n"
                    "2, 0.1, 1, 2, there\n")
    with pytest.warns(TrackWarning, match="ignored 1 column.*my_notes"):
        assert read_track(path).channels == ("AU01",)


def test_values_out_of_scale_are_clipped_and_noted(tmp_path):
    path = _openface(tmp_path, "1, 0.0, 0.9, 1, 6, -1\n2, 0.1, 0.9, 1, 2, 0\n")
    with pytest.warns(TrackWarning, match="clipped 2 value"):
        track = read_track(path)
    assert track.channel("AU01")[0] == 1.0 and track.channel("AU12")[0] == 0.0


@pytest.mark.parametrize("content, match", [
    ("", "empty"),
    ("  \n\n", "empty"),
    (HEAD, "no frames"),
    ('{"format": "wrinkle-vis-layout",\n "version": 1}\n', "not a track this reads"),
    ("name,score\nada,3\n", "not a track this reads"),
    (HEAD + "1, x, 0.9, 1, 1, 0\n", "line 2.*timestamp.*not a number"),
    (HEAD + "1, , 0.9, 1, 1, 0\n", "line 2: no time"),
    (HEAD + "1, 0.0, 0.9, 1, abc, 0\n", "line 2, column 'AU01_r'"),
    (HEAD + "1, 0.0, 0.9, 1, 1\n", "line 2: 5 fields under a header of 6"),
    (HEAD + "1, 0.0, 0.9, 0, 1, 0\n", "every frame is marked as failed"),
    ("frame, timestamp, AU01_r\n1, 0.0, \n2, 0.1, \n", "AU01: no frame has a value"),
])
def test_bad_files_get_one_line_errors(tmp_path, content, match):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(TrackError, match=match) as exc:
        read_track(path)
    assert _one_line(exc).startswith(str(path))


def test_binary_huge_and_missing_files(tmp_path):
    binary = tmp_path / "video.mp4"
    binary.write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)))
    with pytest.raises(TrackError, match="binary file") as exc:
        read_track(binary)
    _one_line(exc)
    huge = tmp_path / "huge.csv"
    with huge.open("wb") as f:
        f.truncate(100 * 2**20)  # 100 MB, sparse: refused before it is read
    with pytest.raises(TrackError, match="100.0 MiB.*max_bytes") as exc:
        read_track(huge)
    _one_line(exc)
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_track(tmp_path / "none.csv")
    with pytest.raises(TrackError, match="unknown track format 'bvh'"):
        read_track(OPENFACE, format="bvh")
    with pytest.raises(TrackError, match="not an ARKit"):
        read_track(OPENFACE, format="arkit")


# ---------------------------------------------------------------------------- the track
def test_at_interpolates_and_resampling_counts_frames():
    track = Track([0.0, 1.0, 3.0], ["AU01"], [[0.0], [1.0], [0.0]])
    assert track.at(0.5)[0] == 0.5 and track.at(2.0)[0] == 0.5
    assert track.at(-1.0)[0] == 0.0 and track.at(9.0)[0] == 0.0  # ends held
    assert np.allclose(track.at([0.25, 2.5])[:, 0], [0.25, 0.25])
    for fps in (1, 7, 30, 24.5):
        r = track.resampled(fps)
        assert r.n_frames == math.floor(3.0 * fps + 1e-9) + 1
        assert np.allclose(r.values[:, 0], track.at(r.times)[:, 0])
    smooth = track.resampled(30, smooth_s=0.2)
    assert smooth.values.max() < 1.0 and smooth.values.min() >= 0.0
    flat = Track([0.0, 1.0], ["AU01"], [[0.4], [0.4]]).resampled(30, smooth_s=0.3)
    assert np.allclose(flat.values, 0.4)  # smoothing keeps a constant


# ---------------------------------------------------------------------------- mapping
def test_mapping_sums_weighted_curved_channels_and_clips():
    mapping = TrackMapping({"AU01": ChannelMap({"a": 1.0, "b": 0.5}),
                            "AU02": ChannelMap({"b": 1.0}, ((0, 0), (0.5, 1), (1, 1)))})
    track = Track([0, 1], ["AU01", "AU02", "AU99"], [[0.2, 0.2, 1.0], [0.8, 0.8, 1.0]])
    acts = mapping.activations(track, ["a", "b", "c"])
    assert np.allclose(acts, [[0.2, 0.1 + 0.4, 0.0], [0.8, 1.0, 0.0]])  # 0.4 + 1 clipped
    assert mapping.drives("AU99") == {} and mapping.drives("AU01") == {"a": 1.0, "b": 0.5}
    again = TrackMapping.from_dict(json.loads(json.dumps(mapping.to_dict())))
    assert again == mapping
    with pytest.raises(ValueError, match="AU02.*curve"):
        TrackMapping.from_dict({"AU02": {"muscles": {}, "curve": [[0, 0], [0.5, 1]]}})
    with pytest.raises(ValueError, match="outside"):
        ChannelMap({"a": 2.0})


def test_default_mapping_follows_facs_onto_both_faces():
    mapping = default_mapping()
    assert set(mapping.drives("AU04")) == {"corrugator_L", "corrugator_R", "procerus"}
    assert set(mapping.drives("AU09")) == {f"{LLSAN}_L", f"{LLSAN}_R"}
    assert mapping.drives("AU17") == {"mentalis": 1.0}
    assert set(mapping.drives("AU12")) == {"zygomaticus_major_L", "zygomaticus_major_R"}
    assert set(mapping.drives("AU06")) == {"orbicularis_oculi_L", "orbicularis_oculi_R"}
    assert mapping.drives("noseSneerLeft") == {f"{LLSAN}_L": 1.0}
    assert mapping.drives("browDownRight") == {"corrugator_R": 1.0, "procerus": 0.5}
    assert mapping.drives("AU45") == {}  # the blink moves no wrinkling muscle
    from wrinkle_vis.datasets.lee_perry_smith import LAYOUT

    for layout in (wv.datasets.BUILTIN_LAYOUT, LAYOUT):
        lay = wv.load_layout(layout)
        assert lay.mapping == mapping  # kept in the layout file
        assert set(mapping.muscle_names) <= {m.name for m in lay.muscles}


def test_the_layout_keeps_its_mapping_and_checks_it(tmp_path):
    lay = wv.load_layout(wv.datasets.BUILTIN_LAYOUT)
    data = lay.to_dict()
    data["mapping"] = {"AU04": {"muscles": {"corrugator_L": 0.7}, "curve": [[0, 0], [1, .5]]}}
    path = tmp_path / "lay.json"
    path.write_text(json.dumps(data))
    back = wv.load_layout(path)
    assert back.mapping.drives("AU04") == {"corrugator_L": 0.7}
    assert back.mapping.channels["AU04"].curve == ((0, 0), (1, 0.5))
    data["mapping"] = {"AU04": {"muscles": {"risorius": 1.0}}}
    path.write_text(json.dumps(data))
    with pytest.raises(wv.LayoutError, match=r"\$\.mapping\.AU04\.muscles\.risorius"):
        wv.load_layout(path)
    del data["mapping"]  # optional: an older layout reads as before
    path.write_text(json.dumps(data))
    assert wv.load_layout(path).mapping is None
    fewer = wv.Layout(muscles=lay.muscles[:2], mapping=lay.mapping)
    assert set(fewer.mapping.muscle_names) <= {m.name for m in lay.muscles[:2]}


# ---------------------------------------------------------------------------- faces
def _region(face, x_range, y_range):
    p = face.skin.points
    ax = np.abs(p[:, 0])
    return (ax >= x_range[0]) & (ax <= x_range[1]) & (p[:, 1] >= y_range[0]) & \
        (p[:, 1] <= y_range[1]) & (p[:, 2] > 40)


def test_forehead_w_follows_au01_and_au02(wv_face):
    """A synthetic track whose AU01 and AU02 rise and fall at different times: the
    frame-wise mean forehead |W| correlates with AU01 + AU02.
    """
    t = np.linspace(0.0, 2.0, 21)
    au1 = np.exp(-((t - 0.6) / 0.3) ** 2)
    au2 = 0.8 * np.exp(-((t - 1.3) / 0.35) ** 2)
    track = Track(t, ["AU01", "AU02", "AU12"], np.column_stack([au1, au2, 0 * t]))
    forehead = _region(wv_face, (0, 45), (35, 80))
    # the mapping's work, the same on either skin: the geometric one is the quicker
    mean_w = [np.abs(s.W[forehead]).mean() for s in wv_face.play(track, skin="geometric")]
    r = np.corrcoef(mean_w, au1 + au2)[0, 1]
    assert r >= 0.8, r
    assert np.abs(wv_face.evaluate().W).max() == 0.0


@pytest.fixture(scope="module")
def head(wv_head):
    return wv_head.with_skin_model(wv_head.skin_model)  # the session's caches (conftest)


@pytest.mark.parametrize("which", ["procedural", "lee_perry_smith"])
@pytest.mark.parametrize("channels, x_range, y_range", [
    ({"AU04": 1.0}, (0, 12), (10, 32)),  # glabella: corrugator and procerus furrows
    ({"AU09": 1.0}, (3, 18), (-32, 6)),  # the sides of the nose
    ({"AU12": 1.0, "AU06": 1.0}, (42, 70), (-15, 12)),  # crow's feet
    ({"AU17": 1.0}, (0, 14), (-100, -75)),  # the chin
])
def test_action_units_wrinkle_their_regions(wv_face, head, which, channels, x_range,
                                            y_range):
    face = wv_face if which == "procedural" else head
    track = Track([0.0, 1.0], list(channels), [[0.0] * len(channels), list(channels.values())])
    first, last = list(face.play(track, skin="geometric"))  # the mapping's work: any skin
    inside = _region(face, x_range, y_range)
    assert np.abs(first.W).max() == 0.0
    assert np.abs(last.W[inside]).max() > 0.05  # mm
    assert np.abs(last.W[inside]).max() >= 0.9 * np.abs(last.W).max()  # mostly there


def test_new_muscles_are_in_no_existing_expression(wv_face):
    new = {f"{LLSAN}_L", f"{LLSAN}_R", "procerus", "mentalis"}
    assert new <= set(wv_face.muscle_names)
    for ex in wv_face.expressions.values():
        assert not new & set(ex.activations), ex.name


def test_play_at_a_frame_rate_and_through_a_face_mapping(wv_face):
    track = Track([0.0, 0.5], ["AU04"], [[0.0], [1.0]])
    states = list(wv_face.play(track, fps=10))
    assert len(states) == 6
    assert [s.activations["procerus"] for s in states] == pytest.approx(np.arange(6) / 5)
    only_left = TrackMapping({"AU04": ChannelMap({"corrugator_L": 1.0, "nasalis": 1.0})})
    last = list(wv_face.play(track, mapping=only_left))[-1]
    assert last.activations["corrugator_L"] == 1.0 and last.activations["procerus"] == 0.0
    perf = performance(track, default_mapping(), wv_face.muscle_names, fps=4)
    assert perf.duration_s == 0.5 and perf.activations["procerus"] == 1.0
    assert perf.at(0.25)["corrugator_R"] == pytest.approx(0.5)
    assert perf.at(0.1)["procerus"] == pytest.approx(0.2)  # linear between frames
    assert perf.at(-1.0)["procerus"] == 0.0 and perf.at(9.0)["procerus"] == 1.0  # held
    assert perf.at(0.5, intensity=0.5)["procerus"] == 0.5
    assert perf == performance(track, default_mapping(), wv_face.muscle_names, fps=4)
    assert perf != performance(track, default_mapping(), wv_face.muscle_names, fps=8)


@pytest.mark.parametrize("which", ["procedural", "lee_perry_smith"])
def test_the_procerus_alone_lines_the_root_of_the_nose(wv_face, head, which):
    """AU4's procerus: furrows across the midline between the brows, where the corrugators'
    vertical furrows (either side) are not.
    """
    face = wv_face if which == "procedural" else head
    w = face.evaluate({"procerus": 1.0}).W
    root = _region(face, (0, 6), (6, 26))
    assert np.abs(w[root]).max() > 0.05 and np.abs(w[root]).max() == np.abs(w).max()
    assert np.abs(w[_region(face, (0, 60), (35, 200))]).max(initial=0) == 0.0  # not above


def test_a_track_fading_to_a_vanishing_activation_refines_every_frame(wv_face):
    """sin(pi t)^2 ends at 1.5e-32, not 0: a muscle that active bends no triangle, and the
    refinement's normals of no triangles were integers (a UFuncTypeError).
    """
    t = np.linspace(0.0, 1.0, 3)
    track = Track(t, ["AU04"], np.sin(np.pi * t)[:, None] ** 2)
    assert 0.0 < track.values[-1, 0] < 1e-30
    states = list(wv_face.play(track, refine=True))
    assert np.abs(states[-1].W).max() < 1e-20 < np.abs(states[1].W).max()


@pytest.mark.parametrize("which", ["procedural", "lee_perry_smith"])
def test_no_triangle_turns_over_under_the_new_action_units(wv_face, head, which):
    """AU4, AU9 and AU17 at full intensity, refined: the wrinkled skin keeps every
    triangle's orientation (the nose wrinkler at strength 5 turned 42 over on the head).
    """
    from wrinkle_vis.core.analysis import turned_over

    face = wv_face if which == "procedural" else head
    for au in ("AU04", "AU09", "AU17"):
        state = next(face.play(Track([0.0], [au], [[1.0]]), refine=True))
        skin = state.face.skin
        assert not turned_over(skin, skin.points, state.points).any(), au
