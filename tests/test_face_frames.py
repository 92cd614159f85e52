"""Frames a participant can read (issue 34, section 1): apexes checked against Greta's face
library and FACS, every face signal of every bundled emotion visible against the neutral
face in the region its units move, hands at the face for hand-to-face gestures, a bow seen
from the front, saccadic scanning, back-to-back occurrences held, frames without text."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mse.api
from mse.export import ExportOptions
from mse.export.face.actions import Action
from mse.export.face.body import compile_half_body, default_half_body
from mse.export.face.lexicon import Resolver, bundled_table
from mse.export.face.raster import face_image, face_scale
from mse.export.face.rig import Rig, default_rig, pose_model, pose_points, project
from mse.export.face.track import build_track, key_weight
from mse.export.lexemes import modality_of, split_lexeme
from mse.export.realizer_libraries import load_face_library
from mse.resources import bundled_names
from mse.timeline import Timeline, TimelineSignal

pytest.importorskip("aggdraw", reason="the video extra is not installed")

FACE_SIZE = (400, 440)
BODY_SIZE = (480, 608)
#: A pixel "changed" when one of its channels moved this many levels (of 255).
LEVELS = 40


@pytest.fixture(scope="module")
def rig() -> Rig:
    return default_rig()


def _values(rig: Rig, action: Action, weight: float = 1.0) -> np.ndarray:
    values = rig.zero()
    index = rig.channel_index
    for channel, value in action.targets:
        values[index[channel]] += weight * value
    return values


def _face_signals() -> list[tuple[str, str, Action]]:
    """(set, lexeme, action) of every face signal of every bundled set."""
    resolver = Resolver()
    found = []
    for name in bundled_names():
        for signal in mse.api.load(name, cache=True).signals:
            modality = modality_of(signal.modality, split_lexeme(signal.lexeme))
            action = resolver.resolve(signal.lexeme, modality)
            if modality == "face" and action is not None and action.units:
                found.append((name, signal.lexeme, action))
    return found


def _changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(np.int16) - b.astype(np.int16)).max(axis=2) > LEVELS


def _unit_region(rig: Rig, action: Action, size: tuple[int, int]) -> tuple[int, int, int, int]:
    """Pixel box of the points the action's units move (neutral and apex), with a margin."""
    moved = np.zeros(len(rig.names), dtype=bool)
    index = rig.channel_index
    for channel, value in action.targets:
        if channel.startswith("AU") and value:
            moved |= np.any(rig.deltas[index[channel]] != 0.0, axis=1)
    scale, dx, dy = face_scale(rig, size)
    points = np.concatenate([pose_points(rig, rig.zero())[moved], pose_points(rig, _values(rig, action))[moved]])
    points = points * scale + np.array([dx, dy])
    left, top = np.floor(points.min(axis=0)).astype(int) - 6
    right, bottom = np.ceil(points.max(axis=0)).astype(int) + 6
    return max(0, left), max(0, top), min(size[0], right), min(size[1], bottom)


# -- apexes against Greta's face library and FACS --------------------------------------------
def _eye_aperture(rig: Rig, values: np.ndarray) -> float:
    """Upper to lower lid at the eye's middle (model units, both eyes)."""
    model = pose_model(rig, values)
    names = rig.names
    return sum(
        float(model[names.index(f"eye.lo2.{s}"), 1] - model[names.index(f"eye.up2.{s}"), 1]) for s in "LR"
    )


def _brow_height(rig: Rig, values: np.ndarray) -> float:
    model = pose_model(rig, values)
    return -sum(float(model[rig.names.index(f"brow.in.lo.{s}"), 1]) for s in "LR")


def _strongest(units: tuple[tuple[int, float, str], ...]) -> dict[int, float]:
    found: dict[int, float] = {}
    for number, intensity, _ in units:
        found[number] = max(found.get(number, 0.0), intensity)
    return found


