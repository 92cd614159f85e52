"""Hostile behaviour-set input fails fast with a located diagnostic (issue 13, items 1, 3-8):
entity bombs and bypasses, regex blow-ups, long and deep expressions, constraint text cut
short, numbers out of range or outside the schema's syntax, and a trusted model cache."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mse.api import compile_source, load, loads
from mse.cli import main
from mse.diagnostics import MseError
from mse.limits import MAX_CONSTRAINT_CHARS, MAX_SIGNALS
from mse.sampling import sample
from mse.syntax.reader import MAX_FILE_BYTES

FIXTURES = Path(__file__).parent / "fixtures" / "invalid"
REPO = Path(__file__).resolve().parent.parent


def _wrap(constraint: str, signals: str = "") -> bytes:
    return (
        '<expression name="x"><signals><signal id="a" modality="face" max_duration="3"/>'
        f'<signal id="b" modality="face" max_duration="3"/>{signals}</signals><constraints>'
        f'<constraint id="k">{constraint}</constraint></constraints></expression>'
    ).encode()


def _signal(**attributes: str) -> bytes:
    text = " ".join(f'{key}="{value}"' for key, value in attributes.items())
    return (
        f'<expression name="x"><signals><signal id="a" modality="face" {text}/></signals></expression>'
    ).encode()


def _codes(data: bytes) -> list[str]:
    _, diagnostics = compile_source("x.xml", data)
    return [d.code for d in diagnostics if d.is_error]


def _run(*argv: str, stdin: bytes | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess[bytes]:
    """The console script in a fresh process (stderr must never hold a traceback)."""
    done = subprocess.run(
        [sys.executable, "-m", "mse", *argv], input=stdin, capture_output=True, timeout=120, cwd=cwd, check=False
    )
    assert b"Traceback" not in done.stderr, done.stderr.decode(errors="replace")
    return done


# -- entities (items 4, 8) -------------------------------------------------------------------
def test_entity_bomb_is_refused_quickly_with_flat_memory() -> None:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    began = time.perf_counter()
    model, diagnostics = compile_source(FIXTURES / "entities.xml")
    assert model is None and [d.code for d in diagnostics] == ["E103"]
    assert time.perf_counter() - began < 1.0
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 50_000  # KiB


def test_billion_laughs_in_an_attribute_is_refused() -> None:
    levels = "".join(f'<!ENTITY e{i} "' + f"&e{i - 1};" * 10 + '">' for i in range(1, 12))
    data = f'<!DOCTYPE x [<!ENTITY e0 "aaaaaaaaaa">{levels}]><expression name="&e11;"/>'.encode()
    assert _codes(data) == ["E103"]


def test_external_entities_are_never_read() -> None:
    model, diagnostics = compile_source(FIXTURES / "external_entity.xml")
    assert model is None and diagnostics[0].code == "E103"
    assert "root:" not in diagnostics[0].message


@pytest.mark.parametrize("use", ['name="&i;"', 'name="x">&i;<signals/'])
def test_entity_declared_behind_a_comment_is_refused(use: str) -> None:
    """Item 8: the decision is taken on the parsed DOCTYPE, not on a regular expression."""
    data = (
        '<!DOCTYPE expression [<!-- ] --><!ENTITY i "x">]>'
        f'<expression {use}><signals><signal id="a" modality="face"/></signals></expression>'
    ).encode()
    model, diagnostics = compile_source("x.xml", data)
    assert model is None and [d.code for d in diagnostics] == ["E103"]
    assert diagnostics[0].span.col > 1  # at the <!ENTITY, not at the start of the file


def test_parameter_entities_and_undeclared_references_are_refused() -> None:
    parameter = b'<!DOCTYPE x [<!ENTITY % p "<!ENTITY i \'x\'>"> %p; ]><expression name="x"/>'
    assert _codes(parameter) == ["E103"]
    undeclared = b'<!DOCTYPE x SYSTEM "x.dtd"><expression name="&foo;"><signals/></expression>'
    assert _codes(undeclared) == ["E103"]


def test_doctype_without_entities_is_ignored_not_fetched() -> None:
    data = (
        b'<?xml version="1.0"?><!DOCTYPE expression SYSTEM "http://example.invalid/x.dtd">'
        b'<expression name="x"><signals><signal id="a" modality="face"/></signals></expression>'
    )
    model, diagnostics = compile_source("x.xml", data)
    assert model is not None, diagnostics


@pytest.mark.parametrize(
    "data",
    [
        b"<!DOCTYPE x " + b"[a]" * 28,  # 25 s before the fix
        b"<!DOCTYPE x " + b"[a]" * 100_000,
        b"<!--" * 80_000,  # 19 s
        b"<!--" * 320_000,  # > 120 s
        b"<?" * 160_000,
        b"<![CDATA[" * 40_000,
        b'<expression name="x">' + b"<!--" * 200_000,
        b'<expression name="x"><signals><signal id="a" ' + b'b="x" ' * 200_000 + b"/></signals></expression>",
    ],
    ids=["doctype-28", "doctype-100k", "comments-80k", "comments-320k", "pi", "cdata", "inner-comments", "attrs"],
)
def test_no_regular_expression_blows_up(data: bytes) -> None:
    """Item 4: every scan of the raw text is linear (a hang would time the test out)."""
    began = time.perf_counter()
    model, diagnostics = compile_source("x.xml", data)
    assert model is None and diagnostics
    assert time.perf_counter() - began < 10  # seconds, generous: the bug took minutes


def test_regex_blow_up_on_stdin_is_fast() -> None:
    began = time.perf_counter()
    done = _run("sample", "-", stdin=b"<!--" * 80_000)
    assert done.returncode == 1 and b"E101" in done.stderr
    assert time.perf_counter() - began < 60


def test_files_over_10_mb_are_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.xml"
    big.write_bytes(b"<expression>" + b" " * MAX_FILE_BYTES + b"</expression>")
    model, diagnostics = compile_source(big)
    assert model is None and [d.code for d in diagnostics] == ["E104"]


# -- expressions (items 3, 5) ------------------------------------------------------------------
@pytest.mark.parametrize("text", ["not " * 5000 + "exists(a)", "(" * 5000 + "exists(a)" + ")" * 5000])
def test_deep_nesting_is_an_error_not_a_recursion_error(text: str) -> None:
    model, diagnostics = compile_source("deep.xml", _wrap(text))
    assert model is None and [d.code for d in diagnostics] == ["E111"]


def test_long_flat_chains_are_fine() -> None:
    text = " and ".join(["exists(a)", "includes(a, b)"] * 2000)
    model = loads(_wrap(text))
    assert len(model.constraints[0].expr.operands) == 4000  # type: ignore[union-attr]


@pytest.mark.slow
def test_long_chains_use_memory_linear_in_their_length() -> None:
    """Item 5: 10,000 `exists(a)` joined by `and` took 523 MB, 20,000 took 2 GB."""
    script = (
        "import resource\n"
        "from mse.api import compile_source\n"
        "from mse.syntax.expression import _parser\n"
        "_parser()\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "for op in ('and', 'or'):\n"
        "    text = (' ' + op + ' ').join(['exists(a)'] * 7000)\n"
        "    data = ('<expression name=\"x\"><signals><signal id=\"a\" modality=\"face\"/></signals>'\n"
        "            '<constraints><constraint>' + text + '</constraint></constraints></expression>').encode()\n"
        "    model, diagnostics = compile_source('x.xml', data)\n"
        "    assert model is not None and len(model.constraints[0].expr.operands) == 7000, diagnostics\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=120)
    assert int(done.stdout) < 150_000, done.stdout  # KiB


def test_over_long_constraints_are_refused() -> None:
    text = " and ".join(["exists(a)"] * 100_000)
    began = time.perf_counter()
    model, diagnostics = compile_source("x.xml", _wrap(text))
    assert model is None and [d.code for d in diagnostics] == ["E104"]
    assert str(MAX_CONSTRAINT_CHARS) in diagnostics[0].message
    assert time.perf_counter() - began < 10


@pytest.mark.parametrize(
    "inner",
    ["exists(b) <?x?> and exists(a)", "exists(b) <!-- x --> and exists(a)", "exists(b) <![CDATA[and]]> exists(a)"],
    ids=["pi", "comment", "cdata"],
)
def test_constraint_text_is_the_parsed_character_data(inner: str) -> None:
    """Item 3: a processing instruction or comment inside a constraint cut it short."""
    model = loads(_wrap(inner))
    assert model.constraints[0].text == "exists(b) and exists(a)"
    assert len(model.constraints[0].expr.operands) == 2  # type: ignore[union-attr]


def test_constraint_with_a_comment_in_a_utf16_file() -> None:
    document = (
        '<?xml version="1.0" encoding="UTF-16"?>\n'
        '<expression name="x"><signals><signal id="a" modality="face"/>\n'
        '<signal id="b" modality="face"/></signals><constraints>\n'
        "<constraint>exists(b) <!-- why --> and\n  exists(a) and nope(a)</constraint></constraints></expression>"
    )
    model, diagnostics = compile_source("x.xml", document.encode("utf-16"))
    assert model is None and [d.code for d in diagnostics] == ["E110"]
    assert (diagnostics[0].span.line, diagnostics[0].span.col) == (5, 17)  # at 'nope', positions kept
    fixed = document.replace(" and nope(a)", "")
    model, diagnostics = compile_source("x.xml", fixed.encode("utf-16"))
    assert model is not None and model.constraints[0].text == "exists(b) and exists(a)", diagnostics


def test_sampled_timelines_respect_the_whole_constraint() -> None:
    model = loads(_wrap("exists(b) <?x?> and not exists(a)"))
    for seed in range(5):
        timeline = sample(model, 6.0, seed=seed)
        ids = {s.id for s in timeline.signals}  # type: ignore[union-attr]
        assert "b" in ids and "a" not in ids


@pytest.mark.parametrize(("raw", "code"), [(b"1\r5", "E110"), (b"1\r\n5", "E110"), (b"1&#13;5", "E110")])
def test_a_carriage_return_separates_tokens(raw: bytes, code: str) -> None:
    """Item 12: a bare CR in a constraint was dropped, so `1<CR>5` compiled as `15`."""
    data = _wrap("start(a) &lt; " + raw.decode())
    assert _codes(data) == [code]


# -- numbers (item 7) ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("data", "code"),
    [
        (_signal(max_duration="1e306"), "E215"),
        (_signal(min_duration="1e308"), "E215"),
        (_signal(max_duration="1e20"), "E215"),
        (_signal(max_duration="1000001"), "E215"),
        (_wrap("start(a) &lt; 1e306"), "E215"),
        (_wrap("equal(start(a), 1, 1e306)"), "E215"),
        (_wrap("start(a) + 900000 + 900000 &lt; 3"), "E215"),
        (_wrap("start(a) &lt; 1e400"), "E112"),
        (_signal(max_duration="1_0"), "E204"),
        (_signal(max_duration="\u0661"), "E204"),  # ARABIC-INDIC DIGIT ONE
        (_signal(max_duration="infinity"), "E204"),
        (_signal(max_duration="0x10"), "E204"),
        (_signal(max_duration="1\u2003"), "E204"),  # a Unicode space is not XML whitespace
        (_signal(max_occurrences="1" + "0" * 5000, repetitivity="1"), "E204"),
        (_signal(max_occurrences="\u0661", repetitivity="1"), "E204"),
        (_wrap("start(a) &lt; \u0661"), "E110"),
    ],
)
def test_numbers_outside_the_schema_or_the_range_are_errors(data: bytes, code: str) -> None:
    assert _codes(data) == [code]


@pytest.mark.parametrize("value", ["3", " 2.5 ", "+1.", ".5", "1E2", "1e-3", "0010"])
def test_xsd_numbers_are_accepted(value: str) -> None:
    assert _codes(_signal(max_duration=value)) == []


def test_out_of_range_numbers_exit_1_everywhere(tmp_path: Path) -> None:
    source = tmp_path / "big.xml"
    source.write_bytes(_wrap("start(a) &lt; 1e306"))
    for argv in (["compile", str(source)], ["sample", str(source)], ["lint", str(source)]):
        assert main(argv) == 1, argv
    source.write_bytes(_signal(max_duration="1e20"))
    assert main(["sample", str(source), "--solver", "cpsat"]) == 1
    assert main(["lint", str(source)]) == 1


def test_a_timeline_far_outside_the_range_is_an_e212(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    timeline = tmp_path / "t.json"
    entry = {"id": "smile", "modality": "face", "lexeme": "smile", "start": 1e308, "stop": 1e308}
    timeline.write_text(json.dumps({"format": "mse-timeline/1", "duration": 10, "signals": [entry]}))
    assert main(["check", str(REPO / "tests/fixtures/valid/minimal.xml"), str(timeline)]) == 1
    assert "E212" in capsys.readouterr().err


# -- the parser and the compiled-model cache (items 1, 6) -----------------------------------------
def test_the_grammar_is_never_cached_in_the_temporary_folder(tmp_path: Path) -> None:
    """Item 1: lark's cache=True unpickled a file from $TMPDIR (anyone can write /tmp)."""
    from mse.syntax.expression import _parser

    assert not _parser().options.cache
    planted = tmp_path / "tmp"
    planted.mkdir()
    env = {**os.environ, "TMPDIR": str(planted), "MSE_CACHE_DIR": str(tmp_path / "cache")}
    subprocess.run(
        [sys.executable, "-m", "mse", "compile", str(REPO / "behaviour_sets" / "relief.xml")],
        env=env, capture_output=True, check=True, timeout=120,
    )  # fmt: skip
    assert list(planted.iterdir()) == []  # nothing written there, so nothing is ever read back


