"""The track model and its formats (docs/tracks.md): the face player's curves, sampled; faithful
to each occurrence's envelope; OpenFace 2.0 and ARKit layouts."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api
from mse.cli import main as cli_main
from mse.cli.common import read_timelines
from mse.dialogue import Session
from mse.envelope import phases
from mse.export import ExportOptions, render
from mse.export.face.lexicon import Resolver
from mse.export.face.page import face_track
from mse.export.face.rig import default_rig
from mse.export.face.track import MERGE_GAP
from mse.export.lexemes import modality_of, split_lexeme
from mse.export.tracks.arkit import ROTATIONS, arkit_table, blendshapes
from mse.export.tracks.model import AU_SCALE, GAZE_DEGREES, Tracks, sample
from mse.export.tracks.openface import AU_INTENSITY, AU_PRESENCE, columns, openface_values, write_openface
from mse.resources import bundled_names
from mse.sampling import sample as sample_timeline
from mse.timeline import Timeline, TimelineSignal

#: Apple's ARFaceAnchor.BlendShapeLocation (developer.apple.com/documentation/arkit/arfaceanchor/blendshapelocation).
APPLE_52 = {
    "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
    "eyeBlinkLeft", "eyeBlinkRight", "eyeLookDownLeft", "eyeLookDownRight", "eyeLookInLeft", "eyeLookInRight",
    "eyeLookOutLeft", "eyeLookOutRight", "eyeLookUpLeft", "eyeLookUpRight", "eyeSquintLeft", "eyeSquintRight",
    "eyeWideLeft", "eyeWideRight",
    "jawForward", "jawLeft", "jawOpen", "jawRight",
    "mouthClose", "mouthDimpleLeft", "mouthDimpleRight", "mouthFrownLeft", "mouthFrownRight", "mouthFunnel",
    "mouthLeft", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthPressLeft", "mouthPressRight", "mouthPucker",
    "mouthRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthSmileLeft",
    "mouthSmileRight", "mouthStretchLeft", "mouthStretchRight", "mouthUpperUpLeft", "mouthUpperUpRight",
    "noseSneerLeft", "noseSneerRight",
    "tongueOut",
}  # fmt: skip
OPTIONS = ExportOptions()
FPS = 30.0


def dialogue(seed: int) -> Timeline:
    session = Session(seed=seed)
    session.emotion(0.0, "anger", until=4.0)
    session.emotion(4.0, "relief", 0.6, until=8.0)
    session.emotion(6.5, "embarrassment", until=11.0)  # unannounced change: cuts relief
    session.end(11.0)
    return session.timeline()


# -- faithfulness ----------------------------------------------------------------------------
def _channels(timeline: Timeline) -> list[tuple[TimelineSignal, dict[str, float], tuple[float, float], bool]]:
    """Per occurrence the face player resolves: its channel targets (rig names, intensity applied),
    its apex window, and whether it is shaped (pulses, oscillation)."""
    resolver = Resolver()
    found = []
    for signal in timeline.signals:
        modality = modality_of(signal.modality, split_lexeme(signal.lexeme))
        action = resolver.resolve(signal.lexeme, modality)
        if action is None:
            continue
        scale = signal.envelope.intensity if signal.envelope is not None else 1.0
        targets: dict[str, float] = {}
        for channel, value in action.targets:
            targets[channel] = targets.get(channel, 0.0) + value * scale
        if signal.envelope is not None:
            attack, release = signal.envelope.attack, signal.envelope.release
        else:
            attack, release = phases(modality, signal.stop - signal.start, action.attack, action.release)
        shaped = action.repeat is not None or action.oscillate is not None
        found.append((signal, targets, (signal.start + attack, signal.stop - release), shaped))
    return found


def _value(tracks: Tracks, channel: str) -> np.ndarray:
    if channel.startswith("AU"):
        number, side = channel[2:].split(":")
        return tracks.sides[:, tracks.units.index(int(number)), "LR".index(side)]
    if channel.startswith("head_") and channel != "head_forward":
        return tracks.head[:, ("head_pitch", "head_yaw", "head_roll").index(channel)]
    return tracks.gaze[:, ("gaze_x", "gaze_y").index(channel)] / GAZE_DEGREES


def _merged(a: TimelineSignal, b: TimelineSignal) -> bool:
    """Two occurrences of one lexeme the face player plays as one hold (track.MERGE_GAP)."""
    return (
        a is not b
        and a.lexeme == b.lexeme
        and a.start <= b.stop + MERGE_GAP
        and b.start <= a.stop + MERGE_GAP
    )


def assert_faithful(timeline: Timeline) -> None:
    tracks = sample(timeline, OPTIONS, FPS)
    times = tracks.times
    occurrences = _channels(timeline)
    drawn = {
        c
        for c in default_rig().channels
        if c.startswith(("AU", "gaze_")) or c in ("head_pitch", "head_yaw", "head_roll")
    }
    for signal, targets, (apex_from, apex_to), shaped in occurrences:
        for channel, expected in targets.items():
            if channel not in drawn or expected == 0.0:
                continue
            others = [
                o
                for o, t, _, _ in occurrences
                if (o is not signal and channel in t and o.start < signal.stop and signal.start - 1.0 / FPS < o.stop)
                or _merged(o, signal)
            ]
            if others:
                continue  # blended with another occurrence, or one hold with the same lexeme's
            curve = _value(tracks, channel)
            if not shaped:  # at the apex: the occurrence's intensity times the table value
                apex = (times >= apex_from) & (times <= apex_to) & (times > signal.start) & (times < signal.stop)
                top = min(expected, 1.0) if channel.startswith("AU") else expected
                assert np.allclose(curve[apex], top, atol=1e-3), (signal, channel)
                if channel.startswith("AU"):
                    assert np.allclose(
                        tracks.au[apex, tracks.units.index(int(channel[2:].split(":")[0]))], AU_SCALE * top, atol=5e-3
                    )
            # onset within one frame of the start; nothing before it
            before, after = times[times <= signal.start], times[times > signal.start]
            if len(before):
                assert curve[len(before) - 1] == 0.0, (signal, channel)
            if len(after) and after[0] < signal.stop and not (shaped and signal.lexeme):
                assert curve[len(before)] != 0.0, (signal, channel)
    # outside every occurrence: at rest
    active = np.zeros(len(times), dtype=bool)
    for signal in timeline.signals:
        active |= (times > signal.start) & (times < signal.stop)
        for other in timeline.signals:  # the gap of back-to-back occurrences is held
            if other is not signal and _merged(other, signal) and signal.stop <= other.start:
                active |= (times >= signal.stop) & (times <= other.start)
    rest = ~active
    assert not tracks.sides[rest].any() and not tracks.head[rest].any() and not tracks.gaze[rest].any()


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(bundled_names()), seed=st.integers(0, 2**20))
def test_tracks_are_faithful_to_every_bundled_set(name: str, seed: int) -> None:
    assert_faithful(sample_timeline(mse.api.load(name, cache=True), 10.0, seed=seed))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_tracks_are_faithful_to_a_dialogue(seed: int) -> None:
    timeline = dialogue(seed)
    assert {s.episode for s in timeline.signals} >= {0, 1, 2}
    assert any(s.envelope is not None and s.envelope.intensity < 1.0 for s in timeline.signals)
    assert_faithful(timeline)


def test_tracks_read_the_face_players_curves() -> None:
    timeline = sample_timeline(mse.api.load("embarrassment"), 10.0, seed=4)
    rig = default_rig()
    tracks = sample(timeline, OPTIONS, FPS)
    values = face_track(timeline, OPTIONS, rig).values(tracks.times)
    index = rig.channel_index
    assert np.array_equal(tracks.head[:, 1], values[:, index["head_yaw"]])
    smile = tracks.units.index(12)
    assert np.array_equal(
        tracks.au[:, smile], AU_SCALE * np.maximum(values[:, index["AU12:L"]], values[:, index["AU12:R"]])
    )
    assert len(tracks.times) == 301 and tracks.times[-1] == pytest.approx(10.0)


def test_a_one_sided_unit_moves_one_side() -> None:
    timeline = Timeline("t", 2.0, (TimelineSignal("s", "face", "AU12", 0.0, 2.0),))
    tracks = sample(timeline, OPTIONS, FPS)
    shapes = blendshapes(tracks)
    names = arkit_table().names
    assert shapes[30, names.index("mouthSmileLeft")] == pytest.approx(1.0)
    assert shapes[30, names.index("mouthSmileRight")] == pytest.approx(1.0)  # AU12 = both sides
    gaze = Timeline("t", 2.0, (TimelineSignal("g", "gaze", "look_left", 0.0, 2.0),))
    shapes = blendshapes(sample(gaze, OPTIONS, FPS))
    assert shapes[30, names.index("eyeLookOutLeft")] == pytest.approx(1.0)
    assert shapes[30, names.index("eyeLookInRight")] == pytest.approx(1.0)
    assert shapes[30, names.index("eyeLookInLeft")] == 0.0


# -- formats ---------------------------------------------------------------------------------
def test_arkit_names_are_apples_52() -> None:
    names = arkit_table().names
    assert len(names) == 52 and set(names) == APPLE_52
    table = arkit_table()
    assert set(table.units) <= set(sample(Timeline("t", 1.0, ()), OPTIONS, FPS).units)


def test_arkit_csv_has_live_link_faces_layout() -> None:
    timeline = sample_timeline(mse.api.load("cheerfulness"), 10.0, seed=2)
    text = render(timeline, "arkit")
    header, *rows = text.splitlines()
    assert header.split(",") == ["Timecode", "BlendShapeCount", *arkit_table().names, *ROTATIONS]
    assert len(rows) == 301
    for k, row in enumerate(rows):
        fields = row.split(",")
        assert len(fields) == 63 and fields[1] == "61"
        assert fields[0] == f"00:00:{k // 30:02d}:{k % 30:02d}.000"
        weights = [float(v) for v in fields[2:54]]
        assert all(0.0 <= w <= 1.0 for w in weights)
    document = json.loads(render(timeline, "arkit-json"))
    assert document["fps"] == 30 and document["names"] == header.split(",")[2:]
    assert len(document["frames"]) == 301 and all(len(f) == 61 for f in document["frames"])
    csv_values = [[float(v) for v in row.split(",")[2:]] for row in rows]
    assert np.allclose(document["frames"], csv_values, atol=1e-6)


def test_openface_csv_has_openface_2_columns_and_values() -> None:
    names = columns()
    assert len(names) == 714 and len(set(names)) == 714
    assert names[:5] == ["frame", "face_id", "timestamp", "confidence", "success"]
    assert names[-35:] == [f"AU{n:02d}_r" for n in AU_INTENSITY] + [f"AU{n:02d}_c" for n in AU_PRESENCE]
    timeline = dialogue(5)
    tracks = sample(timeline, OPTIONS, FPS)
    text = write_openface(tracks)
    assert text == render(timeline, "openface")
    header, *rows = text.splitlines()
    assert header.split(", ") == names
    expected = openface_values(tracks)
    for k, row in enumerate(rows):
        fields = dict(zip(names, row.split(", "), strict=True))
        assert fields["frame"] == str(k + 1) and fields["success"] == "1" and fields["face_id"] == "0"
        for name, values in expected.items():
            assert float(fields[name]) == pytest.approx(values[k], abs=6e-4 if name.startswith("gaze_0") else 6e-3)


def test_cli_writes_every_track_format(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "t.json"
    assert cli_main(["sample", "anger", "--seed", "3", "-o", str(source), "-q"]) == 0
    timeline = read_timelines(str(source))[0]
    for name, fmt in (("a.openface.csv", "openface"), ("a.arkit.csv", "arkit"), ("a.arkit.json", "arkit-json")):
        assert cli_main(["export", str(source), "-o", str(tmp_path / name)]) == 0
        assert (tmp_path / name).read_text() == render(timeline, fmt)
    assert cli_main(["export", str(source), "-o", str(tmp_path / "b.csv")]) == 1
    assert cli_main(["sample", "anger", "--seed", "3", "--format", "openface", "-o", str(tmp_path / "b.csv")]) == 0
    assert (tmp_path / "b.csv").read_text() == (tmp_path / "a.openface.csv").read_text()
    assert cli_main(["sample", "anger", "--seed", "3", "-o", str(tmp_path / "c.arkit.json"), "-q"]) == 0
    assert json.loads((tmp_path / "c.arkit.json").read_text())["names"][0] == "eyeBlinkLeft"
    assert cli_main(["sample", "anger", "--format", "bml", "-o", str(tmp_path / "d.csv")]) == 1
    capsys.readouterr()


# -- OpenFace in: mse learn ------------------------------------------------------------------
def test_learn_reads_openface_presence_columns(tmp_path: Path) -> None:
    from mse.learn.read import read_corpus

    signals = (
        TimelineSignal("smile", "face", "faceexp=smile", 1.0, 3.0),
        TimelineSignal("frown", "face", "AU4", 4.0, 5.5),
    )
    (tmp_path / "a.openface.csv").write_text(render(Timeline("t", 6.0, signals), "openface"), encoding="utf-8")
    corpus, notes = read_corpus([tmp_path])
    assert not [n for n in notes if n.is_error]
    assert len(corpus.sequences) == 1 and set(corpus.signals) >= {"AU12", "AU4"}
    raw = [(a.label, a.start, a.stop) for a in _raw(tmp_path / "a.openface.csv")]
    one_frame = 1000 / 30 + 1
    by_label = {label: (start, stop) for label, start, stop in raw}
    assert set(by_label) == {"AU6", "AU12", "AU4"}
    for label, (start, stop) in (("AU12", (1000, 3000)), ("AU6", (1000, 3000)), ("AU4", (4000, 5500))):
        assert abs(by_label[label][0] - start) <= one_frame and abs(by_label[label][1] - stop) <= one_frame


def _raw(path: Path) -> list[Any]:
    from mse.learn.read_table import read_table

    (sequence,), problems = read_table(path)
    assert problems == []
    return list(sequence.annotations)
