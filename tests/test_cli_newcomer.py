"""What a newcomer trips over (issue 18): empty stdin, pins, lint as a CI tool, check's
report, export's format, animating one's own set, help for every option, the Python API."""

from __future__ import annotations

import argparse
import doctest
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import mse
import mse.api
import mse.sampling
from mse.cli import build_parser, main

REPO_ROOT = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).parent / "fixtures"

TWO_SIGNALS = """<expression name="nod_then_smile">
  <signals>
    <signal id="nod" modality="head" min_duration="0.5" max_duration="1"/>
    <signal id="smile" modality="face" lexeme="faceexp=smile" min_duration="1" max_duration="3"/>
  </signals>
  <constraints><constraint id="nod_first">exists(nod) and precedes(nod, smile)</constraint></constraints>
</expression>
"""


def run_mse(*args: str, stdin: bytes = b"", cwd: Path | None = None) -> subprocess.CompletedProcess[bytes]:
    """``python -m mse ARGS`` with ``stdin`` piped in (a real pipe, as in a shell)."""
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "mse", *args], input=stdin, capture_output=True, cwd=cwd, env=env, timeout=120
    )


# -- 1. empty stdin ---------------------------------------------------------------------------
def test_empty_piped_stdin_is_an_error_not_the_bundled_default() -> None:
    for args in (("sample",), ("sample", "-")):
        result = run_mse(*args, stdin=b"")
        assert result.returncode == 1, result
        assert b"no model on stdin" in result.stderr
        assert b"sampling the bundled expression" not in result.stderr
        assert result.stdout == b""


def test_a_script_whose_own_stdin_is_an_empty_pipe_still_samples_the_default() -> None:
    """A CI harness may run a script with an empty pipe as its input: that pipe was not made
    for ``mse sample`` (it is the script's own stdin), so it is not "no model on stdin"."""
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT)}
    script = f"'{sys.executable}' -m mse sample --duration 2 --seed 1 --format json; exit $?"
    result = subprocess.run(["bash", "-c", script], input=b"", capture_output=True, env=env, timeout=120)
    if b"no model on stdin" in result.stderr and not Path(f"/proc/{os.getpid()}/fd/0").exists():
        pytest.skip("no /proc: an inherited stdin cannot be told from a pipe")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["expression"] == "embarrassment"


def test_piped_model_is_still_read() -> None:
    result = run_mse("sample", "--seed", "1", "--format", "json", stdin=TWO_SIGNALS.encode())
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["expression"] == "nod_then_smile"


# -- 5. pins ----------------------------------------------------------------------------------
def test_pin_with_start_after_stop_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "anger", "--solver", "cpsat", "--pin", "frown@4-3"]) == 1
    err = capsys.readouterr().err
    assert "start 4 > stop 3" in err and "not inside" not in err
    with pytest.raises(mse.MseError, match="start 4 = stop 4"):
        mse.sample(mse.load("anger"), 10.0, seed=1, solver="cpsat", pinned=[mse.Pin("frown", 4.0, 4.0)])


# -- 6. lint ----------------------------------------------------------------------------------
def test_lint_folder_without_sets_warns_and_fails_under_strict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["lint", "--no-deep", str(tmp_path)]) == 0
    assert "W300" in capsys.readouterr().out
    assert main(["lint", "--no-deep", "--strict", str(tmp_path)]) == 1


