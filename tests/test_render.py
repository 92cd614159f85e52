"""``mse render`` and the video formats, decoded again with the library that wrote them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mse.cli import main
from mse.export import ExportOptions
from mse.export.video import VideoOptions, painter
from mse.timeline import Timeline, TimelineSignal

av = pytest.importorskip("av", reason="PyAV is not installed")

SIZE = (640, 360)
FPS = 10
SIGNALS = (
    TimelineSignal("smile", "face", "faceexp=smile", 1.0, 3.0),  # apex 1.3 s .. 2.7 s
    TimelineSignal("look_down", "gaze", "gaze=look_down", 3.2, 4.0),
)
TIMELINE = Timeline("test", 4.0, SIGNALS, solver="hand-made")


@pytest.fixture(scope="module")
def timeline_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("render") / "t.json"
    path.write_text(TIMELINE.dumps(), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def face_box() -> tuple[int, int, int, int]:
    frames = painter(TIMELINE, ExportOptions(), VideoOptions(size=SIZE, fps=FPS, view="face"))
    (x, y), (w, h) = frames.face_at, frames.face_size
    return x, y, x + w, y + h


def _render(*argv: str) -> int:
    """``mse render`` in the face view (these tests read the face's box; the half-body view
    has its own tests in tests/test_face_frames.py)."""
    return main(["render", "--view", "face", *argv])


def _decode(path: Path) -> list[np.ndarray]:
    with av.open(str(path)) as container:
        return [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]


def _crop(frame: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    left, top, right, bottom = box
    return frame[top:bottom, left:right].astype(np.int16)


def _changed(a: np.ndarray, b: np.ndarray) -> int:
    """Pixels that clearly changed (codec noise stays far below 48 levels)."""
    return int((np.abs(a - b).max(axis=2) > 48).sum())


@pytest.mark.parametrize("suffix", [".mp4", ".webm"])
def test_encoded_video_has_the_asked_frames_and_plays_the_timeline(
    timeline_file: Path, tmp_path: Path, face_box: tuple[int, int, int, int], suffix: str
) -> None:
    out = tmp_path / f"clip{suffix}"
    assert _render(str(timeline_file), "-o", str(out), "--size", "640x360", "--fps", str(FPS)) == 0
    frames = _decode(out)
    assert len(frames) == 40  # 4 s at 10 fps
    assert frames[0].shape == (360, 640, 3)
    with av.open(str(out)) as container:
        assert container.duration is not None and abs(container.duration / 1e6 - 4.0) < 0.15
        assert float(container.streams.video[0].average_rate) == pytest.approx(FPS)
    faces = [_crop(frame, face_box) for frame in frames]
    # Neutral (0.0 s, 0.5 s) and the smile's apex (1.5 s, 2.5 s): the face stands still in
    # each pair (lossy codecs: nearly identical), and differs between them.
    assert _changed(faces[0], faces[5]) == 0 and _changed(faces[15], faces[25]) == 0
    assert float(np.abs(faces[15] - faces[25]).mean()) < 1.0
    assert _changed(faces[5], faces[15]) > 30
    assert _changed(faces[25], faces[36]) > 30  # looking down


@pytest.mark.slow
def test_gif_and_png_frames_are_exact(timeline_file: Path, tmp_path: Path, face_box: tuple[int, int, int, int]) -> None:
    from PIL import Image

    gif = tmp_path / "clip.gif"
    folder = tmp_path / "frames"
    args = ["--size", "640x360", "--fps", str(FPS)]
    assert _render(str(timeline_file), "-o", str(gif), "--frames", str(folder), *args) == 0
    names = sorted(p.name for p in folder.iterdir())
    assert names[0] == "frame_00001.png" and len(names) == 40
    pngs = [np.asarray(Image.open(folder / name).convert("RGB")) for name in names]
    faces = [_crop(frame, face_box) for frame in pngs]
    assert np.array_equal(faces[0], faces[5]) and np.array_equal(faces[15], faces[25])
    assert not np.array_equal(faces[5], faces[15])
    assert not np.array_equal(pngs[15], pngs[25])  # the playhead moves
    with Image.open(gif) as image:
        assert image.n_frames == 40
        assert image.info["duration"] == 100
        image.seek(15)
        apex = _crop(np.asarray(image.convert("RGB")), face_box)
        image.seek(25)
        assert np.array_equal(apex, _crop(np.asarray(image.convert("RGB")), face_box))
        image.seek(5)
        assert not np.array_equal(apex, _crop(np.asarray(image.convert("RGB")), face_box))


def test_one_frame_as_png(timeline_file: Path, tmp_path: Path) -> None:
    from PIL import Image

    out = tmp_path / "still.png"
    assert _render(str(timeline_file), "-o", str(out), "--at", "2", "--size", "640x360") == 0
    with Image.open(out) as image:
        assert image.size == (640, 360)
        colours = image.convert("RGB").getcolors(maxcolors=1 << 20)
        assert colours is not None and len(colours) > 200  # a drawn face, not a blank frame


def test_bad_requests_are_diagnostics_and_write_nothing(
    timeline_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    existing = tmp_path / "keep.mp4"
    existing.write_bytes(b"old")
    bad_table = tmp_path / "bad.toml"
    bad_table.write_text("[smile]\nau = { AU12 = 'lots' }\n", encoding="utf-8")
    cases = [
        (["-o", str(tmp_path / "x.avi")], "E130"),
        (["-o", str(tmp_path / "x.mp4"), "--size", "321x180"], "E130"),
        (["-o", str(tmp_path / "x.mp4"), "--fps", "0"], "E130"),
        (["-o", str(existing), "--lexicon", str(bad_table)], "E214"),
        ([], "E130"),
    ]
    for extra, code in cases:
        assert _render(str(timeline_file), *extra) == 1
        assert f" {code} " in capsys.readouterr().err
    assert existing.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "keep.mp4"]
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "other.txt").write_text("x", encoding="utf-8")
    assert _render(str(timeline_file), "--frames", str(tmp_path / "full")) == 1
    assert "new or empty folder" in capsys.readouterr().err


def test_unmapped_lexemes_are_reported_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    signals = (
        TimelineSignal("wave", "gesture", "gesture=wave_hello", 0.0, 0.5),
        TimelineSignal("wave", "gesture", "gesture=wave_hello", 0.6, 1.0),
    )
    path = tmp_path / "t.json"
    path.write_text(Timeline("t", 1.0, signals).dumps(), encoding="utf-8")
    assert _render(str(path), "-o", str(tmp_path / "t.gif"), "--size", "160x90", "--fps", "5") == 0
    err = capsys.readouterr().err
    assert err.count("W602") == 1 and "wave_hello" in err


@pytest.mark.slow
def test_sample_and_export_write_videos(tmp_path: Path, timeline_file: Path) -> None:
    clip = tmp_path / "s.mp4"
    assert main(["sample", "embarrassment", "--duration", "1", "--seed", "3", "--format", "mp4", "-o", str(clip)]) == 0
    assert len(_decode(clip)) == 25
    assert main(["sample", "embarrassment", "--duration", "1", "--format", "mp4"]) == 1  # needs -o
    gif = tmp_path / "e.gif"
    assert main(["export", str(timeline_file), "--format", "gif", "-o", str(gif)]) == 0
    assert gif.stat().st_size > 0
    assert json.loads(timeline_file.read_text(encoding="utf-8"))["duration"] == 4.0


def test_the_body_plays_beside_the_face_when_the_timeline_has_motion(tmp_path: Path) -> None:
    from PIL import Image

    from mse.export.figures import FigureClip
    from mse.export.video import write_frames

    frames = 30
    positions = np.zeros((frames, 3, 3))
    positions[:, 1, 1] = 100.0  # a neck above the hips
    positions[:, 2, 0] = np.linspace(-40.0, 40.0, frames)  # a hand sweeping sideways
    positions[:, 2, 1] = 80.0
    signals = (*SIGNALS, TimelineSignal("wave", "gesture", "gesture=wave", 1.0, 2.0, motion={"file": "w.bvh"}))
    timeline = Timeline("test", 4.0, signals)
    clip = FigureClip("wave", "gesture=wave", 1.0, 2.0, 30.0, ("hips", "neck", "hand"), (-1, 0, 1), positions)
    video = VideoOptions(size=SIZE, fps=FPS, view="face")
    report = write_frames(timeline, tmp_path / "f", ExportOptions(), video, clips=[clip])
    assert report.frames == 40 and report.notes == ()  # the body shows the gesture: no W602
    layout = painter(timeline, ExportOptions(), video, clips=[clip]).layout
    assert layout.body_box is not None
    left, top, right, bottom = layout.body_box
    body = [
        np.asarray(Image.open(tmp_path / "f" / f"frame_{i:05d}.png").convert("RGB"))[top:bottom, left:right]
        for i in (5, 12, 18)
    ]
    assert not np.array_equal(body[1], body[2])  # the hand moves while the clip plays
    assert not np.array_equal(body[0], body[1])  # grey rest pose before it