@pytest.fixture(scope="module")
def greta_faces(greta_dir: Path) -> dict[str, dict[int, float]]:
    """Greta's expressions (instance name in lower case) -> action unit -> intensity, the units
    the rig draws only."""
    from mse.export.face.actions import unit_targets

    library = load_face_library(greta_dir / "facelibrary.xml")
    faces: dict[str, dict[int, float]] = {}
    for (klass, instance), units in library.entries.items():
        if klass != "faceexp":
            continue
        drawn = {u.number: u.intensity for u in units if unit_targets(u.number, u.side, u.intensity)[1]}
        strongest: dict[int, float] = {}
        for unit in units:
            if unit.number in drawn:
                strongest[unit.number] = max(strongest.get(unit.number, 0.0), unit.intensity)
        faces[instance] = strongest
    return faces


#: FACS antagonists: units that move the same feature in opposite directions (upper lid up
#: against lids tightened or closed, lip corners up against down, lips apart against pressed).
ANTAGONISTS: tuple[tuple[int, int], ...] = ((5, 7), (5, 43), (12, 15), (25, 24), (26, 24))


def _agrees(ours: dict[int, float], greta: dict[int, float]) -> list[str]:
    """Greta's units of at least 0.25 that ours lack or show at under half Greta's intensity;
    a unit Greta pairs with an antagonist at least as strong is not one reading of the face,
    and is not compared."""

    def contradicted(unit: int, level: float) -> bool:
        return any(
            greta.get(b if a == unit else a, 0.0) >= level for a, b in ANTAGONISTS if unit in (a, b)
        )

    return [
        f"AU{unit} {ours.get(unit, 0.0):g} < half of Greta's {level:g}"
        for unit, level in sorted(greta.items())
        if level >= 0.25 and ours.get(unit, 0.0) < 0.5 * level and not contradicted(unit, level)
    ]


def test_bundled_lexemes_named_like_a_greta_expression_carry_its_units(
    greta_faces: dict[str, dict[int, float]],
) -> None:
    table = bundled_table()
    compared = 0
    for name, action in table.items():
        if name in greta_faces and action.units:
            compared += 1
            differences = _agrees(_strongest(action.units), greta_faces[name])
            assert not differences, (name, differences)
    assert compared >= 4  # anger, fear, surprise, joy, eyebrows_frown...


def test_every_bundled_set_with_a_greta_expression_shows_its_units(
    greta_faces: dict[str, dict[int, float]],
) -> None:
    """The union of a set's face signals at their apexes carries the units of Greta's
    expression of the same name (anger: AU4, AU5, AU7, AU23; relief: AU43, AU25, AU26, AU12;
    pride: AU6, AU12; tension: AU24...)."""
    compared = []
    for name in bundled_names():
        if name not in greta_faces:
            continue
        union: dict[int, float] = {}
        for set_name, _, action in _face_signals():
            if set_name == name:
                for unit, level in _strongest(action.units).items():
                    union[unit] = max(union.get(unit, 0.0), level)
        assert not _agrees(union, greta_faces[name]), (name, _agrees(union, greta_faces[name]))
        compared.append(name)
    assert len(compared) >= 5, compared


def test_an_open_mouth_of_an_emotion_without_raised_lids_is_not_surprise(
    rig: Rig, greta_faces: dict[str, dict[int, float]]
) -> None:
    """FACS surprise is brows up (AU1+2), lids up (AU5) and a dropped jaw (AU26).  A set whose
    Greta expression has no lid raiser (relief...) must not open the mouth with raised brows
    or widened eyes: its jaw-dropping signals keep the eyes and brows at or below neutral."""
    neutral = rig.zero()
    checked = 0
    for name, lexeme, action in _face_signals():
        greta = greta_faces.get(name)
        if greta is None or greta.get(5, 0.0) > 0.0 or 26 not in _strongest(action.units):
            continue
        apex = _values(rig, action)
        assert _eye_aperture(rig, apex) <= _eye_aperture(rig, neutral) + 1e-9, (name, lexeme)
        assert _brow_height(rig, apex) <= _brow_height(rig, neutral) + 1e-9, (name, lexeme)
        checked += 1
    assert checked >= 1


