"""The compiled-model cache gives back exactly the model a fresh compile gives."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from mse.api import load
from mse.ir.canonical import model_to_json
from mse.ir.decode import model_from_trusted_json
from mse.model_cache import cache_dir
from mse.resources import behaviour_sets_dir

FILES = sorted(behaviour_sets_dir().glob("*.xml")) + sorted(
    (Path(__file__).parent / "fixtures" / "valid").glob("*.xml")
)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_decoding_the_canonical_json_gives_the_same_model(path: Path) -> None:
    model = load(path)
    decoded = model_from_trusted_json(json.loads(json.dumps(model_to_json(model))))
    assert decoded == model
    assert [s.span for s in decoded.signals] == [s.span for s in model.signals]
    assert [c.span for c in decoded.constraints] == [c.span for c in model.constraints]


def test_cache_hit_miss_edit_and_damage(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MSE_CACHE_DIR", str(tmp_path / "cache"))
    source = tmp_path / "x.xml"
    source.write_text('<expression name="x"><signals><signal id="a" modality="face"/></signals></expression>')
    first = load(source, cache=True)
    entries = list(cache_dir().glob("*.json"))
    assert len(entries) == 1
    assert load(source, cache=True) == first
    source.write_text('<expression name="x"><signals><signal id="b" modality="face"/></signals></expression>')
    assert load(source, cache=True).signals[0].id == "b"  # an edit is a miss
    for entry in cache_dir().glob("*.json"):
        entry.write_text("{damaged")
    assert load(source, cache=True).signals[0].id == "b"  # damage is ignored


def test_cached_sample_start_does_not_import_the_parser(tmp_path: Path) -> None:
    script = (
        "import sys, io, contextlib\n"
        "from mse.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    main(['sample', 'relief', '--seed', '1', '--format', 'json'])\n"
        "print(sorted(m for m in ('lark', 'lxml') if m in sys.modules))\n"
    )
    env = {"MSE_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
    runs = [
        subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True).stdout
        for _ in range(2)
    ]
    assert "lark" in runs[0]  # the first run compiles and fills the cache
    assert runs[1].strip() == "[]", runs[1]
