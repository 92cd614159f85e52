"""Occurrences to channel values: onset/apex/offset envelopes, blending, pulses, markers."""

from __future__ import annotations

import numpy as np
import pytest

from mse.export.face.lexicon import Resolver
from mse.export.face.rig import default_rig
from mse.export.face.track import Key, Track, build_track, key_weight
from mse.timeline import Timeline, TimelineSignal


def _track(*signals: TimelineSignal, duration: float = 6.0) -> Track:
    return build_track(Timeline("t", duration, signals), default_rig(), Resolver())


def _channel(track: Track, name: str, times: list[float]) -> np.ndarray:
    return track.values(np.array(times))[:, default_rig().channel_index[name]]


def test_envelope_rises_holds_and_falls() -> None:
    key = Key("s", "x", "face", 1.0, 3.0, 0.3, 0.5, ((0, 1.0),))
    times = np.array([0.5, 1.0, 1.15, 1.3, 2.0, 2.5, 2.75, 3.0, 3.5])
    weight = key_weight(key, times)
    assert weight[0] == weight[1] == 0.0  # before and at the start
    assert 0.0 < weight[2] < 1.0 and weight[2] == pytest.approx(0.5)  # half-way up (smoothstep)
    assert weight[3] == weight[4] == weight[5] == 1.0  # apex
    assert 0.0 < weight[6] < 1.0
    assert weight[7] == weight[8] == 0.0  # after the stop
    rising = key_weight(key, np.linspace(1.0, 1.3, 20))
    assert np.all(np.diff(rising) >= 0)


def test_default_phases_never_exceed_forty_percent_of_a_short_occurrence() -> None:
    track = _track(TimelineSignal("s", "face", "faceexp=smile", 1.0, 1.5))
    key = track.keys[0]
    assert key.attack == key.release == pytest.approx(0.2)


def test_overlapping_expressions_blend_and_clamp() -> None:
    track = _track(
        TimelineSignal("a", "face", "faceexp=slight_smile", 0.0, 4.0),
        TimelineSignal("b", "face", "faceexp=laugh", 2.0, 6.0),
    )
    au12 = _channel(track, "AU12:L", [1.0, 3.0, 5.0])
    assert au12[0] == pytest.approx(0.55) and au12[1] == 1.0 and au12[2] == 1.0  # 0.55 + 1.0 clamped
    jaw = _channel(track, "AU26:L", [1.0, 2.1, 3.0])
    assert jaw[0] == 0.0 < jaw[1] < jaw[2]  # the laugh's onset blends in


def test_blinks_are_pulses() -> None:
    track = _track(TimelineSignal("b", "face", "faceexp=blinking", 0.0, 3.6))
    times = np.linspace(0.0, 3.6, 721)
    closed = _channel(track, "AU43:L", list(times))
    peaks = np.flatnonzero((closed[1:-1] > closed[:-2]) & (closed[1:-1] >= closed[2:]) & (closed[1:-1] > 0.99))
    assert len(peaks) == 3  # one blink every 1.2 s
    assert (closed < 0.01).sum() > 0.6 * len(times)  # open most of the time
    single = _track(TimelineSignal("b", "face", "faceexp=blink", 1.0, 1.3))
    assert _channel(single, "AU43:L", [1.15])[0] == pytest.approx(1.0)


def test_nods_and_shakes_oscillate() -> None:
    nod = _channel(_track(TimelineSignal("n", "head", "head=nod", 0.0, 2.2)), "head_pitch", [0.275, 0.55, 0.825])
    assert nod[0] > 5.0 and nod[1] < 1.0 and nod[2] > 5.0  # down, up, down
    shake = _channel(_track(TimelineSignal("s", "head", "head=shake", 0.0, 2.4)), "head_yaw", [0.75, 1.05])
    assert shake[0] > 5.0 and shake[1] < -5.0


def test_unmapped_lexemes_are_markers_reported_once() -> None:
    track = _track(
        TimelineSignal("w", "gesture", "gesture=wave_hello", 0.0, 1.0),
        TimelineSignal("w", "gesture", "gesture=wave_hello", 2.0, 3.0),
        TimelineSignal("h", "gesture", "gesture=point_at_door", 1.0, 2.0, motion={"file": "h.bvh"}),
        TimelineSignal("f", "face", "faceexp=AU33", 0.0, 1.0),
        TimelineSignal("b", "torso", "torso=bend", 4.0, 5.0, motion={"action": "bend"}),  # not animated
    )
    assert [m.signal for m in track.markers] == ["w", "w", "b"]
    assert [b.signal for b in track.bodies] == ["h"]  # the body shows it: no marker, no note
    assert len(track.notes) == 3
    assert any("--animate" in note for note in track.notes)
    assert sorted("AU33" in note for note in track.notes) == [False, False, True]
    assert [m.label for m in track.active_markers(2.5)] == ["w: gesture=wave_hello"]
    assert track.active_markers(1.5) == []


def test_page_json_has_what_face_js_reads() -> None:
    track = _track(TimelineSignal("s", "face", "faceexp=smile", 0.0, 2.0))
    data = track.to_json()
    assert set(data) == {"keys", "markers", "clamped"}
    key = data["keys"][0]
    assert set(key) == {"signal", "start", "stop", "attack", "release", "targets", "repeat", "oscillate"}
    channels = default_rig().channels
    assert {channels[c] for c, _ in key["targets"]} == {"AU6:L", "AU6:R", "AU12:L", "AU12:R"}
