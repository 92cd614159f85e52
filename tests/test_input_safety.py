"""Hostile input fails fast with a diagnostic: entity bombs, external entities, huge
files, deeply nested or very long expressions."""

from __future__ import annotations

import resource
import time
from pathlib import Path

import pytest

from mse.api import compile_source, loads
from mse.diagnostics import MseError
from mse.syntax.reader import MAX_FILE_BYTES

FIXTURES = Path(__file__).parent / "fixtures" / "invalid"


def _wrap(constraint: str) -> bytes:
    return (
        '<expression name="x"><signals><signal id="a" modality="face"/>'
        f'<signal id="b" modality="face"/></signals><constraints><constraint id="k">{constraint}'
        "</constraint></constraints></expression>"
    ).encode()


def test_entity_bomb_is_refused_quickly_with_flat_memory() -> None:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    began = time.perf_counter()
    model, diagnostics = compile_source(FIXTURES / "entities.xml")
    assert model is None and [d.code for d in diagnostics] == ["E103"]
    assert time.perf_counter() - began < 1.0
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 50_000  # KiB


def test_external_entities_are_never_read() -> None:
    model, diagnostics = compile_source(FIXTURES / "external_entity.xml")
    assert model is None and diagnostics[0].code == "E103"
    assert "root:" not in diagnostics[0].message


def test_doctype_without_entities_is_ignored_not_fetched() -> None:
    data = (
        b'<?xml version="1.0"?><!DOCTYPE expression SYSTEM "http://example.invalid/x.dtd">'
        b'<expression name="x"><signals><signal id="a" modality="face"/></signals></expression>'
    )
    model, diagnostics = compile_source("x.xml", data)
    assert model is not None, diagnostics


def test_files_over_10_mb_are_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.xml"
    big.write_bytes(b"<expression>" + b" " * MAX_FILE_BYTES + b"</expression>")
    model, diagnostics = compile_source(big)
    assert model is None and [d.code for d in diagnostics] == ["E104"]


@pytest.mark.parametrize("text", ["not " * 5000 + "exists(a)", "(" * 5000 + "exists(a)" + ")" * 5000])
def test_deep_nesting_is_an_error_not_a_recursion_error(text: str) -> None:
    model, diagnostics = compile_source("deep.xml", _wrap(text))
    assert model is None and [d.code for d in diagnostics] == ["E111"]


def test_long_flat_chains_are_fine() -> None:
    text = " and ".join(["exists(a)", "includes(a, b)"] * 2000)
    model = loads(_wrap(text))
    assert len(model.constraints[0].expr.operands) == 4000  # type: ignore[union-attr]


def test_missing_file_and_directory_give_diagnostics(tmp_path: Path) -> None:
    for path in (tmp_path / "missing.xml", tmp_path):
        model, diagnostics = compile_source(path)
        assert model is None and diagnostics[0].code == "E100"


def test_load_unknown_name_suggests_bundled() -> None:
    with pytest.raises(MseError) as error:
        from mse.api import load

        load("embarassment")
    assert "E100" in str(error.value)


def test_bom_and_latin1_declaration() -> None:
    data = (
        "\ufeff<?xml version='1.0' encoding='UTF-8'?>"
        "<expression name='x'><signals><signal id='a' modality='face'/></signals></expression>"
    )
    model, _ = compile_source("bom.xml", data.encode("utf-8"))
    assert model is not None
