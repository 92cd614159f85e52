"""Every reader of a file bounds what it reads and reports bad content with a located E-code
(issue 13, items 9-12): non-regular files, size caps, bad UTF-8, deep JSON, huge integers,
NaN/Infinity, out-of-range times and motion, damaged models, and output that reads back."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from lxml import etree

from mse.api import load
from mse.cli import main
from mse.diagnostics import MseError
from mse.timeline import Timeline, TimelineSignal, dumps_jsonl, loads_many

REPO = Path(__file__).resolve().parent.parent
MINIMAL = REPO / "tests" / "fixtures" / "valid" / "minimal.xml"
BUNDLED_TIMELINE = REPO / "tests" / "fixtures" / "export" / "embarrassment_bundled.json"


def _run(*argv: str, stdin: bytes | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess[bytes]:
    done = subprocess.run(
        [sys.executable, "-m", "mse", *argv], input=stdin, capture_output=True, timeout=120, cwd=cwd, check=False
    )
    assert b"Traceback" not in done.stderr, done.stderr.decode(errors="replace")
    return done


def _timeline(**signal: Any) -> dict[str, Any]:
    entry = {"id": "smile", "modality": "face", "lexeme": "smile", "start": 1.0, "stop": 2.0, **signal}
    return {"format": "mse-timeline/1", "expression": "minimal", "duration": 10, "signals": [entry]}


# -- item 9: whole files read before any limit ---------------------------------------------------
@pytest.mark.parametrize(
    "argv",
    [
        ["compile", "/dev/zero"],
        ["sample", "/dev/zero"],
        ["check", str(MINIMAL), "/dev/zero"],
        ["lma", "/dev/zero"],
        ["export", "/dev/zero", "--format", "svg"],
        ["animate", "/dev/zero", "-o", "anim"],
        ["lint", "/dev/zero"],
    ],
)
def test_devices_are_refused_not_read(argv: list[str], tmp_path: Path) -> None:
    done = _run(*argv, cwd=tmp_path)
    report = done.stderr + done.stdout  # lint reports on stdout
    assert done.returncode == 1 and b"E100" in report and b"character device" in report


def test_html_export_never_reads_a_device_named_by_the_timeline(tmp_path: Path) -> None:
    timeline = tmp_path / "t.json"
    timeline.write_text(json.dumps(_timeline(motion={"action": "bow", "file": "/dev/zero"})))
    done = _run("export", str(timeline), "--format", "html")
    assert done.returncode == 1 and b"/dev/zero: E100" in done.stderr


def test_a_large_stdin_is_refused_with_bounded_memory() -> None:
    """300 MB on stdin used 612 MB before the size error; now reading stops at the cap."""
    script = (
        "import resource, subprocess, sys\n"
        "p = subprocess.Popen([sys.executable, '-m', 'mse', 'sample', '-'], stdin=subprocess.PIPE,\n"
        "                     stderr=subprocess.PIPE)\n"
        "chunk = b' ' * (1 << 20)\n"
        "try:\n"
        "    for _ in range(300):\n"
        "        p.stdin.write(chunk)\n"
        "except BrokenPipeError:\n"
        "    pass\n"
        "p.stdin.close()\n"
        "err = p.stderr.read()\n"
        "p.wait()\n"
        "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, err.decode())\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, check=True)
    code, rss, message = done.stdout.split(" ", 2)
    assert code == "1" and "E104" in message, done.stdout
    assert int(rss) < 200_000  # KiB


# -- item 11: JSON everywhere ---------------------------------------------------------------------
DEEP = "[" * 100_000 + "]" * 100_000
HUGE_INT = "1" + "0" * 5000


@pytest.mark.parametrize("text", [DEEP, '{"format": "mse-timeline/1", "duration": ' + HUGE_INT + "}"])
def test_hostile_json_timelines_are_e212(text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "t.json"
    path.write_text(text)
    assert main(["check", str(MINIMAL), str(path)]) == 1
    assert "E212" in capsys.readouterr().err


@pytest.mark.parametrize(
    "text",
    [
        DEEP,
        '{"format": "mse-ir/1", "signals": [{"id": "a", "modality": "face", "max_duration": ' + HUGE_INT + "}]}",
        '{"format": "mse-ir/1", "signals": 1.5}',
        '{"format": "mse-ir/1", "signals": [{"id": "a", "modality": "face", "lexeme": "\\u0001"}]}',
        '{"format": "mse-ir/1", "signals": [{"id": "a", "modality": "face", "lexeme": "\\ud800"}]}',
        '{"format": "mse-ir/1", "signals": [{"id": "a", "modality": "face", "max_duration": NaN}]}',
    ],
    ids=["deep", "huge-int", "signals-float", "control", "surrogate", "nan"],
)
def test_hostile_compiled_ir_is_an_error(text: str, tmp_path: Path) -> None:
    path = tmp_path / "model.json"
    path.write_text(text)
    with pytest.raises(MseError) as error:
        load(path)
    assert error.value.diagnostics[0].code.startswith("E")
    done = _run("sample", "-", stdin=text.encode())
    assert done.returncode == 1


def test_a_json_model_that_is_a_directory_or_bad_utf8(tmp_path: Path) -> None:
    folder = tmp_path / "model.json"
    folder.mkdir()
    with pytest.raises(MseError, match="E100"):
        load(folder)
    bad = tmp_path / "bad.json"
    bad.write_bytes(b'{"format": "mse-ir/1", "name": "\xff"}')
    with pytest.raises(MseError) as error:
        load(bad)
    assert error.value.diagnostics[0].span.col == 33  # at the bad byte


def test_json_lines_read_back_whatever_the_strings_hold(tmp_path: Path) -> None:
    """Item 12: JSONL with U+2028/U+0085 in a lexeme could not be read back (splitlines)."""
    signals = tuple(
        TimelineSignal(f"s{i}", "face", f"smile{char}wide", float(i), float(i) + 1.0)
        for i, char in enumerate("\u2028\u0085\u2029")
    )
    timelines = [Timeline("x", 10.0, signals, seed=1), Timeline("x", 10.0, signals[:2], seed=2)]
    assert loads_many(dumps_jsonl(timelines)) == timelines


def test_json_lines_errors_name_the_right_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = json.dumps(_timeline())
    path = tmp_path / "t.jsonl"
    path.write_text(f"\n\n{line}\n\n{line}\n{{broken\n")
    assert main(["check", str(MINIMAL), str(path)]) == 1
    assert f"{path}:6:2: E212" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("signal", "key"),
    [
        ({"start": 1e308}, "start"),
        ({"stop": -1e7}, "stop"),
        ({"lexeme": "a\u0001b"}, "lexeme"),
        ({"id": "\ud800"}, "surrogate"),
        ({"motion": {"file": "a\u0000b"}}, "motion.file"),
    ],
)
def test_timeline_values_outside_the_range_or_xml_are_e212(
    signal: dict[str, Any], key: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "t.json"
    path.write_text(json.dumps(_timeline(**signal)))
    for argv in (["check", str(MINIMAL), str(path)], ["export", str(path), "--format", "svg"]):
        assert main(argv) == 1
        err = capsys.readouterr().err
        assert "E212" in err and key in err, err


def test_exports_stay_well_formed_whatever_the_strings_hold() -> None:
    """Item 12: control characters produced SVG/BML that is not well-formed; a lone
    surrogate crashed the export."""
    from mse.export import ExportOptions, render

    odd = "smile\u0001\u0008\ud800\ufffe--"
    timeline = Timeline(odd, 10.0, (TimelineSignal(odd, "face", odd, 1.0, 2.0),), seed=1)
    for fmt in ("bml", "greta-bml", "svg"):
        text = render(timeline, fmt, ExportOptions())
        etree.fromstring(text.encode("utf-8"))  # well-formed


# -- items 7 and 11: numbers and durations given on the command line ----------------------------------
@pytest.mark.parametrize("value", ["nan", "inf", "-5", "0", "1e9"])
def test_lint_duration_is_checked(value: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lint", str(MINIMAL), f"--duration={value}"]) == 2  # a usage error, as a bad --select
    err = capsys.readouterr().err
    assert "<arguments>: E130 lint duration" in err and "W402" not in err


@pytest.mark.parametrize(
    "argv",
    [
        ["--slot", "inf"],
        ["--slot", "nan"],
        ["--duration", "1e-9", "--solver", "cpsat"],
        ["--duration", "nan"],
        ["--pin", "smile@0-99999999999"],
    ],
)
def test_sample_options_are_checked(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", str(MINIMAL), *argv]) == 1
    assert "<arguments>: E" in capsys.readouterr().err  # E130, or E215 for a time out of range


# -- item 10 and 11: motion --------------------------------------------------------------------------
def _bvh(
    tmp_path: Path, frames: str = "Frames: 2", frame_time: str = "Frame Time: 0.04", rows: str = "0 0 0\n0 0 0"
) -> Path:
    text = (
        "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\n"
        f"MOTION\n{frames}\n{frame_time}\n{rows}\n"
    )
    path = tmp_path / "clip.bvh"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "change",
    [
        {"frames": "Frames: 0", "rows": "\n"},
        {"frame_time": "Frame Time: 1e-300"},
        {"frame_time": "Frame Time: -0.04"},
        {"frames": "Frames: " + "9" * 5000},
        {"frames": "Frames: \u0662"},
        {"rows": "0 0 1e300\n0 0 0"},
    ],
    ids=["no-frames", "tiny-frame-time", "negative-frame-time", "huge-count", "arabic-digit", "huge-value"],
)
def test_bad_bvh_is_a_located_e100(change: dict[str, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _bvh(tmp_path, **change)
    assert main(["lma", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"{path}:" in err and "E100 invalid BVH" in err


def test_lma_output_is_valid_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _bvh(tmp_path, rows="0 0 9e6\n0 0 -9e6")
    code = main(["lma", str(path)])
    out, err = capsys.readouterr()
    if code == 0:
        json.loads(out, parse_constant=lambda name: pytest.fail(f"{name} in the output"))
    else:
        assert "E100" in err


def test_animate_refuses_occurrences_too_long_to_generate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Item 10: a 9,000 s occurrence ran for minutes at 2.7 GB; 1e7 s tried 148 GiB."""
    entry = {"id": "bow", "modality": "torso", "lexeme": "bow"}
    for stop in (9000.0, 1e6):
        timeline = {
            "format": "mse-timeline/1",
            "expression": "embarrassment",
            "duration": stop,
            "signals": [{**entry, "start": 0.0, "stop": stop}],
        }
        path = tmp_path / "t.json"
        path.write_text(json.dumps(timeline))
        assert main(["animate", str(path), "-o", str(tmp_path / "anim")]) == 1
        assert "E215" in capsys.readouterr().err
        assert not (tmp_path / "anim").exists()


