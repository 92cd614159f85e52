"""Many timelines from the CLI: --count streams (same text as before, one timeline at a time),
--stream lines carry their expression, seed and duration, -o works with --stream, and a
--diverse timeline can be reproduced from what its JSON records."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mse.api import load
from mse.cli import main
from mse.sampling import iter_timelines, sample
from mse.timeline import Timeline


@pytest.mark.parametrize("fmt", ["json", "jsonl", "table"])
def test_count_output_is_the_rendering_of_all_timelines(fmt: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "relief", "--count", "3", "--seed", "4", "--format", fmt]) == 0
    text = capsys.readouterr().out
    timelines = list(iter_timelines(load("relief"), 10.0, seed=4, count=3))
    if fmt == "json":
        assert text == json.dumps([t.to_json() for t in timelines], indent=2, ensure_ascii=False) + "\n"
    elif fmt == "jsonl":
        assert text == "".join(t.dumps(indent=None) + "\n" for t in timelines)
    else:
        from mse.cli.table import render_table

        assert text == "\n".join(render_table(t) for t in timelines)


def test_iter_timelines_is_lazy_and_reproducible() -> None:
    model = load("anger")
    stream = iter_timelines(model, 10.0, seed=30, count=10**9)
    first, second = next(stream), next(stream)
    alone = sample(model, 10.0, seed=31)
    assert isinstance(alone, Timeline)
    assert (first.seed, second.seed) == (30, 31) and second.signals == alone.signals


def test_first_timeline_arrives_at_once() -> None:
    started = time.monotonic()
    process = subprocess.Popen([sys.executable, "-m", "mse", "sample", "relief", "--count", "1000000",
                                "--format", "jsonl", "--seed", "1"], stdout=subprocess.PIPE, text=True)
    assert process.stdout is not None
    line = process.stdout.readline()
    elapsed = time.monotonic() - started
    process.stdout.close()
    process.wait(timeout=60)
    assert json.loads(line)["seed"] == 1
    assert elapsed < 30  # a generous bound for a loaded machine: today's cost is one timeline


@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_stream_lines_carry_their_timeline_and_go_to_a_file(solver: str, tmp_path: Path) -> None:
    out = tmp_path / "lines.jsonl"
    assert main(["sample", "relief", "--stream", "--seed", "8", "--count", "2", "--solver", solver,
                 "-o", str(out)]) == 0
    lines = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    assert lines and {line["expression"] for line in lines} == {"relief"}
    assert {line["seed"] for line in lines} <= {8, 9} and {line["duration"] for line in lines} == {10.0}
    first = sample(load("relief"), 10.0, seed=8, solver=solver)
    assert isinstance(first, Timeline)
    mine = [(line["id"], line["start"], line["stop"]) for line in lines if line["seed"] == 8]
    assert sorted(mine) == sorted((s.id, s.start, s.stop) for s in first.signals)
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.slow
def test_diverse_timelines_say_how_to_reproduce_them(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "tension", "--solver", "cpsat", "--diverse", "--count", "3", "--seed", "5",
                 "--format", "jsonl", "--duration", "6"]) == 0
    third = json.loads(capsys.readouterr().out.splitlines()[2])
    assert third["diverse"] == {"seed": 5, "index": 2} and third["seed"] == 7
    recipe = third["diverse"]
    assert main(["sample", "tension", "--solver", "cpsat", "--diverse", "--count", str(recipe["index"] + 1),
                 "--seed", str(recipe["seed"]), "--format", "jsonl", "--duration", "6"]) == 0
    again = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert again["signals"] == third["signals"]
