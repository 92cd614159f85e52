"""Static lint rules, output formats, --select/--ignore/--strict, and the compile/check CLI."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mse.api import lint
from mse.cli import main

FIXTURES = Path(__file__).parent / "fixtures"
WARNINGS = FIXTURES / "lint" / "warnings.xml"


def codes(path: Path, **options: object) -> list[str]:
    return [d.code for d in lint([path], **options)]  # type: ignore[arg-type]


def test_every_static_rule_fires() -> None:
    found = codes(WARNINGS)
    for code in ("W301", "W303", "W304", "W305", "W306", "W307"):
        assert code in found, (code, found)


def test_select_and_ignore() -> None:
    assert set(codes(WARNINGS, select=["W30"], ignore=["W303", "W307"])) == {"W301", "W304", "W305", "W306"}
    assert codes(WARNINGS, select=["W305"]) == ["W305"]


def test_exit_codes_and_strict(capsys: pytest.CaptureFixture[str]) -> None:
    valid = FIXTURES / "valid" / "minimal.xml"
    assert main(["lint", "--no-deep", str(valid)]) == 0
    assert main(["lint", "--no-deep", str(WARNINGS)]) == 0
    assert main(["lint", "--no-deep", "--strict", str(WARNINGS)]) == 1
    assert main(["lint", "--no-deep", str(FIXTURES / "invalid" / "semantic_errors.xml")]) == 1


def test_github_format(capsys: pytest.CaptureFixture[str]) -> None:
    main(["lint", "--no-deep", "--format", "github", str(WARNINGS)])
    lines = capsys.readouterr().out.splitlines()
    assert lines and all(line.startswith("::warning file=") for line in lines)
    assert any(",line=11,col=" in line and "W303" in line for line in lines)


def test_json_and_sarif_formats(capsys: pytest.CaptureFixture[str]) -> None:
    main(["lint", "--no-deep", "--format", "json", str(WARNINGS)])
    records = json.loads(capsys.readouterr().out)
    assert {"path", "line", "col", "code", "severity", "message"} <= set(records[0])
    main(["lint", "--no-deep", "--format", "sarif", str(FIXTURES / "invalid" / "semantic_errors.xml")])
    sarif = json.loads(capsys.readouterr().out)
    assert sarif["version"] == "2.1.0"
    results = sarif["runs"][0]["results"]
    assert results and results[0]["level"] == "error"
    assert results[0]["locations"][0]["physicalLocation"]["region"]["startLine"] > 0
    rule_ids = [rule["id"] for rule in sarif["runs"][0]["tool"]["driver"]["rules"]]
    assert all(rule_ids[r["ruleIndex"]] == r["ruleId"] for r in results)


def test_lint_output_file_is_written(tmp_path: Path) -> None:
    target = tmp_path / "report.sarif"
    main(["lint", "--no-deep", "--format", "sarif", "-o", str(target), str(WARNINGS)])
    assert json.loads(target.read_text())["version"] == "2.1.0"


def test_compile_prints_ir_and_reports_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compile", str(FIXTURES / "valid" / "operators.xml")]) == 0
    ir = json.loads(capsys.readouterr().out)
    assert ir["signals"][0]["id"] == "gaze_down" and len(ir["constraints"]) == 11
    assert main(["compile", str(FIXTURES / "invalid" / "semantic_errors.xml")]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert (
        "semantic_errors.xml:14:34: E203 unknown signal 'gaze_dwn' in constraint 'c4' (did you mean 'gaze_down'?)"
        in captured.err
    )
    assert "Traceback" not in captured.err


def test_compile_output_is_atomic_and_absent_on_error(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    assert main(["compile", str(FIXTURES / "invalid" / "syntax_errors.xml"), "-o", str(target)]) == 1
    assert not target.exists() and list(tmp_path.iterdir()) == []
    assert main(["compile", str(FIXTURES / "valid" / "minimal.xml"), "-o", str(target)]) == 0
    assert json.loads(target.read_text())["name"] == "minimal"


def _timeline(signals: list[tuple[str, float, float]], duration: float = 10.0) -> dict[str, object]:
    return {
        "format": "mse-timeline/1",
        "expression": "operators",
        "duration": duration,
        "solver": "hand",
        "seed": None,
        "signals": [{"id": i, "modality": "", "lexeme": i, "start": a, "stop": b} for i, a, b in signals],
    }


CONSISTENT = [("gaze_down", 0.5, 2.0), ("smile", 0.7, 1.8), ("bow", 2.2, 3.5)]
INCONSISTENT = [("gaze_down", 0.5, 2.0), ("smile", 3.0, 4.5), ("bow", 1.0, 2.5)]


def test_check_consistent_and_inconsistent(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = str(FIXTURES / "valid" / "operators.xml")
    good = tmp_path / "good.json"
    good.write_text(json.dumps(_timeline(CONSISTENT)))
    assert main(["check", source, str(good)]) == 0, capsys.readouterr()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_timeline(INCONSISTENT)))
    capsys.readouterr()
    assert main(["check", source, str(bad)]) == 1
    out = capsys.readouterr().out
    assert "constraint 'inc' violated" in out and "operators.xml:18:5:" in out
    assert "constraint 'pre' violated" in out
    many = tmp_path / "many.jsonl"
    many.write_text(json.dumps(_timeline(CONSISTENT)) + "\n" + json.dumps(_timeline(INCONSISTENT)) + "\n")
    assert main(["check", source, str(many)]) == 1
    assert "[timeline 2]" in capsys.readouterr().out
    array = tmp_path / "array.json"
    array.write_text(json.dumps([_timeline(CONSISTENT), _timeline(CONSISTENT)]))
    assert main(["check", source, str(array)]) == 0


def test_check_bad_timeline_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    broken = tmp_path / "broken.json"
    broken.write_text('{"duration": 10, "signals": [{"id": 3}]}')
    assert main(["check", str(FIXTURES / "valid" / "minimal.xml"), str(broken)]) == 1
    assert "E212" in capsys.readouterr().err


GRID = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="grid">
  <signals>
    <signal id="a" modality="face" min_duration="0.0015"/>
    <signal id="b" modality="head"/>
  </signals>
  <constraints>
    <constraint id="c1">start(b) &gt;= stop(a) + 0.0005</constraint>
  </constraints>
</expression>
"""


