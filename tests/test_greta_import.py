"""``mse import-greta``: operator mapping, safety, name repairs, and Greta's real data.

Small hand-written fixtures live in tests/fixtures/greta/; the real files are read in place
from ``$MSE_SHARED/greta`` (the ``greta_dir`` fixture skips when they are absent).
"""

from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api
from mse.cli import cmd_import_greta
from mse.diagnostics import Diagnostic, MseError
from mse.syntax.greta import (
    ImportedExpression,
    import_greta,
    import_greta_legacy,
    import_greta_report,
)

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "greta"
LEXICON = FIXTURES / "lexicon.xml"
CONSTRAINT = FIXTURES / "constraint.xml"

GRETA_EMOTIONS = {
    "anger", "anxiety", "embarrassment", "joy", "panic_fear",
    "pride", "regret", "rejoice", "relief", "tension",
}

#: Measured on the Greta data (isir/greta @ 48345c5): signals, constraints, warnings.
GRETA_COUNTS = {
    "anger": (11, 10, 0),
    "anxiety": (11, 6, 0),
    "embarrassment": (12, 19, 0),
    "joy": (19, 27, 0),
    "panic_fear": (12, 26, 0),
    "pride": (10, 9, 0),
    "regret": (24, 75, 4),
    "rejoice": (18, 51, 4),
    "relief": (14, 33, 0),
    "tension": (8, 3, 0),
    "test": (5, 6, 0),
}


def _by_name(expressions: list[ImportedExpression]) -> dict[str, ImportedExpression]:
    return {e.name: e for e in expressions}


def _constraints(xml: str) -> dict[str, str]:
    """Constraint id -> text, unescaped, read from the generated native XML."""
    found = re.findall(r'<constraint id="([^"]+)">([^<]*)</constraint>', xml)
    return {cid: text.replace("&gt;", ">").replace("&lt;", "<") for cid, text in found}


def _codes(diagnostics: tuple[Diagnostic, ...] | list[Diagnostic]) -> list[str]:
    return [d.code for d in diagnostics]


@pytest.fixture(scope="module")
def calm() -> ImportedExpression:
    return _by_name(import_greta(LEXICON, CONSTRAINT))["calm"]


# -- operator mapping ------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("label", "text"),
    [
        ("inc", "includes(s3, s1)"),  # included(A, B): A inside B -> includes(B, A)
        ("prec", "precedes(s2, s1)"),  # preceded(A, B): A after B -> precedes(B, A)
        ("rinc", "rightincludes(s1, s3)"),
        ("exc", "excludes(s3, s4)"),
        ("calm_label_1", "exists(s1) and (not exists(s4) or start(s1) > stop(s3))"),
        ("lt", "stop(s2) < start(s1)"),
        ("eq", "equal(start(s1), stop(s2), 0.3)"),  # Greta's own tolerance
        ("notype", "start(s1) > start(s2)"),
        ("self", "not exists(s3) or not exists(s1)"),
        ("missing_or", "exists(s4)"),
        ("eq_2", "exists(s3)"),
        ("lexicon_rule_1", "exists(s1) implies not exists(s4)"),
        ("excludelist_s2_s3", "excludes(s2, s3)"),
    ],
)
def test_operator_mapping(calm: ImportedExpression, label: str, text: str) -> None:
    assert _constraints(calm.xml)[label] == text


def test_constraint_ids_keep_greta_labels(calm: ImportedExpression) -> None:
    ids = list(_constraints(calm.xml))
    assert ids[:5] == ["inc", "prec", "rinc", "exc", "ex12"]
    assert "missing" not in ids  # names only an absent signal: never violated, left out
    assert len(ids) == len(set(ids)) == calm.constraint_count == 14


