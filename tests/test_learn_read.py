"""Reading corpora for ``mse learn``: ELAN 2.7/2.8/3.0 (checked against pympi-ling, an
independent reader), CSV/TSV and timelines; bad input gets an E-code at file:line."""

from __future__ import annotations

from pathlib import Path

import pytest

from mse.diagnostics import MseError
from mse.learn.corpus import TierMapping
from mse.learn.read import read_corpus
from mse.learn.read_eaf import read_eaf
from mse.learn.read_table import read_table

FIXTURES = Path(__file__).parent / "fixtures" / "learn"
VERSIONS = ("v27", "v28", "v30")


@pytest.mark.parametrize("version", VERSIONS)
def test_eaf_reader_agrees_with_pympi(version: str) -> None:
    pympi = pytest.importorskip("pympi")
    path = FIXTURES / f"session_{version}.eaf"
    sequence, diagnostics = read_eaf(path)
    assert sequence is not None
    assert not [d for d in diagnostics if d.is_error]
    ours = sorted((a.tier, a.start, a.stop, a.label) for a in sequence.annotations)
    eaf = pympi.Elan.Eaf(str(path))
    theirs = sorted(
        (tier, entry[0], entry[1], entry[2])
        for tier in eaf.get_tier_names()
        for entry in eaf.get_annotation_data_for_tier(tier)
        if entry[0] is not None and entry[1] is not None  # unaligned slots: we leave them out too
    )
    assert ours == theirs


def test_unaligned_slot_is_left_out_with_a_note() -> None:
    sequence, diagnostics = read_eaf(FIXTURES / "session_v28.eaf")
    assert sequence is not None
    notes = [d for d in diagnostics if d.code == "W503"]
    assert notes and notes[0].span.line > 0 and "unaligned" in notes[0].message


def test_tiers_and_labels_are_mapped() -> None:
    files = sorted(FIXTURES.glob("session_*.eaf"))
    mapping = TierMapping({"Gaze": "gaze", "Face": "face", "Head": "head"}, {"look down": "gaze_down"},
                          only_listed=True)
    corpus, _ = read_corpus(files, mapping)
    assert set(corpus.signals) == {"gaze_down", "smile", "nod", "tilt"}
    assert corpus.signals["gaze_down"].modality == "gaze"
    assert corpus.signals["gaze_down"].lexeme == "look down"
    assert len(corpus.sequences) == 3
    first = corpus.sequences[0]
    assert first.occurrences["smile"] == ((1700, 4200), (5000, 6100))
    assert first.duration == 6100  # no mse:duration: the last stop


def test_unlisted_tiers_become_modalities_named_after_them() -> None:
    corpus, _ = read_corpus([FIXTURES / "session_v27.eaf"])
    assert corpus.signals["look_down"].modality == "gaze"
    assert corpus.signals["clip_1_coder_A"].modality == "comments"


def test_csv_and_tsv(tmp_path: Path) -> None:
    corpus, _ = read_corpus([FIXTURES / "corpus.csv"])
    assert [s.name for s in corpus.sequences] == ["clip1", "clip2"]
    assert corpus.sequences[1].occurrences["nod"] == ((1250, 2000),)
    tsv = tmp_path / "c.tsv"
    tsv.write_text("s1\tface\t0.5\t1.5\tsmile\ns1\thead\t0\t2\tnod\n", encoding="utf-8")
    corpus, _ = read_corpus([tsv])
    assert corpus.sequences[0].occurrences == {"smile": ((500, 1500),), "nod": ((0, 2000),)}


def test_overlapping_annotations_of_one_signal_are_merged(tmp_path: Path) -> None:
    table = tmp_path / "c.csv"
    table.write_text("s,face,0,2,smile\ns,face,1,3,smile\n", encoding="utf-8")
    corpus, notes = read_corpus([table])
    assert corpus.sequences[0].occurrences["smile"] == ((0, 3000),)
    assert any(n.code == "W503" and n.span.line == 2 for n in notes)