def _cache_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    cache = tmp_path / "cache"
    monkeypatch.setenv("MSE_CACHE_DIR", str(cache))
    return cache / "models"


def test_a_tampered_cache_entry_is_a_miss(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Item 6: one flipped digit of max_duration made `mse sample` break the set."""
    entries = _cache_env(tmp_path, monkeypatch)
    source = tmp_path / "x.xml"
    source.write_bytes(_signal(max_duration="2.5"))
    fresh = load(source)
    assert load(source, cache=True) == fresh
    (entry,) = entries.glob("*.json")
    text = entry.read_text()
    assert '\\"max_duration\\": 2.5' in text
    entry.write_text(text.replace('\\"max_duration\\": 2.5', '\\"max_duration\\": 9.5'))
    assert load(source, cache=True) == fresh
    for damage in ("[" * 50_000, "{}", json.dumps({"model": "x"}), "\udcff" * 3):
        entry.write_text(damage, errors="surrogateescape")
        assert load(source, cache=True) == fresh


def test_a_cache_entry_forged_with_a_right_checksum_but_another_source_is_a_miss(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    entries = _cache_env(tmp_path, monkeypatch)
    source = tmp_path / "x.xml"
    source.write_bytes(_signal(max_duration="2.5"))
    load(source, cache=True)
    (entry,) = entries.glob("*.json")
    envelope = json.loads(entry.read_text())
    envelope["source_sha256"] = "0" * 64
    entry.write_text(json.dumps(envelope))
    assert load(source, cache=True) == load(source)


def test_a_cache_folder_others_can_write_is_not_used(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    entries = _cache_env(tmp_path, monkeypatch)
    entries.mkdir(parents=True)
    entries.chmod(0o777)
    source = tmp_path / "x.xml"
    source.write_bytes(_signal(max_duration="2.5"))
    assert load(source, cache=True) == load(source)
    assert list(entries.iterdir()) == []


@pytest.mark.slow
def test_concurrent_processes_share_one_cache(tmp_path: Path) -> None:
    env = {**os.environ, "MSE_CACHE_DIR": str(tmp_path / "cache")}
    command = [sys.executable, "-m", "mse", "sample", "relief", "--seed", "3", "--format", "json"]
    runs = [subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in range(6)]
    outputs = [run.communicate(timeout=120) for run in runs]
    assert all(run.returncode == 0 for run in runs), [err for _, err in outputs]
    assert len({out for out, _ in outputs}) == 1
    assert not list((tmp_path / "cache").rglob("*.tmp"))


def test_load_unknown_name_suggests_bundled() -> None:
    with pytest.raises(MseError) as error:
        load("embarassment")
    assert "E100" in str(error.value)


def test_bom_and_latin1_declaration() -> None:
    data = (
        "\ufeff<?xml version='1.0' encoding='UTF-8'?>"
        "<expression name='x'><signals><signal id='a' modality='face'/></signals></expression>"
    )
    model, _ = compile_source("bom.xml", data.encode("utf-8"))
    assert model is not None
    latin = "<?xml version='1.0' encoding='ISO-8859-1'?><expression name='x'><signals>" + (
        "<signal id='a' modality='face' lexeme='caf\u00e9'/></signals></expression>"
    )
    model, diagnostics = compile_source("latin.xml", latin.encode("latin-1"))
    assert model is not None and model.signals[0].lexeme == "caf\u00e9", diagnostics


def test_missing_file_and_directory_give_diagnostics(tmp_path: Path) -> None:
    for path in (tmp_path / "missing.xml", tmp_path):
        model, diagnostics = compile_source(path)
        assert model is None and diagnostics[0].code == "E100"


def test_documents_with_too_many_elements_or_signals_are_refused_fast() -> None:
    signal = '<signal id="s{}" modality="face" max_duration="3"/>'
    many = "".join(signal.format(i) for i in range(MAX_SIGNALS + 1))
    began = time.perf_counter()
    assert _codes(f'<expression name="x"><signals>{many}</signals></expression>'.encode()) == ["E104"]
    noise = "<x/>" * 1_000_000
    assert _codes(f'<expression name="x">{noise}</expression>'.encode()) == ["E104"]
    assert time.perf_counter() - began < 20