def test_signals_defaults_and_impossible_signal(calm: ImportedExpression) -> None:
    assert '<signal id="s3" modality="gaze" lexeme="gaze=look_down" min_duration="1.5" ' \
        'max_duration="2.5"/>' in calm.xml
    assert '<signal id="s4" modality="gesture" lexeme="gesture=wave"/>' in calm.xml  # defaults
    assert 'id="s5"' not in calm.xml  # max 0: it can never occur
    assert calm.signal_count == 4
    assert "Imported from Greta" in calm.xml and "lexicon.xml" in calm.xml


def test_warnings_have_greta_positions(calm: ImportedExpression) -> None:
    rendered = [d.render() for d in calm.diagnostics]
    assert all(re.match(r".+\.xml:\d+:\d+: W50[12] ", line) for line in rendered), rendered
    messages = " | ".join(rendered)
    assert "constraint.xml:25:5: W501 Greta label 'calm-label 1'" in messages
    assert "constraint.xml:63:5: W502 constraint 'self'" in messages
    assert "unknown_thing" in messages  # unresolved excludelist name
    assert "no start/stop type" in messages
    assert "lexicon.xml:10:4: W502 signal 5" in messages


def test_excludelist_pair_already_stated_is_not_repeated(calm: ImportedExpression) -> None:
    texts = list(_constraints(calm.xml).values())
    assert "excludes(s2, s1)" in texts  # from constraint.xml (ex12)
    assert not any(t in texts for t in ("excludes(s1, s2)",))


def test_name_mismatch_is_warned_never_silent() -> None:
    report = import_greta_report(LEXICON, CONSTRAINT)
    names = {e.name for e in report.expressions}
    assert names == {"calm", "happy", "lonely"}  # emotion-other has no type="mse"
    happy = _by_name(list(report.expressions))["happy"]
    assert _codes(happy.diagnostics) == ["W501"]
    assert "emotion-happyS" in happy.diagnostics[0].message
    assert _constraints(happy.xml) == {"happy_label_1": "exists(s1)"}
    loose = [d.message for d in report.diagnostics if "ghost" in d.message]
    assert loose and "skipped" in loose[0]
    lonely = _by_name(list(report.expressions))["lonely"]
    assert _codes(lonely.diagnostics) == ["W501", "W502"] and lonely.constraint_count == 0
    assert "element 'alternative' (values gaze=look_up)" in lonely.diagnostics[1].message


def test_outputs_compile() -> None:
    for expression in import_greta(LEXICON, CONSTRAINT):
        model = mse.api.loads(expression.xml, path=f"{expression.name}.xml")
        assert model.name == expression.name


def test_legacy_format() -> None:
    (calm,) = import_greta_legacy(FIXTURES / "legacy.xml")
    assert calm.name == "calm"
    assert _constraints(calm.xml) == {"calm_label_1": "precedes(s1, s2)"}
    assert sorted(_codes(calm.diagnostics)) == ["W501", "W502"]  # name 'calmS'; 'occurence'
    mse.api.loads(calm.xml, path="calm.xml")


# -- safety and errors -------------------------------------------------------------------------
def test_bom_and_dtd_reference_are_accepted() -> None:
    assert CONSTRAINT.read_bytes().startswith(b"\xef\xbb\xbf")
    assert b"<!DOCTYPE multimodals SYSTEM" in CONSTRAINT.read_bytes()
    assert import_greta(LEXICON, CONSTRAINT)  # the DTD (missing here) is never fetched


def test_entity_declarations_are_refused() -> None:
    with pytest.raises(MseError) as caught:
        import_greta(LEXICON, FIXTURES / "entity_bomb.xml")
    (diagnostic,) = caught.value.diagnostics
    assert diagnostic.code == "E103" and diagnostic.span.line == 3  # the first <!ENTITY


