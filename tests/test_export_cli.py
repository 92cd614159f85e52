"""``mse export``: driven through its own argparse registration (cheap, no subprocess)."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest

from mse.cli import cmd_export

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "export" / "embarrassment_timeline.json"


def run_export(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="mse")
    cmd_export.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["export", *argv])
    return int(args.handler(args))


@pytest.mark.parametrize("fmt", ["bml", "greta-bml", "svg", "html"])
def test_export_to_stdout(fmt: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_export([str(FIXTURE), "--format", fmt]) == 0
    out = capsys.readouterr().out
    assert ("<bml" in out) if "bml" in fmt else ("<svg" in out)


def test_export_to_file_with_options(tmp_path: Path) -> None:
    target = tmp_path / "out" / "emb.bml"
    code = run_export([str(FIXTURE), "-f", "bml", "-o", str(target), "--character-id", "Robot", "--bml-constraints"])
    assert code == 0
    text = target.read_text(encoding="utf-8")
    assert 'characterId="Robot"' in text
    assert not list(target.parent.glob(".*.tmp"))


def test_several_timelines_first_or_all(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    one = json.loads(FIXTURE.read_text(encoding="utf-8"))
    two = dict(one, expression="second")
    source = tmp_path / "many.jsonl"
    source.write_text(json.dumps(one) + "\n" + json.dumps(two) + "\n", encoding="utf-8")
    assert run_export([str(source), "-f", "svg"]) == 0
    captured = capsys.readouterr()
    assert "exported the first" in captured.err and "embarrassment" in captured.out
    folder = tmp_path / "all"
    assert run_export([str(source), "-f", "svg", "-o", f"{folder}/"]) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["many-1.svg", "many-2.svg"]
    assert "second" in (folder / "many-2.svg").read_text(encoding="utf-8")


def test_bad_json_reports_position(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "bad.json"
    source.write_text('{"duration": 3,\n  "signals": [}\n', encoding="utf-8")
    target = tmp_path / "never.bml"
    assert run_export([str(source), "-f", "bml", "-o", str(target)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"{source}:2:") and "E212" in err
    assert not target.exists()


def test_invalid_timeline_and_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "neg.json"
    source.write_text('{"duration": -1, "signals": []}', encoding="utf-8")
    assert run_export([str(source), "-f", "html"]) == 1
    assert "E212" in capsys.readouterr().err
    assert run_export([str(tmp_path / "absent.json"), "-f", "bml"]) == 1
    assert "E100" in capsys.readouterr().err


def test_bad_face_library_is_a_diagnostic(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    library = tmp_path / "faces.xml"
    library.write_text("<facelibrary><expression", encoding="utf-8")
    assert run_export([str(FIXTURE), "-f", "bml", "--face-library", str(library)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"{library}:1:") and "E101" in err and "Traceback" not in err


def test_module_imports_stay_light() -> None:
    # Whatever ``import mse`` loads is the package's business; export adds nothing heavy.
    code = (
        "import sys, mse; before = set(sys.modules);"
        "import mse.cli.cmd_export, mse.export;"
        "heavy = {'numpy', 'lxml', 'lxml.etree', 'selenium', 'scipy'} & (set(sys.modules) - before);"
        "print(sorted(heavy))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "[]"
