"""Golden fixtures: each file under fixtures/valid compiles to the IR in its .json twin;
each file under fixtures/invalid gives exactly the diagnostics in its .expected twin.
Regenerate after an intended change with MSE_UPDATE_GOLDEN=1 and review the diff."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from mse.api import compile_source
from mse.ir.canonical import model_to_json

FIXTURES = Path(__file__).parent / "fixtures"
UPDATE = os.environ.get("MSE_UPDATE_GOLDEN") == "1"


def _relative_compile(path: Path) -> tuple[object, list[str]]:
    relative = path.relative_to(FIXTURES).as_posix()
    model, diagnostics = compile_source(relative, path.read_bytes())
    return model, [d.render() for d in diagnostics]


@pytest.mark.parametrize("path", sorted((FIXTURES / "invalid").glob("*.xml")), ids=lambda p: p.stem)
def test_invalid_fixture_diagnostics(path: Path) -> None:
    model, rendered = _relative_compile(path)
    assert model is None
    expected_file = path.with_suffix(".expected")
    text = "\n".join(rendered) + "\n"
    if UPDATE:
        expected_file.write_text(text, encoding="utf-8")
    assert text == expected_file.read_text(encoding="utf-8")


@pytest.mark.parametrize("path", sorted((FIXTURES / "valid").glob("*.xml")), ids=lambda p: p.stem)
def test_valid_fixture_ir(path: Path) -> None:
    model, rendered = _relative_compile(path)
    assert model is not None, rendered
    expected_file = path.with_suffix(".json")
    text = json.dumps(model_to_json(model), indent=2) + "\n"  # type: ignore[arg-type]
    if UPDATE:
        expected_file.write_text(text, encoding="utf-8")
    assert text == expected_file.read_text(encoding="utf-8")