def _write(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "constraint.xml"
    path.write_text(f'<?xml version="1.0"?>\n<multimodals>\n{body}\n</multimodals>\n',
                    encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("body", "code"),
    [
        ('<multimodal emotion="calm"><con type="during"><arg id="1"/></con></multimodal>', "E102"),
        ('<multimodal emotion="calm"><con type="not"><arg id="1"/></con></multimodal>', "E102"),
        ('<multimodal emotion="calm"><con type="exists"><arg id="x"/></con></multimodal>', "E102"),
        ('<multimodal emotion="calm"><con type="excludes"><arg id="1"/></con></multimodal>',
         "E102"),
        ('<multimodal emotion="calm"><con type="exists"><arg id="1"/></multimodal>', "E101"),
    ],
)
def test_bad_constraints_raise_with_position(tmp_path: Path, body: str, code: str) -> None:
    with pytest.raises(MseError) as caught:
        import_greta(LEXICON, _write(tmp_path, body))
    assert _codes(caught.value.diagnostics) == [code]
    assert caught.value.diagnostics[0].span.line >= 2


@pytest.mark.parametrize(
    ("attributes", "code"),
    [('id="a"', "E210"), ('id="1" probability_start="1.5"', "E206"),
     ('id="1" min="3" max="2"', "E205"), ('id="1" max="nan"', "E112"),
     ('id="1" repetitivity="2"', "E207"), ('id="1" modality="bad modality"', "E210")],
)
def test_bad_signals_raise(tmp_path: Path, attributes: str, code: str) -> None:
    lexicon = tmp_path / "lexicon.xml"
    modality = "" if "modality" in attributes else ' modality="face"'
    lexicon.write_text(
        '<behaviorsets><behaviorset name="emotion-calm" type="mse"><signals>'
        f'<signal {attributes} name="faceexp=smile"{modality}/>'
        "</signals><constraints/></behaviorset></behaviorsets>", encoding="utf-8")
    with pytest.raises(MseError) as caught:
        import_greta(lexicon, _write(tmp_path, ""))
    assert code in _codes(caught.value.diagnostics)


def test_deep_nesting_is_an_error_not_a_crash(tmp_path: Path) -> None:
    body = '<con type="not"><arg>' * 120 + '<con type="exists"><arg id="1"/></con>' + \
        "</arg></con>" * 120
    with pytest.raises(MseError) as caught:
        import_greta(LEXICON, _write(tmp_path, f'<multimodal emotion="calm">{body}</multimodal>'))
    assert {"E111", "E101"} & set(_codes(caught.value.diagnostics))


# -- the command -------------------------------------------------------------------------------
def _run(*argv: str) -> int:
    parser = argparse.ArgumentParser(prog="mse")
    cmd_import_greta.register(parser.add_subparsers())
    args = parser.parse_args(["import-greta", *argv])
    return int(args.handler(args))


def test_cli_writes_one_file_per_emotion(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(str(LEXICON), str(CONSTRAINT), "-o", str(tmp_path / "out")) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "calm.xml", "happy.xml", "lonely.xml"]
    err = capsys.readouterr().err
    assert re.search(r"lexicon\.xml:\d+:\d+: W501 behaviour set 'emotion-happyS'", err)
    for written in (tmp_path / "out").iterdir():
        assert mse.api.load(written).name == written.stem


def test_cli_errors_exit_1_and_write_nothing(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert _run(str(LEXICON), str(FIXTURES / "entity_bomb.xml"), "-o", str(out)) == 1
    assert not out.exists()
    assert "E103" in capsys.readouterr().err


def test_cli_usage_errors(tmp_path: Path) -> None:
    assert _run(str(LEXICON), "-o", str(tmp_path)) == 2
    assert _run(str(LEXICON), str(CONSTRAINT), "--legacy", "x.xml", "-o", str(tmp_path)) == 2


def test_cli_legacy(tmp_path: Path) -> None:
    assert _run("--legacy", str(FIXTURES / "legacy.xml"), "-o", str(tmp_path)) == 0
    assert (tmp_path / "calm.xml").is_file()


# -- Greta's real data ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def greta_import(greta_dir: Path) -> list[ImportedExpression]:
    return import_greta(greta_dir / "lexicon.xml", greta_dir / "constraint.xml")


def test_all_ten_greta_emotions_import(greta_import: list[ImportedExpression]) -> None:
    names = {e.name for e in greta_import}
    assert names >= GRETA_EMOTIONS
    assert names - GRETA_EMOTIONS == {"test"}  # Greta's own test set imports too


def test_greta_counts(greta_import: list[ImportedExpression]) -> None:
    measured = {e.name: (e.signal_count, e.constraint_count, len(e.diagnostics))
                for e in greta_import}
    assert measured == GRETA_COUNTS


def test_every_greta_emotion_compiles(greta_import: list[ImportedExpression]) -> None:
    for expression in greta_import:
        model = mse.api.loads(expression.xml, path=f"{expression.name}.xml")
        assert len(model.signals) == expression.signal_count
        assert len(model.constraints) == expression.constraint_count


def test_greta_rejoice_mismatch_and_embarrassment_mapping(
    greta_import: list[ImportedExpression],
) -> None:
    emotions = _by_name(greta_import)
    rejoice = [d for d in emotions["rejoice"].diagnostics if d.code == "W501"]
    assert len(rejoice) == 1 and "emotion-rejoiceS" in rejoice[0].message
    embarrassment = _constraints(emotions["embarrassment"].xml)
    assert embarrassment["embarrassment_label_2"] == "equal(start(s11), start(s1), 0.3)"
    assert embarrassment["embarrassment_label_13"] == "precedes(s10, s2)"  # preceded(2, 10)
    assert embarrassment["embarrassment_label_5"] == "includes(s10, s6) or includes(s12, s6)"


def test_greta_legacy_example_imports_and_compiles(greta_dir: Path) -> None:
    expressions = import_greta_legacy(greta_dir / "example.xml")
    assert {e.name for e in expressions} >= GRETA_EMOTIONS
    for expression in expressions:
        mse.api.loads(expression.xml, path=f"{expression.name}.xml")


# -- robustness ----------------------------------------------------------------------------------
_MUTATION_TOKENS = ('"', "<", ">", "/", "=", " ", "&", "x", "9", "-1", "nan", "con", "arg",
                    'type="not"', 'id="99"', "</con>", "<arg>", "\ufeff")


@settings(max_examples=int(os.environ.get("GRETA_FUZZ", "80")), deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_mutated_greta_files_never_crash(tmp_path_factory: pytest.TempPathFactory,
                                         data: st.DataObject) -> None:
    """Random edits of the fixtures give warnings or MseError, never another exception."""
    which = data.draw(st.sampled_from([LEXICON, CONSTRAINT, FIXTURES / "legacy.xml"]))
    text = which.read_bytes().decode("utf-8")
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(0, len(text)))
        cut = data.draw(st.integers(0, 12))
        text = text[:at] + data.draw(st.sampled_from(_MUTATION_TOKENS)) + text[at + cut:]
    folder = tmp_path_factory.mktemp("mutated")
    mutated = folder / which.name
    mutated.write_bytes(text.encode("utf-8"))
    lexicon = mutated if which == LEXICON else LEXICON
    constraint = mutated if which == CONSTRAINT else CONSTRAINT
    try:
        legacy = which.name == "legacy.xml"
        expressions = import_greta_legacy(mutated) if legacy else import_greta(lexicon, constraint)
    except MseError as error:
        assert error.diagnostics and all(d.is_error for d in error.diagnostics)
        return
    for expression in expressions:  # and what is written always compiles
        mse.api.loads(expression.xml, path="mutated.xml")


def test_cli_on_greta_data(greta_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "greta"
    assert _run(str(greta_dir / "lexicon.xml"), str(greta_dir / "constraint.xml"), "-o", str(out)) == 0
    written = {p.stem: p for p in out.glob("*.xml")}
    assert set(written) >= GRETA_EMOTIONS
    for name, path in written.items():
        model = mse.api.load(path)
        assert (len(model.signals), len(model.constraints)) == GRETA_COUNTS[name][:2]
