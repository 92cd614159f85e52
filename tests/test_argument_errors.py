"""A bad option value is E130 ("invalid argument or option value") at ``<arguments>``, the
message naming the option; exit 1 (2 where the command documents usage errors: lint,
import-greta), nothing on stdout, never a traceback.  One case per kind of option."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import mse
from mse.cli import main
from mse.diagnostics import CODES, MseError, argument_error
from mse.export import render

REPO = Path(__file__).resolve().parents[1]
MINIMAL = REPO / "tests" / "fixtures" / "valid" / "minimal.xml"


@pytest.fixture(scope="module")
def timeline_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("timeline") / "anger.json"
    timeline = mse.sample(mse.load("anger"), 4.0, seed=1)
    assert isinstance(timeline, mse.Timeline)
    path.write_text(timeline.dumps() + "\n", encoding="utf-8")
    return path


SAMPLE_CASES = [
    (["--pin", "frown@x"], "--pin 'frown@x' must look like SIGNAL@START-STOP"),
    (["--solver", "cpsat", "--pin", "frown@6-4"], "pin frown@6-4: start 6 > stop 4"),
    (["--solver", "cpsat", "--pin", "frown@4-30"], "pin frown@4-30 is not inside [0, 10] s"),
    (["--objective", "likely"], "solver 'greedy' does not support objective (use --solver cpsat)"),
    (["--require", "nosuch"], "unknown signal(s) nosuch in require/forbid"),
    (["--solver", "cpsat", "--forbid", "nosuch"], "unknown signal 'nosuch' in 'anger'"),
    (["--duration", "0"], "--duration "),
    (["--slot", "nan"], "--slot "),
    (["--time-limit", "0"], "--time-limit must be in (0, 86400] s"),
    (["--grid", "0"], "--grid in (0, 3600] s"),
    (["--count", "0"], "--count must be between 1 and 1000000"),
    (["--realtime"], "--realtime goes with --stream"),
    (["--stream", "--format", "svg"], "--stream prints JSON lines; drop --format"),
    (["--format", "mp4"], "--format mp4 writes one timeline to a file: give -o FILE, no --count"),
    (["--format", "svg", "--count", "2"], "--format svg exports one timeline; drop --count or give -o FOLDER/"),
    (["--solver", "csp"], "the csp solver handles at most 8 signals"),
    (["--format", "greta-bml", "--realizer", "generic"], "--format greta-bml is Greta's dialect"),
]


def _argument_error_only(err: str, out: str, message: str) -> None:
    assert "Traceback" not in err and out == ""
    assert err.startswith("<arguments>: E130 "), err
    assert message in err, err


@pytest.mark.parametrize(("argv", "message"), SAMPLE_CASES, ids=[" ".join(a) for a, _ in SAMPLE_CASES])
def test_sample_options(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "anger", "--seed", "1", *argv]) == 1
    captured = capsys.readouterr()
    _argument_error_only(captured.err, captured.out, message)


def test_every_problem_of_one_command_is_reported(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "anger", "--count", "0", "--realtime"]) == 1
    assert capsys.readouterr().err == (
        "<arguments>: E130 --count must be between 1 and 1000000\n<arguments>: E130 --realtime goes with --stream\n"
    )


def test_export_options(timeline_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cases = [
        ([], "cannot tell the format without -o: give --format"),
        (["-o", str(tmp_path / "t.pdf")], "cannot tell the format from"),
        (["--format", "mp4"], "--format mp4 writes a file: give -o FILE"),
        (["--format", "greta-bml", "--realizer", "asap"], "--format greta-bml is Greta's dialect"),
    ]
    for argv, message in cases:
        assert main(["export", str(timeline_file), *argv]) == 1, argv
        captured = capsys.readouterr()
        _argument_error_only(captured.err, captured.out, message)
    assert not list(tmp_path.iterdir())


def test_render_options(timeline_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cases = [
        ([], "give -o FILE (.mp4 .webm .gif .png) and/or --frames DIR"),
        (["-o", str(tmp_path / "x.avi")], "cannot tell the format of"),
        (["-o", str(tmp_path / "x.mp4"), "--size", "321x180"], "mp4 needs an even frame size (got 321x180)"),
        (["-o", str(tmp_path / "x.png"), "--size", "8x8"], "frame size 8x8 must be between"),
        (["-o", str(tmp_path / "x.mp4"), "--fps", "0"], "frame rate 0 must be between 1 and 120"),
        (["-o", str(tmp_path / "x.png"), "--at", "nan"], "--at nan must be a number of seconds"),
    ]
    for argv, message in cases:
        assert main(["render", str(timeline_file), *argv]) == 1, argv
        captured = capsys.readouterr()
        _argument_error_only(captured.err, captured.out, message)
    assert not list(tmp_path.iterdir())


def test_animate_options(timeline_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "motion"
    for style, message in (("nonsense", "--style expects EMOTION=STYLE"), ("angr=sad", "--style: unknown emotion")):
        assert main(["animate", str(timeline_file), "-o", str(out), "--style", style]) == 1
        captured = capsys.readouterr()
        _argument_error_only(captured.err, captured.out, message)
    assert not out.exists()


def test_learn_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for argv, message in (
        (["--confidence", "2"], "--confidence must be in (0, 1]"),
        (["--min-support", "0"], "--min-support must be at least 1"),
        (["--significance", "0"], "--significance must be in (0, 1]"),
    ):
        assert main(["learn", str(tmp_path), *argv]) == 1
        captured = capsys.readouterr()
        _argument_error_only(captured.err, captured.out, message)


def test_style_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model, out = str(tmp_path / "m.npz"), str(tmp_path / "x")
    for argv, message in (
        (["train", "--library", "lib", "--action", "walk", "--states", "0", "-o", out], "--states must be at least 1"),
        (["train", "--library", "lib", "--action", "walk", "--takes", "2", "-o", out], "--takes goes with --style"),
        (["adapt", model, "--library", "lib", "--style", "sad", "--takes", "-1", "-o", out], "--takes must be 0"),
        (["synth", model, "--duration", "0", "-o", out], "--duration must be"),
        (["synth", model, "--steps", "100000", "-o", out], "--steps must be between 1 and"),
    ):
        assert main(["style", *argv]) == 1, argv
        captured = capsys.readouterr()
        _argument_error_only(captured.err, captured.out, message)
    assert not list(tmp_path.iterdir())


def test_lint_options_are_usage_errors(capsys: pytest.CaptureFixture[str]) -> None:
    for argv, message in (
        (["--duration", "nan"], "lint duration"),
        (["--deep-budget", "-1"], "deep budget -1 s"),
        (["--select", "W9"], "select 'W9' matches no rule code"),
    ):
        assert main(["lint", str(MINIMAL), *argv]) == 2  # as documented by mse lint --help
        captured = capsys.readouterr()
        _argument_error_only(captured.err, captured.out, message)


def test_lint_reports_option_errors_in_json_and_sarif(capsys: pytest.CaptureFixture[str]) -> None:
    run = ["lint", "--no-deep", str(MINIMAL), "--realizer", "greta"]
    assert main([*run, "--format", "json"]) == 1
    records = json.loads(capsys.readouterr().out)
    [record] = [r for r in records if r["code"] == "E130"]
    assert record["path"] == "<arguments>" and record["severity"] == "error"
    assert record["message"].startswith("--realizer greta needs --library-dir")
    assert main([*run, "--format", "sarif"]) == 1
    sarif = json.loads(capsys.readouterr().out)["runs"][0]
    rules = {rule["id"]: rule for rule in sarif["tool"]["driver"]["rules"]}
    assert rules["E130"]["shortDescription"]["text"] == CODES["E130"] == "invalid argument or option value"
    [result] = [r for r in sarif["results"] if r["ruleId"] == "E130"]
    assert result["level"] == "error"
    assert result["locations"][0]["physicalLocation"]["artifactLocation"]["uri"] == "<arguments>"


def test_import_greta_usage(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["import-greta", "a.xml", "--legacy", "b.xml", "-o", str(tmp_path / "out")]) == 2
    captured = capsys.readouterr()
    _argument_error_only(captured.err, captured.out, "give either LEXICON CONSTRAINT or --legacy EXAMPLE")


def test_library_arguments_raise_the_same_code() -> None:
    anger = mse.load("anger")
    calls = [
        lambda: mse.sample(anger, 0.0),
        lambda: mse.sample(anger, 10.0, solver="nosuch"),
        lambda: mse.sample(anger, 10.0, solver="cpsat", pinned=[mse.Pin("frown", 4.0, 3.0)]),
        lambda: mse.lint("anger", select="W9"),
        lambda: render(mse.Timeline("x", 1.0, ()), "pdf"),
    ]
    for call in calls:
        with pytest.raises(MseError) as error:
            call()
        assert [d.code for d in error.value.diagnostics] == ["E130"]
        assert str(error.value).startswith("<arguments>: E130 ")


def test_the_helper() -> None:
    error = argument_error("--a is bad", "--b is bad too")
    assert str(error) == "<arguments>: E130 --a is bad\n<arguments>: E130 --b is bad too"


def test_console_script_exits_1_without_traceback() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "mse", "sample", "anger", "--solver", "cpsat", "--pin", "frown@x", "--seed", "1"],
        capture_output=True, text=True, cwd=REPO, timeout=120,
    )
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr == (
        "<arguments>: E130 --pin 'frown@x' must look like SIGNAL@START-STOP, e.g. smile@4.0-6.0\n"
    )