def test_lint_takes_bundled_names(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lint", "--strict", "embarrassment", "anger"]) == 0
    assert main(["lint", "embarasment"]) == 1
    assert "did you mean 'embarrassment'" in capsys.readouterr().out


def test_lint_refuses_select_or_ignore_that_matches_no_rule(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lint", "--select", "X9", "relief"]) == 2
    assert "'X9' matches no rule code" in capsys.readouterr().err
    assert main(["lint", "--ignore", "W30,W99", "relief"]) == 2
    assert main(["lint", "--select", "W30,W4", "relief"]) == 0
    with pytest.raises(mse.MseError, match="matches no rule code"):
        mse.lint(["relief"], ignore=["Z"])


def test_lint_api_and_cli_run_the_same_rules(capsys: pytest.CaptureFixture[str]) -> None:
    conflict = FIXTURES / "solvers" / "conflict.xml"
    assert conflict.is_file()
    main(["lint", "--format", "json", "--duration", "2", str(conflict)])
    from_cli = [(r["code"], r["line"]) for r in json.loads(capsys.readouterr().out)]
    from_api = [(d.code, d.span.line) for d in mse.lint([conflict], duration=2.0)]
    assert from_cli == from_api
    assert any(code.startswith("W4") or code.startswith("E") for code, _ in from_api), from_api


def test_sarif_has_no_placeholder_uri(capsys: pytest.CaptureFixture[str]) -> None:
    main(["lint", "--no-deep", "--format", "sarif", str(FIXTURES / "lint" / "warnings.xml")])
    out = capsys.readouterr().out
    assert "example.invalid" not in out
    driver = json.loads(out)["runs"][0]["tool"]["driver"]
    assert "informationUri" not in driver or driver["informationUri"].startswith("https://")


# -- 7. check ---------------------------------------------------------------------------------
def test_check_summary_on_stdout_and_json_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    timeline = tmp_path / "t.json"
    assert main(["sample", "relief", "--seed", "1", "--format", "json", "-o", str(timeline)]) == 0
    assert main(["check", "relief", str(timeline)]) == 0
    assert "1 of 1 timeline(s) consistent with relief" in capsys.readouterr().out
    assert main(["check", "anger", str(timeline), "--format", "json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["expression"] == "anger" and report["timelines"] == 1 and report["consistent"] == 0
    violation = report["results"][0]["violations"][0]
    assert {"path", "line", "col", "kind", "constraint", "message"} <= set(violation)


def test_stream_lines_are_explained(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = tmp_path / "s.jsonl"
    lines.write_text('{"id": "smile", "modality": "face", "lexeme": "smile", "start": 0.5, "stop": 2.0}\n')
    assert main(["check", "relief", str(lines)]) == 1
    assert "signal line of 'mse sample --stream', not a timeline" in capsys.readouterr().err


# -- 8. export --------------------------------------------------------------------------------
def test_export_format_from_the_output_extension(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    timeline = tmp_path / "t.json"
    main(["sample", "relief", "--seed", "1", "--format", "json", "-o", str(timeline)])
    assert main(["export", str(timeline), "-o", str(tmp_path / "t.svg")]) == 0
    assert "<svg" in (tmp_path / "t.svg").read_text(encoding="utf-8")
    assert main(["export", str(timeline), "-o", str(tmp_path / "t.bml")]) == 0
    assert "<bml" in (tmp_path / "t.bml").read_text(encoding="utf-8")
    assert main(["export", str(timeline), "-o", str(tmp_path / "t.foo")]) == 1
    assert "give --format" in capsys.readouterr().err
    assert not (tmp_path / "t.foo").exists()


def test_face_library_lacking_the_lexemes_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    library = tmp_path / "facelibrary.xml"
    library.write_text(
        '<facelibrary><expression class="faceexp" instance="frown"><action name="AU4" intensity="1"/>'
        "</expression></facelibrary>",
        encoding="utf-8",
    )
    model = tmp_path / "set.xml"
    model.write_text(TWO_SIGNALS, encoding="utf-8")
    timeline = tmp_path / "t.json"
    assert main(["sample", str(model), "--seed", "1", "--solver", "cpsat", "--require", "smile",
                 "-o", str(timeline)]) == 0
    capsys.readouterr()
    args = ["export", str(timeline), "-f", "bml", "--face-library", str(library), "--bml-extensions"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "faceexp=smile" in captured.err and "not in this face library" in captured.err
    assert "faceFacs" not in captured.out


# -- 4. animate one's own set -----------------------------------------------------------------
def test_timeline_records_its_source(tmp_path: Path) -> None:
    bundled = mse.sample(mse.load("relief"), 4.0, seed=1)
    assert bundled.source is not None and bundled.source["bundled"] == "relief"
    path = tmp_path / "mine.xml"
    path.write_text(TWO_SIGNALS, encoding="utf-8")
    own = mse.sample(mse.load(path), 4.0, seed=1)
    assert own.source is not None and own.source["path"] == str(path.resolve())
    assert len(own.source["sha256"]) == 64
    again = mse.Timeline.from_json(json.loads(own.dumps()))
    assert again.source == own.source
    assert mse.Timeline.from_json({"duration": 1.0, "signals": []}).source is None  # older timelines


def test_animate_finds_the_recorded_file_and_refuses_a_wrong_expression(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "mine.xml"
    path.write_text(TWO_SIGNALS, encoding="utf-8")
    timeline = tmp_path / "t.json"
    assert main(["sample", str(path), "--seed", "1", "--format", "json", "-o", str(timeline)]) == 0
    monkeypatch.chdir(tmp_path.parent)  # the recorded path is absolute: any folder works
    assert main(["animate", str(timeline), "-o", str(tmp_path / "out")]) == 0
    assert "warning" not in capsys.readouterr().err
    assert main(["animate", str(timeline), "-o", str(tmp_path / "wrong"), "--expression", "anger"]) == 1
    err = capsys.readouterr().err
    assert "are not in expression 'anger'" in err and "0 motion clip" not in err
    path.write_text(TWO_SIGNALS + "<!-- edited -->\n", encoding="utf-8")
    assert main(["animate", str(timeline), "-o", str(tmp_path / "edited")]) == 0
    assert "changed since the timeline was sampled" in capsys.readouterr().err
    path.unlink()
    assert main(["animate", str(timeline), "-o", str(tmp_path / "gone")]) == 1
    assert "give --expression" in capsys.readouterr().err


def test_animate_style_with_unknown_emotion_lists_the_known(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    timeline = tmp_path / "t.json"
    main(["sample", "relief", "--seed", "1", "--format", "json", "-o", str(timeline)])
    assert main(["animate", str(timeline), "-o", str(tmp_path / "out"), "--style", "angr=sad"]) == 1
    err = capsys.readouterr().err
    assert "unknown emotion(s) 'angr'" in err and "anger" in err
    assert not (tmp_path / "out").exists()


def test_style_train_with_unknown_action_lists_the_actions() -> None:
    from mse.motion.base.library import Clip, MotionLibrary
    from mse.motion.hsmm.leaf import train_from_library

    clips = (Clip("c1", "walk", "sad", "p1", "c1.bvh"), Clip("c2", "bow", "sad", "p1", "c2.bvh"))
    library = MotionLibrary("lib", clips)
    with pytest.raises(mse.MseError, match="no clips of action 'wlk' in the motion library; it has: bow, walk"):
        train_from_library(library, "wlk")
    with pytest.raises(mse.MseError, match="it has: walk in sad"):
        train_from_library(library, "walk", style="happy")


# -- 9. help ----------------------------------------------------------------------------------
def _parsers(parser: argparse.ArgumentParser, name: str = "mse") -> list[tuple[str, argparse.ArgumentParser]]:
    found = [(name, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                found.extend(_parsers(sub, f"{name} {sub_name}"))
    return found


def test_every_option_of_every_command_has_help() -> None:
    missing, bad_defaults = [], []
    for name, parser in _parsers(build_parser()):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                continue
            if not action.help:
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}")
            has_default = action.default not in (None, argparse.SUPPRESS, [])
            if action.choices is not None and has_default and action.default not in action.choices:
                bad_defaults.append(f"{name} {action.dest}={action.default!r}")
    assert missing == [], missing
    assert bad_defaults == [], bad_defaults


def test_every_command_has_a_description_and_no_help_points_outside_the_wheel() -> None:
    for name, parser in _parsers(build_parser()):
        if name != "mse":
            assert parser.description, f"{name} has no description"
        text = parser.format_help()
        assert "docs/" not in text, f"{name} --help points at a doc the wheel does not ship"


def test_require_and_forbid_are_not_filed_under_exact_solvers() -> None:
    parser = dict(_parsers(build_parser()))["mse sample"]
    for group in parser._action_groups:
        options = {o for action in group._group_actions for o in action.option_strings}
        if group.title and "exact" in group.title:
            assert not options & {"--require", "--forbid", "--pin"}, group.title


def test_default_objective_names_agree() -> None:
    from mse.cli import cmd_sample
    from mse.solve import objectives

    assert cmd_sample.DEFAULT_OBJECTIVE == objectives.DEFAULT_OBJECTIVE
    model = mse.load("relief")
    assert mse.sample(model, 4.0, seed=3, objective="profile") == mse.sample(model, 4.0, seed=3)


# -- 10. the Python API -----------------------------------------------------------------------
def test_a_string_require_is_one_signal() -> None:
    model = mse.load("anger")
    timeline = mse.sample(model, 10.0, seed=1, require="frown", forbid="frown_teeth")
    ids = {s.id for s in timeline.signals}
    assert "frown" in ids and "frown_teeth" not in ids


def test_request_types_are_importable_from_mse() -> None:
    from mse import Explanation, NoSolution, Pin, SolveRequest, TimelineSignal

    assert Pin("a", 0.0, 1.0).signal == "a"
    assert SolveRequest().duration == 10.0
    assert issubclass(NoSolution, mse.MseError)
    assert TimelineSignal and Explanation
    for name in mse.__all__:
        assert getattr(mse, name) is not None


def _public_functions() -> list[str]:
    names = [n for n in mse.__all__ if callable(getattr(mse, n)) and not isinstance(getattr(mse, n), type)]
    module_functions = [
        n
        for module in (mse.api, mse.sampling)
        for n, value in vars(module).items()
        if not n.startswith("_") and callable(value) and not isinstance(value, type)
        and getattr(value, "__module__", "") == module.__name__  # its own functions, not those it imports
    ]
    return sorted(set(names) | set(module_functions))


def test_every_public_function_has_a_docstring_with_an_example() -> None:
    functions = _public_functions()
    assert {"sample", "load", "lint", "explain", "check", "iter_sample", "loads"} <= set(functions)
    lacking = [n for n in functions
               if ">>>" not in ((getattr(mse.api, n, None) or getattr(mse.sampling, n)).__doc__ or "")]
    assert lacking == [], lacking


@pytest.mark.slow
@pytest.mark.parametrize("module", [mse, mse.api, mse.sampling], ids=lambda m: m.__name__)
def test_docstring_examples_run(module: object) -> None:
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)  # type: ignore[arg-type]
    assert result.attempted > 0 and result.failed == 0, result


def test_docs_api_lists_every_name_and_its_examples_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = (REPO_ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    for name in [*mse.__all__, *_public_functions()]:
        if name != "__version__":
            assert re.search(rf"\b{re.escape(name)}\b", text), f"docs/api.md does not mention {name}"
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 8
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    for number, block in enumerate(blocks, 1):
        exec(compile(block, f"docs/api.md (python block {number})", "exec"), namespace)