def test_lowered_brows_come_with_tightened_lids_not_wide_eyes(rig: Rig) -> None:
    """FACS anger: brows lowered and drawn together (AU4) with the lids tightened (AU7); when
    AU4 leads the brows (stronger than AU1 and AU2), the eyes must not open wider than at rest
    (the weak, wide-eyed frown read as surprise)."""
    neutral = _eye_aperture(rig, rig.zero())
    checked = 0
    for name, action in bundled_table().items():
        units = _strongest(action.units)
        if units.get(4, 0.0) >= 0.5 and units[4] > max(units.get(1, 0.0), units.get(2, 0.0)):
            assert _eye_aperture(rig, _values(rig, action)) < neutral, name
            checked += 1
    assert checked >= 4


# -- frames: the apex of every face signal differs from the neutral face -----------------------
def _signal_id(value: object) -> str:
    return value if isinstance(value, str) else ""


@pytest.mark.parametrize(("name", "lexeme", "action"), _face_signals(), ids=_signal_id)
def test_each_face_signal_apex_differs_visibly_from_neutral(name: str, lexeme: str, action: Action, rig: Rig) -> None:
    neutral = np.asarray(face_image(rig, rig.zero(), FACE_SIZE))
    apex = np.asarray(face_image(rig, _values(rig, action), FACE_SIZE))
    left, top, right, bottom = _unit_region(rig, action, FACE_SIZE)
    changed = _changed(neutral, apex)
    inside = int(changed[top:bottom, left:right].sum())
    # At least 150 clearly changed pixels (a 400x440 face) in the region the units move,
    # and most of the change is there.
    assert inside >= 150, (name, lexeme, inside)
    units_only = all(channel.startswith("AU") for channel, _ in action.targets)
    assert inside >= 0.6 * int(changed.sum()) or not units_only


def test_each_face_signal_apex_is_visible_in_the_half_body_view_too(rig: Rig) -> None:
    body = default_half_body()
    neutral = np.asarray(face_image(rig, rig.zero(), BODY_SIZE, body))
    for name, lexeme, action in _face_signals():
        apex = np.asarray(face_image(rig, _values(rig, action), BODY_SIZE, body))
        assert int(_changed(neutral, apex).sum()) >= 60, (name, lexeme)


# -- hands at the face ----------------------------------------------------------------------
def _head_places(rig: Rig) -> set[str]:
    """Hand places on the head: their points turn with the head (head weight > 0)."""
    return {p for p in rig.places if rig.head_weight[rig.names.index(f"hand.{p}.L")] > 0}


def test_hands_appear_at_the_face_for_hand_to_face_gestures(rig: Rig) -> None:
    body = default_half_body()
    framed = body.rig
    head = _head_places(rig)
    assert {"mouth", "cheek"} <= head
    resolver = Resolver()
    neutral_values = rig.zero()
    neutral = np.asarray(face_image(rig, neutral_values, BODY_SIZE, body))
    scale, dx, dy = face_scale(framed, BODY_SIZE)
    # The face's outline in the frame.
    outline = project(framed, pose_model(framed, neutral_values))[
        [framed.names.index(n) for n in framed.names if n.startswith("face.")]
    ] * scale + np.array([dx, dy])
    left, top = outline.min(axis=0).astype(int)
    right, bottom = outline.max(axis=0).astype(int)
    checked = 0
    for name in bundled_names():
        for signal in mse.api.load(name, cache=True).signals:
            action = resolver.resolve(signal.lexeme, signal.modality)
            if action is None:
                continue
            places = {c.split("@", 1)[1] for c, _ in action.targets if c.startswith("hand_")}
            if not places & head:
                continue
            apex = np.asarray(face_image(rig, _values(rig, action), BODY_SIZE, body))
            changed = _changed(neutral, apex)[top:bottom, left:right]
            # A hand covers a clear part of the face (the hand is about a fifth of its width).
            assert changed.mean() > 0.04, (name, signal.lexeme, float(changed.mean()))
            checked += 1
    assert checked >= 3  # hand_on_mouth, hands_on_face, open_flat_hand_on_mouth, hand_on_face