@pytest.fixture(scope="module")
def hsmm_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from mse.motion.base.starter import starter_library
    from mse.motion.hsmm import api
    from mse.motion.hsmm.io import save_model

    library = starter_library()
    clips = [(library.motion(c), c.style) for c in library.select(action="bow")][:3]
    path = tmp_path_factory.mktemp("hsmm") / "bow.avg"
    save_model(path, api.train_average(clips, "bow", api.Options(states=3)))
    return path


@pytest.mark.parametrize("argv", [["--duration", "inf"], ["--duration", "1e9"], ["--steps", "1000000"]])
def test_style_synth_lengths_are_bounded(
    argv: list[str], hsmm_model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.bvh"
    assert main(["style", "synth", str(hsmm_model), *argv, "-o", str(out)]) == 1
    assert capsys.readouterr().err.startswith("<arguments>: E130 --") and not out.exists()


def _variant(source: Path, target: Path, change: Any) -> Path:
    arrays = dict(np.load(source))
    meta = json.loads(str(arrays["meta"]))
    change(meta, arrays)
    arrays["meta"] = np.array(json.dumps(meta))
    with target.open("wb") as handle:
        np.savez_compressed(handle, **arrays)
    return target


@pytest.mark.parametrize(
    "name",
    ["frame-time-0", "frame-time-tiny", "frame-time-negative", "no-units", "short-names", "byte-flip", "directory"],
)
def test_damaged_models_are_e100(
    name: str, hsmm_model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / f"{name}.avg"
    frame_times = {"frame-time-0": 0.0, "frame-time-tiny": 1e-300, "frame-time-negative": -0.03}
    if name in frame_times:
        _variant(hsmm_model, target, lambda meta, _: meta["template"].__setitem__("frame_time", frame_times[name]))
    elif name == "no-units":
        _variant(hsmm_model, target, lambda meta, _: meta.__setitem__("units", []))
    elif name == "short-names":
        _variant(hsmm_model, target, lambda meta, _: meta["skeleton"].__setitem__("names", ["Hips"]))
    elif name == "byte-flip":
        data = bytearray(hsmm_model.read_bytes())
        data[len(data) // 2] ^= 0xFF
        target.write_bytes(bytes(data))
    else:
        target.mkdir()
    out = tmp_path / "x.bvh"
    assert main(["style", "synth", str(target), "--duration", "2", "-o", str(out)]) == 1
    assert f"{target}: E100" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("library.json", b'{"clips": [{"file": "\xff.bvh"}]}'),
        ("library.json", b"[" * 100_000),
        ("library.json", b'{"clips": [], "x": ' + HUGE_INT.encode() + b"}"),
        ("library.csv", b"file,action,style\n\xff.bvh,bow,angry\n"),
        ("library.csv", b"file,action,style\n" + b"x" * 140_000 + b",bow,angry\n"),
        ("library.csv", b"file,action,style\nclip\x00.bvh,bow,angry\n"),
    ],
    ids=["json-utf8", "json-deep", "json-huge-int", "csv-utf8", "csv-long-field", "csv-nul"],
)
def test_hostile_library_indexes_are_e100(name: str, content: bytes, tmp_path: Path) -> None:
    from mse.motion.base.library import load_library

    (tmp_path / name).write_bytes(content)
    with pytest.raises(MseError) as error:
        load_library(tmp_path)
    assert error.value.diagnostics[0].code == "E100"


@pytest.mark.parametrize(
    ("labels", "sidecar"),
    [
        (b"dataset-1_bow\n\xff\n", b'{"content": 0, "style": 0}'),
        (b"dataset-1_bow\n", b'{"content": Infinity, "style": 0}'),
        (b"dataset-1_bow\n", b'{"content": -1, "style": 0}'),
        (b"dataset-1_bow\n", b'{"content": 1.5, "style": 0}'),
    ],
    ids=["cfg-utf8", "infinity", "negative", "float"],
)
def test_hostile_bandai_layouts_are_e100(labels: bytes, sidecar: bytes, tmp_path: Path) -> None:
    from mse.motion.base.library import load_library

    (tmp_path / "cfg").mkdir()
    (tmp_path / "data").mkdir()
    (tmp_path / "cfg" / "content_label.txt").write_bytes(labels)
    (tmp_path / "cfg" / "style_label.txt").write_bytes(b"dataset-1_angry\n")
    _bvh(tmp_path).rename(tmp_path / "data" / "dataset-1_bow_angry_001.bvh")
    (tmp_path / "data" / "dataset-1_bow_angry_001.json").write_bytes(sidecar)
    with pytest.raises(MseError) as error:
        load_library(tmp_path)
    assert error.value.diagnostics[0].code == "E100"
