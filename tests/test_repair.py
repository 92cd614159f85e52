"""`mse repair` / `mse.repair`: the nearest consistent timeline to a proposal (issue 33).

Every repaired timeline is re-checked by the evaluator and by an independent checker written
from docs/semantics.md; its cost is compared with an independent computation of the objective.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse
from mse.cli import main
from mse.ir.evaluate import check_schedule
from mse.repairing.read import proposal_schema
from tests.independent_checker import problems

EXAMPLE = {
    "format": "mse-proposal/1",
    "expression": "embarrassment",
    "duration": 8,
    "occurrences": [
        {"signal": "tensed_smile", "start": 0.5, "stop": 3.0, "id": "first_smile"},
        {"signal": "gaze_down", "start": 1.0, "stop": 2.5},
        {"lexeme": "head=head_down", "start": 0.8, "stop": 3.2},
        {"signal": "hand_on_mouth", "start": 2.5, "stop": 4.5, "weight": 5},
        {"signal": "wink", "start": 5.0, "stop": 5.3},
    ],
}


def _consistent(model: mse.Model, repair: mse.Repair) -> None:
    schedule = repair.timeline.to_schedule()
    assert check_schedule(model, schedule) == []
    assert problems(model, [(o.signal, o.start, o.stop) for o in schedule.occurrences], schedule.duration) == []


def _cost(proposed: list[tuple[str, int, int, int]], result: list[tuple[str, int, int]]) -> tuple[int, int]:
    """(dropped + added, weighted ms moved) of ``result`` against ``proposed`` (signal, start,
    stop[, weight]), with the best order-preserving matching per signal (a small DP)."""
    changes = moved = 0
    for name in {p[0] for p in proposed} | {r[0] for r in result}:
        ps = sorted(p for p in proposed if p[0] == name)
        rs = sorted(r for r in result if r[0] == name)
        best: dict[tuple[int, int], tuple[int, int]] = {(0, 0): (0, 0)}
        for i in range(len(ps) + 1):
            for j in range(len(rs) + 1):
                if (i, j) == (0, 0):
                    continue
                options = []
                if i:
                    c, m = best[(i - 1, j)]
                    options.append((c + 1, m))
                if j:
                    c, m = best[(i, j - 1)]
                    options.append((c + 1, m))
                if i and j:
                    c, m = best[(i - 1, j - 1)]
                    p, r = ps[i - 1], rs[j - 1]
                    options.append((c, m + p[3] * (abs(p[1] - r[1]) + abs(p[2] - r[2]))))
                best[(i, j)] = min(options)
        c, m = best[(len(ps), len(rs))]
        changes, moved = changes + c, moved + m
    return changes, moved


def _perturbed(timeline: mse.Timeline, rng: random.Random) -> dict[str, object]:
    ticks = round(timeline.duration * 1000)
    out: list[list[object]] = []
    for s in timeline.signals:
        if rng.random() < 0.15:
            continue
        start, length = round(s.start * 1000), round((s.stop - s.start) * 1000)
        if rng.random() < 0.5:
            start = min(max(0, start + rng.randint(-1500, 1500)), ticks - 1)
        if rng.random() < 0.3:
            length = max(1, round(length * rng.uniform(0.5, 1.6)))
        out.append([s.id, start, start + length])
        if rng.random() < 0.1:
            at = rng.randint(0, max(0, ticks - length))
            out.append([s.id, at, at + length])
    if len(out) > 1 and rng.random() < 0.3:
        i, j = rng.sample(range(len(out)), 2)
        out[i][1:], out[j][1:] = out[j][1:], out[i][1:]
    if rng.random() < 0.3:
        out.append(["not_a_signal", 1000, 2000])
    out.sort(key=lambda item: (item[1], item[0]))  # type: ignore[arg-type, return-value]
    kept, last = [], {}
    for name, start, stop in out:
        if start >= last.get(name, -1):  # type: ignore[operator]
            kept.append((name, start, stop))
            last[name] = stop
    return {"duration": timeline.duration,
            "occurrences": [{"signal": n, "start": a / 1000, "stop": b / 1000} for n, a, b in kept]}


# -- the worked example of docs/repair.md -------------------------------------------------------
def test_worked_example_moves_the_smile_after_the_gaze_and_reports_the_foreign_wink() -> None:
    model = mse.load("embarrassment")
    result = mse.repair(model, EXAMPLE)
    _consistent(model, result)
    assert result.optimal and not result.unchanged
    kinds = [(c.kind, c.signal) for c in result.changes]
    assert kinds == [("moved", "tensed_smile"), ("foreign", "wink")]
    moved = result.changes[0]
    assert (moved.start, moved.stop, moved.moved) == (2500, 4500, 3500)
    assert [r.rule for r in moved.reasons] == ["looks_down_first"]
    assert moved.reasons[0].span.path.endswith("embarrassment.xml") and moved.reasons[0].span.line > 0
    report = result.to_json()
    assert (report["moved"], report["moved_ms"], report["foreign"], report["dropped"]) == (1, 3500, 1, 0)


def test_schema_accepts_the_example_and_refuses_what_the_reader_refuses() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    validator = jsonschema.Draft202012Validator(proposal_schema())
    assert validator.is_valid(EXAMPLE)
    assert validator.is_valid({"text": "[gaze_down] I am sorry", "words": [["I", 0, 0.1], ["am", 0.1, 0.3],
                                                                          ["sorry", 0.3, 0.8]]})
    assert validator.is_valid({"occurrences": [{"signal": "smile"}, {"signal": "bow", "length": 3}]})
    for bad in ({"occurrences": [{"signal": "a", "lexeme": "b"}]}, {"occurrences": [{"signal": "a", "when": 1}]},
                {"occurrences": [{"signal": "a", "start": -1}]}, {"words": []}, {"occurrences": [], "text": "x"}):
        assert not validator.is_valid(bad), bad
        with pytest.raises(mse.MseError):
            mse.repair(mse.load("embarrassment"), bad)


# -- perturbed timelines, re-checked ---------------------------------------------------------
@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), name=st.sampled_from(["anger", "anxiety", "embarrassment", "relief", "tension"]))
def test_repaired_perturbations_are_consistent_optimal_and_no_farther_than_the_original(seed: int, name: str) -> None:
    model = mse.load(name)
    original = mse.sample(model, 10.0, seed=seed)
    proposal = _perturbed(original, random.Random(seed))
    result = mse.repair(model, proposal)
    _consistent(model, result)
    assert result.optimal
    proposed = [(o["signal"], round(o["start"] * 1000), round(o["stop"] * 1000), 1)  # type: ignore[index]
                for o in proposal["occurrences"] if o["signal"] in model.signal_by_id]  # type: ignore[attr-defined]
    ours = _cost(proposed, [(o.signal, o.start, o.stop) for o in result.timeline.to_schedule().occurrences])
    theirs = _cost(proposed, [(o.signal, o.start, o.stop) for o in original.to_schedule().occurrences])
    assert ours <= theirs  # the original is consistent: the nearest cannot be farther
    assert ours == (result.count("dropped") + result.count("added"), result.moved)
    for change in result.changes:  # every change has a rule that forced it
        assert change.kind == "foreign" or change.reasons, change
    assert result.count("foreign") == sum(o["signal"] == "not_a_signal" for o in proposal["occurrences"])  # type: ignore[attr-defined, index]


@pytest.mark.parametrize("name", ["anger", "pride", "panic_fear", "cheerfulness"])
def test_a_consistent_timeline_comes_back_as_it_is(name: str) -> None:
    model = mse.load(name)
    timeline = mse.sample(model, 10.0, seed=5)
    result = mse.repair(model, timeline)
    assert result.unchanged and result.timeline is timeline and result.changes == ()


def test_weights_decide_which_occurrence_moves() -> None:
    model = mse.load("embarrassment")
    base = [{"signal": "head_down", "start": 0.5, "stop": 3.5}, {"signal": "gaze_down", "start": 1, "stop": 2.8},
            {"signal": "tensed_smile", "start": 2.5, "stop": 5}]
    heavy_smile = [*base[:2], {**base[2], "weight": 100}]  # 300 ms either way: the weight decides
    heavy_gaze = [base[0], {**base[1], "weight": 100}, base[2]]
    assert [c.signal for c in mse.repair(model, {"duration": 10, "occurrences": heavy_smile}).changes] == ["gaze_down"]
    assert [c.signal for c in mse.repair(model, {"duration": 10, "occurrences": heavy_gaze}).changes] == [
        "tensed_smile"]
    fixed_gaze = [base[0], {**base[1], "fixed": True}, base[2]]
    moved = mse.repair(model, {"duration": 10, "occurrences": fixed_gaze})
    assert [c.signal for c in moved.changes] == ["tensed_smile"]
    assert moved.changes[0].start == 2800


def test_order_and_rough_lengths_only() -> None:
    model = mse.load("embarrassment")
    result = mse.repair(model, {"duration": 8, "occurrences": [{"signal": "tensed_smile"}, {"signal": "gaze_down"}]})
    _consistent(model, result)
    assert all(c.proposed is None or c.proposed.estimated for c in result.changes)


def test_tagged_text_with_estimated_and_given_word_times() -> None:
    model = mse.load("embarrassment")
    text = "[gaze_down] I am [tensed_smile]so sorry[/tensed_smile] about that"
    estimated = mse.repair(model, text, duration=6)
    _consistent(model, estimated)
    words = [["I", 0.0, 0.2], ["am", 0.2, 0.5], ["so", 2.0, 2.4], ["sorry", 2.4, 4.5], ["about", 4.5, 4.8],
             ["that", 4.8, 5.2]]
    given_times = mse.repair(model, {"duration": 6, "text": text, "words": words})
    _consistent(model, given_times)
    smile = next(s for s in given_times.timeline.signals if s.id == "tensed_smile")
    assert (smile.start, smile.stop) == (2.0, 4.5)  # the tag's words, already consistent


# -- --keep, infeasibility ------------------------------------------------------------------
def test_keep_that_cannot_hold_is_a_minimal_explanation() -> None:
    model = mse.load("embarrassment")
    stuck = {"duration": 8, "occurrences": [
        {"signal": "tensed_smile", "start": 0.5, "stop": 3.0, "fixed": True},
        {"signal": "gaze_down", "start": 3.0, "stop": 4.5}]}
    assert [c.kind for c in mse.repair(model, stuck).changes] == ["dropped"]
    with pytest.raises(mse.NoRepair) as failure:
        mse.repair(model, stuck, keep=["gaze_down"])
    ids = sorted(item.id for item in failure.value.items)
    assert ids == ["gaze_down", "gaze_down", "looks_down_first", "tensed_smile"]
    assert failure.value.proven and failure.value.diagnostics[0].code == "E702"


def test_keeping_two_of_a_signal_that_occurs_once() -> None:
    model = mse.load("embarrassment")
    twice = {"duration": 10, "occurrences": [{"signal": "bow", "start": 0, "stop": 3},
                                             {"signal": "bow", "start": 5, "stop": 8}]}
    assert mse.repair(model, twice).count("dropped") == 1
    with pytest.raises(mse.NoRepair) as failure:
        mse.repair(model, twice, keep=["bow"])
    assert "at most 1 time" in failure.value.diagnostics[0].message


# -- the command line -------------------------------------------------------------------------
def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(args)
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_repairs_reports_and_writes_back_consistent_timelines_unchanged(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    proposal = tmp_path / "proposal.json"
    proposal.write_text(json.dumps(EXAMPLE, indent=2))
    fixed, report = tmp_path / "fixed.json", tmp_path / "report.json"
    code, _, err = _run(["repair", "embarrassment", str(proposal), "-o", str(fixed), "--report", str(report)], capsys)
    assert code == 0, err
    assert f"{proposal}:6:5: moved tensed_smile 'first_smile'" in err
    assert "W701 wink" in err
    assert json.loads(report.read_text())["changes"][0]["because"][0]["rule"] == "looks_down_first"
    assert main(["check", "embarrassment", str(fixed)]) == 0
    again = tmp_path / "again.json"
    code, _, err = _run(["repair", "embarrassment", str(fixed), "-o", str(again)], capsys)
    assert code == 0 and "unchanged" in err
    assert again.read_bytes() == fixed.read_bytes()
    sampled = tmp_path / "t.json"
    assert main(["sample", "relief", "--seed", "4", "-o", str(sampled)]) == 0
    code, out, _ = _run(["repair", "relief", str(sampled)], capsys)
    assert code == 0 and out == sampled.read_text()


def test_cli_keep_that_cannot_hold_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    stuck = tmp_path / "stuck.json"
    stuck.write_text('{"duration": 8, "occurrences": [\n'
                     '  {"signal": "tensed_smile", "start": 0.5, "stop": 3.0, "fixed": true},\n'
                     '  {"signal": "gaze_down", "start": 3.0, "stop": 4.5}\n]}')
    out = tmp_path / "out.json"
    code, _, err = _run(["repair", "embarrassment", str(stuck), "--keep", "gaze_down", "-o", str(out)], capsys)
    assert code == 2 and not out.exists()
    assert f"{stuck}:2:3: E702 " in err and "looks_down_first" in err


@pytest.mark.parametrize(("text", "where", "needle"), [
    ('{"duration": 8, "occurrences": [', "1:33", "invalid JSON"),
    ('{"duration": 8, "occurrences": [{"signal": "smile", "start": 1, "stop": NaN}]}', "1:", "NaN"),
    ('{"duration": 8,\n "occurrences": [{"signal": "smile", "start": -1, "stop": 2}]}', "2:47", "start -1"),
    ('{"duration": 8,\n "occurrences": [{"signal": "smile", "start": 3, "stop": 2}]}', "2:18", "not after its start"),
    ('{"duration": 8, "occurrences": [\n {"signal": "smile", "start": 1, "stop": 3},\n'
     ' {"signal": "smile", "start": 2, "stop": 4}]}', "3:2", "overlaps"),
    ('{"duration": 8, "occurrences": [\n {"signal": "smile", "begin": 1}]}', "2:31", "unknown key 'begin'"),
    ('{"duration": "long", "occurrences": []}', "1:14", "'duration' must be"),
    ('{"text": "[smile] hi there", "words": [["hi", 0, 0.2]]}', "1:", "gives 1 words"),
    ("I said [/smile] it", "1:8", "closes no open"),
    ('{"format": "mse-proposal/2", "occurrences": []}', "1:12", "unknown format"),
])
def test_cli_bad_input_is_located_and_exits_1(text: str, where: str, needle: str, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(text)
    out = tmp_path / "out.json"
    code, _, err = _run(["repair", "embarrassment", str(bad), "-o", str(out)], capsys)
    assert code == 1 and not out.exists()
    assert f"{bad}:{where}" in err and " E218 " in err and needle in err, err
    assert "Traceback" not in err


def test_cli_unknown_keep_and_strict(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    proposal = tmp_path / "p.json"
    proposal.write_text(json.dumps(EXAMPLE))
    code, _, err = _run(["repair", "embarrassment", str(proposal), "--keep", "nothing"], capsys)
    assert code == 1 and "E100 --keep 'nothing'" in err
    code, _, err = _run(["repair", "embarrassment", str(proposal), "--strict"], capsys)
    assert code == 1 and "E218 wink" in err


@pytest.mark.shared
def test_sets_imported_from_greta(greta_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["import-greta", str(greta_dir / "lexicon.xml"), str(greta_dir / "constraint.xml"),
                 "-o", str(tmp_path)]) == 0
    capsys.readouterr()
    rng = random.Random(3)
    for path in sorted(tmp_path.glob("*.xml")):
        model = mse.load(path)
        for seed in range(3):
            original = mse.sample(model, 10.0, seed=seed)
            assert mse.repair(model, original).timeline is original
            result = mse.repair(model, _perturbed(original, rng))
            _consistent(model, result)
            assert result.optimal, path.name
