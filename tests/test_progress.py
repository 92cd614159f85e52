"""Long work shows a progress bar on a terminal only, on stderr only (issue 18 item 11)."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mse import progress
from mse.cli import main

REPO_ROOT = Path(__file__).resolve().parent.parent


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _run(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[bytes]:
    environment = {**os.environ, "PYTHONPATH": str(REPO_ROOT), **(env or {})}
    if env is None or "MSE_PROGRESS" not in env:
        environment.pop("MSE_PROGRESS", None)
    return subprocess.run([sys.executable, "-m", "mse", *args], capture_output=True, env=environment, timeout=120)


def test_piped_output_gets_no_progress() -> None:
    result = _run("sample", "relief", "--count", "200", "--seed", "1", "--format", "jsonl")
    assert result.returncode == 0
    assert b"it/s" not in result.stderr and b"timeline/s" not in result.stderr and b"%|" not in result.stderr
    assert len(result.stdout.splitlines()) == 200


def test_forced_progress_goes_to_stderr_never_into_the_data() -> None:
    result = _run("sample", "relief", "--count", "200", "--seed", "1", "--format", "jsonl", env={"MSE_PROGRESS": "1"})
    assert result.returncode == 0
    assert b"sample:" in result.stderr and b"/200" in result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 200
    for line in lines:
        json.loads(line)  # every stdout line is data


def test_quiet_silences_even_a_forced_bar() -> None:
    result = _run(
        "sample", "relief", "--count", "50", "--format", "jsonl", "--quiet", env={"MSE_PROGRESS": "1"}
    )
    assert result.returncode == 0
    assert b"sample:" not in result.stderr


def test_a_terminal_gets_a_bar(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """stdout and stderr both terminals (fake ones): the bar appears on stderr."""
    monkeypatch.delenv("MSE_PROGRESS", raising=False)
    out, err = _Terminal(), _Terminal()
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(progress, "_terminal", lambda: True)
    monkeypatch.setattr(progress, "DELAY", 0.0)
    target = tmp_path / "many.jsonl"
    assert main(["sample", "relief", "--count", "300", "--seed", "1", "--format", "jsonl", "-o", str(target)]) == 0
    assert len(target.read_text(encoding="utf-8").splitlines()) == 300
    assert out.getvalue() == ""
    assert "sample:" in err.getvalue() and "/300" in err.getvalue()
    progress.enable(False)


def test_the_terminal_check_needs_both_streams(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MSE_PROGRESS", raising=False)
    progress.enable(True)
    try:
        monkeypatch.setattr(sys, "stdout", _Terminal())
        monkeypatch.setattr(sys, "stderr", io.StringIO())
        assert not progress.shown()
        monkeypatch.setattr(sys, "stderr", _Terminal())
        assert progress.shown()
        monkeypatch.setenv("MSE_PROGRESS", "0")
        assert not progress.shown()
    finally:
        progress.enable(False)


def test_library_calls_draw_nothing_unless_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MSE_PROGRESS", "1")
    progress.enable(False)
    assert not progress.shown()
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    assert list(progress.each([1, 2, 3], "nothing")) == [1, 2, 3]
    assert err.getvalue() == ""


@pytest.mark.slow
@pytest.mark.parametrize(
    "args,label",
    [
        (["lint", "behaviour_sets/"], "lint"),
        (["learn", "tests/fixtures/learn/corpus.csv", "--name", "r", "--min-support", "2", "-o", "{tmp}/r.xml"],
         "read"),
    ],
)
def test_long_commands_show_their_bar_when_forced(args: list[str], label: str, tmp_path: Path) -> None:
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    environment = {**os.environ, "PYTHONPATH": str(REPO_ROOT), "MSE_PROGRESS": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "mse", *argv], capture_output=True, env=environment, cwd=REPO_ROOT, timeout=120
    )
    assert result.returncode in (0, 1), result.stderr
    assert label.encode() in result.stderr


@pytest.mark.slow
def test_render_and_animate_show_their_bar_when_forced(tmp_path: Path) -> None:
    environment = {**os.environ, "PYTHONPATH": str(REPO_ROOT), "MSE_PROGRESS": "1"}

    def run(*args: str) -> subprocess.CompletedProcess[bytes]:
        return subprocess.run(
            [sys.executable, "-m", "mse", *args], capture_output=True, env=environment, cwd=tmp_path, timeout=120
        )

    sampled = run("sample", "embarrassment", "--seed", "1", "--duration", "3", "-o", "t.json")
    assert sampled.returncode == 0, sampled.stderr
    animated = run("animate", "t.json", "-o", "motion/")
    assert animated.returncode == 0, animated.stderr
    assert b"animate" in animated.stderr
    rendered = run("render", "t.json", "-o", "t.gif", "--size", "160x90", "--fps", "5")
    assert rendered.returncode == 0, rendered.stderr
    assert b"render" in rendered.stderr and b"frame" in rendered.stderr
    quiet = run("render", "t.json", "-o", "q.gif", "--size", "160x90", "--fps", "5", "--quiet")
    assert b"frame/s" not in quiet.stderr and b"15/15" not in quiet.stderr
