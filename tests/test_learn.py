"""``mse learn``: signals and rules learned from a corpus, with evidence; the result is a
valid behaviour set (round trip), lint-clean, samplable, and accepts every corpus sequence
at confidence 1 (checked with the one evaluator)."""

from __future__ import annotations

import random
import re
from pathlib import Path
from typing import Any

import pytest

import mse.api as api
import mse.sampling as sampling
from mse.cli import main
from mse.diagnostics import Severity
from mse.ir import model as ir
from mse.learn import LearnOptions, LearnResult, learn
from mse.learn.implication import ImplicationChecker
from mse.learn.signals import profile_from, profile_mean
from mse.timeline import dumps_jsonl

FIXTURES = Path(__file__).parent / "fixtures" / "learn"
QUICK = LearnOptions(name="relief", confidence=1.0, calibration_rounds=1, calibration_samples=100)


@pytest.fixture(scope="module")
def relief_corpus(tmp_path_factory: pytest.TempPathFactory) -> Path:
    timelines = sampling.iter_timelines(api.load("relief"), 10.0, seed=11, count=300)
    path = tmp_path_factory.mktemp("corpus") / "relief.jsonl"
    path.write_text(dumps_jsonl(timelines), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def relief(relief_corpus: Path) -> LearnResult:
    return learn([relief_corpus], QUICK)


def test_confidence_one_accepts_every_corpus_sequence(relief: LearnResult, relief_corpus: Path) -> None:
    assert relief.breaks == []
    from mse.timeline import loads_many

    for timeline in loads_many(relief_corpus.read_text(encoding="utf-8")):
        assert api.check(relief.model, timeline) == []


def test_xml_round_trips_through_the_reader(relief: LearnResult) -> None:
    loaded = api.loads(relief.xml)
    assert loaded.signals == relief.model.signals
    assert loaded.constraints == relief.model.constraints
    assert loaded.modalities == relief.model.modalities


def _explained_w406(relief: LearnResult) -> set[str]:
    """Signals kept above probability_start 0 despite W406, as the calibration notes say: a
    once-only signal above level 0.5 that a profile from 0 cannot reach (docs/learn.md)."""
    kept = [n.split(": ", 1)[1] for n in relief.calibration if n.startswith("probability_start kept above 0")]
    return {name for line in kept for name in line.split(", ")}


def test_result_is_lint_clean_and_samplable(relief: LearnResult, tmp_path: Path) -> None:
    explained = _explained_w406(relief)
    for signal in explained:
        assert relief.model.signal(signal).probability_start + relief.model.signal(signal).probability_end > 1
    found = [d for d in relief.diagnostics if d.code[:2] in ("W3", "W4")]
    assert [d.render() for d in found if not (d.code == "W406" and d.message.split("'")[1] in explained)] == []
    path = tmp_path / "relief.xml"
    path.write_text(relief.xml, encoding="utf-8")
    # notes (N407: a learned relation void in most timelines) say what the corpus shows
    assert [d.render() for d in api.lint([path], deep=True, duration=10.0) if d.severity is not Severity.NOTE
            and not (d.code == "W406" and d.message.split("'")[1] in explained)] == []
    timeline = sampling.sample(relief.model, 10.0, seed=1)
    assert api.check(relief.model, timeline) == []  # type: ignore[arg-type]


def test_every_rule_carries_its_evidence(relief: LearnResult) -> None:
    lines = relief.xml.splitlines()
    constraints = [i for i, line in enumerate(lines) if "<constraint " in line]
    assert constraints
    for index in constraints:
        assert re.search(r"<!-- support \d+, confidence 1\.000 \(holds in (\d+) of \1 sequences\)", lines[index - 1])
    for signal in relief.model.signals:
        assert any(f'id="{signal.id}"' in line for line in lines)


def test_known_rules_of_the_generating_set_are_recovered(relief: LearnResult) -> None:
    """Not ``tilt_after_head_up`` (``rightincludes(head_tilt_right, head_up)``): since the
    default sampler draws relief exactly (the rejection stage), the two occur together in 6 of
    the 300 timelines, below ``--min-support`` (10): no corpus of this size can teach it."""
    truth = api.load("relief")
    # Four rules of relief are no longer recovered from the walk's 300 timelines: the walk now
    # follows the target more closely, where their signals co-occur less (head_up with
    # open_mouth: 1 % of the walk's timelines, 6.5 % of the target's, 5.7 % of the walk's
    # before, which drew head_up at open_mouth's start), or it is still under the target on
    # relief (-0.24 once-only signals; docs/sampler.md, "The walk's choices against the
    # target").  A corpus drawn from the target by rejection does not give head_up_with_mouth
    # either.  Left out: head_up_with_mouth, tilt_after_head_up, smile_after_exhale,
    # gaze_away_after_exhale.
    wanted = {c.id: c.expr for c in truth.constraints if c.id in ("thrust_outlasts_mouth", "one_torso_movement")}
    checker = ImplicationChecker(relief.model, list(wanted.values()), duration=10000)
    learned = [c.id for c in relief.model.constraints]
    for number, name in enumerate(wanted):
        assert checker.implied(f"extra:{number}", learned) == "yes", name


def test_signals_recover_durations_and_exclusivity(relief: LearnResult) -> None:
    truth = api.load("relief")
    for signal in relief.model.signals:
        original = truth.signal(signal.id)
        assert original.min_duration <= signal.min_duration < signal.max_duration <= original.max_duration + 0.05  # type: ignore[operator]
        assert signal.repetitivity == 0
        assert signal.modality == original.modality
        assert (signal.motion is None) == (original.motion is None)
    assert {"face", "gesture"} <= relief.model.exclusive_modalities


def _write_csv(path: Path, rows: list[tuple[str, str, float, float, str]]) -> Path:
    path.write_text("sequence,tier,start,stop,label\n" + "".join(
        f"{s},{t},{a:.3f},{b:.3f},{label}\n" for s, t, a, b, label in rows), encoding="utf-8")
    return path


def _ordered_corpus(tmp_path: Path, exceptions: int) -> Path:
    """a (face) then b (head) in 40 sequences, b first in ``exceptions`` of them."""
    rng = random.Random(4)
    rows = []
    for number in range(40):
        a_start = rng.uniform(0, 3)
        a_stop = a_start + rng.uniform(1, 2)
        b_start = a_stop + rng.uniform(0.1, 2)
        if number < exceptions:
            a_start, b_start = b_start, a_start
            a_stop = a_start + 1
        rows.append((f"s{number}", "face", a_start, a_stop, "a"))
        rows.append((f"s{number}", "head", b_start, b_start + 1.5, "b"))
        rows.append((f"s{number}", "gaze", 0.0, 0.5, "c"))
        rows.append((f"s{number}", "torso", 9.0, 10.0, "end"))
    return _write_csv(tmp_path / "ordered.csv", rows)


def test_below_one_the_breaking_sequences_are_named(tmp_path: Path) -> None:
    corpus = _ordered_corpus(tmp_path, exceptions=2)
    strict = learn([corpus], LearnOptions(confidence=1.0, calibrate=False, deep_lint=False))
    assert ir.Relation("precedes", "a", "b") not in [c.expr for c in strict.model.constraints]
    assert strict.breaks == []
    loose = learn([corpus], LearnOptions(confidence=0.9, calibrate=False, deep_lint=False))
    kept = {c.id: c.expr for c in loose.model.constraints}
    assert ir.Relation("precedes", "a", "b") in kept.values()
    rule = next(k for k, v in kept.items() if v == ir.Relation("precedes", "a", "b"))
    broken = {(b.sequence, b.rule) for b in loose.breaks}
    assert ("s0", rule) in broken and ("s1", rule) in broken
    assert not any(b.sequence == "s5" for b in loose.breaks)


def test_repetition_and_overlapping_tiers(tmp_path: Path) -> None:
    rows = []
    for number in range(20):
        rows += [(f"s{number}", "head", 0.5, 1.0, "nod"), (f"s{number}", "head", 2.0, 2.6, "nod"),
                 (f"s{number}", "face", 0.0, 3.0, "smile"), (f"s{number}", "face", 1.0, 2.0, "frown")]
        if number % 2:
            rows.append((f"s{number}", "head", 4.0, 4.4, "nod"))
    result = learn([_write_csv(tmp_path / "r.csv", rows)], LearnOptions(calibrate=False, deep_lint=False))
    nod = result.model.signal("nod")
    assert nod.repetitivity == 1 and nod.max_occurrences == 3
    assert (nod.min_duration, nod.max_duration) == (0.4, 0.6)
    assert "head" in result.model.exclusive_modalities
    assert "face" not in result.model.exclusive_modalities  # the frown is inside the smile


def test_profile_follows_the_sampler_definition() -> None:
    for level, mean in ((0.5, 0.5), (0.3, 0.4), (0.45, 0.6)):
        start, end = profile_from(level, mean)
        assert (start + end) / 2 == pytest.approx(level, abs=1e-3)
        assert profile_mean(start, end) == pytest.approx(mean, abs=2e-3)
    assert profile_from(0.9, 0.2) == (1.0, 0.8)  # clipped: the occurrence rate wins


def test_once_only_probabilities_are_estimated_by_moments(tmp_path: Path) -> None:
    rng = random.Random(9)
    rows = []
    for number in range(400):
        rows.append((f"s{number}", "torso", 9.5, 10.0, "end"))
        if rng.random() < 0.4:  # occurs in 40 %, start density ∝ 1 - u (p 0.8 -> 0)
            u = 1 - (1 - rng.random()) ** 0.5
            rows.append((f"s{number}", "face", u * 9, u * 9 + 0.5, "smile"))
    result = learn([_write_csv(tmp_path / "p.csv", rows)], LearnOptions(calibrate=False, deep_lint=False))
    smile = result.model.signal("smile")
    assert (smile.probability_start + smile.probability_end) / 2 == pytest.approx(0.4, abs=0.05)
    assert smile.probability_start > 0.5 and smile.probability_end < 0.2


def test_cli_learns_from_elan_files_with_a_mapping(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "learned.xml"
    report = tmp_path / "report.json"
    files = [str(f) for f in sorted(FIXTURES.glob("session_*.eaf"))]
    code = main(["learn", *files, "--mapping", str(FIXTURES / "mapping.toml"), "--name", "coded",
                 "--min-support", "2", "--no-calibrate", "-o", str(out), "--report", str(report)])
    assert code == 0
    model = api.load(out)
    assert model.name == "coded" and {s.id for s in model.signals} == {"gaze_down", "smile", "nod", "tilt"}
    assert "3 sequences" in capsys.readouterr().err
    assert '"rules"' in report.read_text(encoding="utf-8")


def test_cli_bad_input_exits_1_with_file_and_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("s,face,1,oops,smile\n", encoding="utf-8")
    out = tmp_path / "never.xml"
    assert main(["learn", str(bad), "-o", str(out)]) == 1
    assert f"{bad}:1:1: E121" in capsys.readouterr().err
    assert not out.exists()
    assert main(["learn", str(FIXTURES / "corpus.csv"), "--confidence", "2"]) == 1


@pytest.mark.slow
def test_learned_set_samples_back_at_the_corpus_rates() -> None:
    """Learn → sample round trip (issue 32, bench/evaluation/learn_roundtrip.py): a random set
    whose learned rules include one that, in the default sampler, forces a signal the corpus
    shows in 11 % of its sequences (``exists(s10) or exists(s12)``: 0.39 before calibration
    released it); every signal's occurrence rate comes back within 0.1 of the corpus."""
    from bench.evaluation.learn_roundtrip import BACK_SEEDS, occurrence_rates
    from bench.generators.corpus import random_model

    truth = random_model(8, 18, random.Random(8).randint(9, 36), name="random8")
    corpus = list(sampling.iter_timelines(truth, 10.0, seed=8, count=300))
    result = learn_corpus_quietly(corpus)
    back = list(sampling.iter_timelines(result.model, 10.0, seed=8 + BACK_SEEDS, count=1000))
    before, after = occurrence_rates(corpus), occurrence_rates(back)
    off = {s: (before.get(s, 0.0), after.get(s, 0.0)) for s in set(before) | set(after)
           if abs(before.get(s, 0.0) - after.get(s, 0.0)) > 0.1}
    assert off == {}, (off, result.calibration)


def learn_corpus_quietly(corpus: list[Any]) -> LearnResult:
    from bench.evaluation.learn_roundtrip import LEARN_SEEDS, corpus_of
    from mse.learn import learn_corpus

    # The corpus was drawn with seeds 8..307: calibration samples with unrelated ones (the
    # same seeds would share the corpus' random draws, and its sampling noise).
    # The bench's row for random8 (bench/evaluation/learn_roundtrip.py), deep lint included.
    return learn_corpus(corpus_of(corpus), LearnOptions(name="random8", confidence=1.0, seed=8 + LEARN_SEEDS))