def test_hands_stay_at_the_mouth_while_the_head_turns(rig: Rig) -> None:
    """Head places turn with the head: the hand follows the mouth."""
    from mse.export.face.body import arm_joints

    body = default_half_body()
    action = Resolver().resolve("gesture=hand_on_mouth", "gesture")
    assert action is not None
    mouth = rig.names.index("hand.mouth.R")
    for pitch in (0.0, 15.0):
        values = _values(rig, action)
        values[rig.channel_index["head_pitch"]] = pitch
        model = pose_model(body.rig, values)
        _, _, wrist = arm_joints(body, model, values)[1]
        assert np.linalg.norm(wrist - model[mouth]) < 1.0


def test_a_bow_is_visible_from_the_front(rig: Rig) -> None:
    body = default_half_body()
    action = Resolver().resolve("torso=bow", "torso")
    assert action is not None
    framed = body.rig
    top = framed.names.index("hairf.top")
    chin = framed.names.index("face.chin")
    neutral, bowed = (project(framed, pose_model(framed, v)) for v in (rig.zero(), _values(rig, action)))
    # The head comes down and nearer (larger), the face turns down: the top of the head shows.
    assert bowed[top, 1] - neutral[top, 1] > 30
    assert bowed[chin, 1] - bowed[top, 1] < neutral[chin, 1] - neutral[top, 1] + 40
    images = [np.asarray(face_image(rig, v, BODY_SIZE, body)) for v in (rig.zero(), _values(rig, action))]
    assert _changed(*images).mean() > 0.05


def test_gestures_of_the_bundled_sets_move_the_arms(rig: Rig) -> None:
    body = default_half_body()
    resolver = Resolver()
    neutral = np.asarray(face_image(rig, rig.zero(), BODY_SIZE, body))
    for name in bundled_names():
        for signal in mse.api.load(name, cache=True).signals:
            if signal.modality != "gesture":
                continue
            action = resolver.resolve(signal.lexeme, signal.modality)
            assert action is not None, (name, signal.lexeme)
            apex = np.asarray(face_image(rig, _values(rig, action), BODY_SIZE, body))
            assert _changed(neutral, apex).mean() > 0.01, (name, signal.lexeme)


def test_arms_come_from_motion_when_the_timeline_has_it(rig: Rig) -> None:
    from mse.export.face.body import arm_motion
    from mse.export.figures import FigureClip

    joints = ("Hips", "LeftShoulder", "LeftElbow", "LeftWrist", "RightShoulder", "RightElbow", "RightWrist")
    parents = (-1, 0, 1, 2, 0, 4, 5)
    frames = 10
    positions = np.zeros((frames, len(joints), 3))
    for side, x in ((1, 20.0), (4, -20.0)):  # X to the body's left, Y up
        positions[:, side] = (x, 140.0, 0.0)
        positions[:, side + 1] = (x * 1.1, 115.0, 0.0)
        positions[:, side + 2] = (x * 1.2, 90.0, 0.0)
    positions[5:, 6] = (-20.0, 190.0, 10.0)  # the right wrist goes up over the head
    clip = FigureClip("timeline", "all", 0.0, 1.0, 10.0, joints, parents, positions)
    body = default_half_body()
    arms = arm_motion([clip], body)
    assert arms is not None
    down, up = arms.at(0.1), arms.at(0.7)
    assert down is not None and up is not None
    assert up[1, 1, 1] < -100 < down[1, 1, 1]  # the rig's y points down
    images = [np.asarray(face_image(rig, rig.zero(), BODY_SIZE, body, a)) for a in (down, up)]
    assert _changed(*images).mean() > 0.01


# -- gaze, merging, frames without text ------------------------------------------------------
def test_look_around_scans_in_saccades_with_fixations(rig: Rig) -> None:
    timeline = Timeline("t", 4.0, (TimelineSignal("s", "gaze", "gaze=look_around", 0.0, 4.0),))
    track = build_track(timeline, rig, Resolver())
    times = np.arange(0.0, 4.0, 0.005)
    gaze = track.values(times)[:, rig.channel_index["gaze_x"]]
    speed = np.abs(np.diff(gaze)) / 0.005
    apex = (times[1:] > 0.6) & (times[1:] < 3.4)
    moving = speed[apex] > 2.0  # gaze widths per second
    assert moving.mean() < 0.2  # fixations most of the time ...
    assert speed[apex].max() > 20.0  # ... joined by fast jumps
    assert len(np.unique(np.round(gaze[1:][apex][~moving], 2))) >= 3  # to several places