def test_times_finer_than_the_grid_are_warned_not_silently_rounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "grid.xml"
    path.write_text(GRID, encoding="utf-8")
    found = lint([path])
    w309 = [d for d in found if d.code == "W309"]
    assert [d.span.line for d in w309] == [4, 8]
    assert "rounded to 0.002 s" in w309[0].message and "0.0005 s" in w309[1].message
    timeline = tmp_path / "t.json"
    timeline.write_text(json.dumps({"format": "mse-timeline/1", "duration": 10, "signals": [
        {"id": "a", "start": 0.0004, "stop": 1.0}, {"id": "b", "start": 1.5, "stop": 2.0}]}), encoding="utf-8")
    assert main(["check", str(path), str(timeline)]) == 0
    assert "W309" in capsys.readouterr().err


INFEASIBLE = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="tight">
  <modality name="face" exclusive="true"/>
  <signals>
    <signal id="a" modality="face" min_duration="6"/>
    <signal id="b" modality="face" min_duration="6"/>
  </signals>
  <constraints>
    <constraint id="both">exists(a) and exists(b)</constraint>
  </constraints>
</expression>
"""


def test_a_set_without_timeline_is_a_lint_error_at_file_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tight.xml"
    path.write_text(INFEASIBLE, encoding="utf-8")
    assert main(["lint", "--format", "json", str(path)]) == 1
    [record] = [r for r in json.loads(capsys.readouterr().out) if r["code"].endswith("401")]
    assert record["code"] == "E401" and record["severity"] == "error" and record["line"] > 0
    assert "both (" in record["message"] and "[duration]" in record["message"]
    assert main(["lint", str(path), "--duration", "13"]) == 0


@pytest.mark.parametrize("budget", ["-1", "nan", "inf"])
def test_a_bad_deep_budget_is_a_usage_error(budget: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lint", "relief", "--deep-budget", budget]) == 2
    err = capsys.readouterr().err
    assert err.startswith("<arguments>: E130 deep budget") and "Traceback" not in err