@pytest.mark.parametrize(
    ("text", "line", "code"),
    [
        ("sequence,tier,start,stop,label\ns,face,1,x,smile\n", 2, "E121"),
        ("s,face,2,1,smile\n", 1, "E121"),
        ("s,face,1,2,smile\ns,face,1\n", 2, "E121"),
        ("sequence,tier,start,stop,label,duration\ns,face,1,4,smile,3\n", 2, "E121"),
    ],
)
def test_bad_rows_are_reported_at_their_line(tmp_path: Path, text: str, line: int, code: str) -> None:
    table = tmp_path / "bad.csv"
    table.write_text(text, encoding="utf-8")
    with pytest.raises(MseError) as caught:
        read_corpus([table])
    diagnostic = caught.value.diagnostics[0]
    assert (diagnostic.code, diagnostic.span.path, diagnostic.span.line) == (code, str(table), line)


@pytest.mark.parametrize(
    ("edit", "code", "line"),
    [
        (lambda t: t.replace('TIME_SLOT_REF2="ts4"', 'TIME_SLOT_REF2="ts9"'), "E120", 23),
        (lambda t: t.replace("</TIER>", "</TIR>", 1), "E101", 20),
        (lambda t: t.replace('TIME_VALUE="4800"', 'TIME_VALUE="4.8s"'), "E120", 12),
        (lambda t: t.replace("ANNOTATION_DOCUMENT", "DOCUMENT"), "E120", 2),
    ],
)
def test_bad_eaf_files_get_an_error_with_file_and_line(tmp_path: Path, edit: object, code: str, line: int) -> None:
    text = (FIXTURES / "session_v30.eaf").read_text(encoding="utf-8")
    bad = tmp_path / "bad.eaf"
    bad.write_text(edit(text), encoding="utf-8")  # type: ignore[operator]
    with pytest.raises(MseError) as caught:
        read_corpus([bad])
    diagnostic = caught.value.diagnostics[0]
    assert diagnostic.code == code
    assert diagnostic.span.path == str(bad)
    assert diagnostic.span.line == line


def test_entity_declarations_are_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bomb.eaf"
    bad.write_text('<?xml version="1.0"?>\n<!DOCTYPE a [<!ENTITY x "xx">]>\n<ANNOTATION_DOCUMENT/>\n',
                   encoding="utf-8")
    with pytest.raises(MseError) as caught:
        read_corpus([bad])
    assert caught.value.diagnostics[0].code == "E103"


def test_timelines_are_a_corpus(tmp_path: Path) -> None:
    import mse.api as api
    import mse.sampling as sampling
    from mse.timeline import dumps_jsonl

    model = api.load("relief")
    timelines = sampling.iter_timelines(model, 6.0, seed=3, count=4)
    path = tmp_path / "t.jsonl"
    path.write_text(dumps_jsonl(timelines), encoding="utf-8")
    corpus, _ = read_corpus([path])
    assert len(corpus.sequences) == 4 and corpus.typical_duration == 6000
    for signal_id, info in corpus.signals.items():
        assert info.modality == model.signal(signal_id).modality
        assert info.lexeme == model.signal(signal_id).lexeme


def test_unknown_suffix_and_empty_input(tmp_path: Path) -> None:
    other = tmp_path / "notes.txt"
    other.write_text("x", encoding="utf-8")
    with pytest.raises(MseError) as caught:
        read_corpus([other])
    assert caught.value.diagnostics[0].code == "E100"
    empty = tmp_path / "empty.csv"
    empty.write_text("sequence,tier,start,stop,label\n", encoding="utf-8")
    with pytest.raises(MseError) as caught:
        read_corpus([empty])
    assert caught.value.diagnostics[-1].code == "E121"


def test_table_reader_directly() -> None:
    sequences, problems = read_table(FIXTURES / "corpus.csv")
    assert not problems and [len(s.annotations) for s in sequences] == [2, 3]