def test_back_to_back_occurrences_of_one_lexeme_hold(rig: Rig) -> None:
    signals = (
        TimelineSignal("a", "face", "faceexp=jaw_clench", 0.0, 2.0),
        TimelineSignal("b", "face", "faceexp=jaw_clench", 2.05, 4.0),
        TimelineSignal("c", "face", "faceexp=jaw_clench", 5.0, 6.0),
    )
    track = build_track(Timeline("t", 6.0, signals), rig, Resolver())
    assert [k.signal for k in track.keys] == ["a+b", "c"]
    held = key_weight(track.keys[0], np.arange(1.0, 3.0, 0.01))
    assert held.min() == 1.0  # no relaxing between a and b


def test_frames_without_title_carry_no_text(tmp_path: Path) -> None:
    from PIL import Image

    from mse.diagnostics import MseError
    from mse.export.video import VideoOptions, painter, render_stimulus

    timeline = Timeline("t", 2.0, (TimelineSignal("s", "face", "faceexp=smile", 0.0, 2.0),), solver="hand-made")
    titled = painter(timeline, ExportOptions(), VideoOptions(size=(320, 240), strip=False)).paint(1.0)
    bare = painter(timeline, ExportOptions(), VideoOptions(size=(320, 240), strip=False, title=False)).paint(1.0)
    header = np.asarray(titled)[:20]
    assert (header < 100).any()  # text in the title line
    background = np.asarray(Image.new("RGB", (1, 1), default_half_body().rig.background))[0, 0]
    assert (np.asarray(bare)[:20] == background).all()  # nothing but the backdrop above the head
    out = tmp_path / "still.png"
    report = render_stimulus(timeline, out, view="face", size=(200, 220), still_at=1.0)
    assert report.frames == 1
    with Image.open(out) as image:
        assert image.size == (200, 220)
    again = tmp_path / "again.png"
    render_stimulus(timeline, again, view="face", size=(200, 220), still_at=1.0)
    assert out.read_bytes() == again.read_bytes()  # deterministic
    with pytest.raises(MseError, match="a still"):
        render_stimulus(timeline, tmp_path / "still.mp4", still_at=1.0)
    clip = tmp_path / "clip.gif"
    assert render_stimulus(timeline, clip, size=(96, 120), fps=5).frames == 10
    assert clip.stat().st_size > 0


def test_unknown_view_and_place_are_clear_errors() -> None:
    from mse.diagnostics import MseError
    from mse.export.face.lexicon import parse_table
    from mse.export.video import VideoOptions, check_options

    with pytest.raises(MseError, match="unknown view"):
        check_options(VideoOptions(view="full-body"))
    with pytest.raises(MseError, match="not a hand place"):
        parse_table('[x]\nhands = { right = "knee" }\n', "t", "t.toml")
    with pytest.raises(MseError, match=r"hands\.middle"):
        parse_table('[x]\nhands = { middle = "mouth" }\n', "t", "t.toml")
    assert compile_half_body(default_rig()).rig.view_box != default_rig().view_box


def test_the_face_view_marks_the_gestures_it_does_not_draw() -> None:
    from mse.export.face.page import face_page

    signals = (
        TimelineSignal("g", "gesture", "gesture=hands_on_hips", 0.0, 3.0),
        TimelineSignal("s", "face", "faceexp=smile", 0.0, 3.0),
    )
    page = face_page(Timeline("t", 3.0, signals, solver="hand-made"), ExportOptions())
    track = page.data["track"]
    assert isinstance(track, dict)
    assert [m["label"] for m in track["markers"]] == ["g: gesture=hands_on_hips"]
