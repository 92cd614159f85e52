"""W314: a relation that, read "for every pair of occurrences", lets one occurrence of a
repetitive signal block all its later ones (issue 32 item 5): decided from the relation's
bounds and the signals' durations and repetitivity, never from names."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import escape

import pytest

import mse.api as api
from mse.cli import main
from mse.resources import bundled_names

SET = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="blocking">
  <signals>
    <signal id="a" modality="face" lexeme="faceexp=a" min_duration="{a_min}" max_duration="2"
            probability_start="0.5" probability_end="0.5" repetitivity="{a_rep}"/>
    <signal id="b" modality="head" lexeme="head=b" min_duration="1" max_duration="2"
            probability_start="0.5" probability_end="0.5" repetitivity="0"/>
  </signals>
  <constraints>
    <constraint id="c1">{expr}</constraint>
  </constraints>
</expression>
"""


def _w314(tmp_path: Path, expr: str, a_min: float = 1.0, a_rep: int = 1) -> list[str]:
    path = tmp_path / "set.xml"
    path.write_text(SET.format(expr=escape(expr), a_min=a_min, a_rep=a_rep), encoding="utf-8")
    return [d.render() for d in api.lint([path], deep=False) if d.code == "W314"]


def test_fires_with_position_signals_and_advice(tmp_path: Path) -> None:
    (found,) = _w314(tmp_path, "equal(start(a), stop(b), 0.3) and exists(b)")
    assert found.startswith(f"{tmp_path / 'set.xml'}:10:25: W314 constraint 'c1': equal(start(a), stop(b), 0.3)")
    assert "once 'b' occurs, at most one 'a' can" in found
    assert "each 'a' with its nearest 'b'" in found and 'repetitivity="0"' in found


@pytest.mark.parametrize("expr", [
    "equal(start(a), stop(b), 0.3)",
    "exists(b) implies start(a) >= stop(b) and start(a) <= stop(b) + 0.5",  # a 0.5 s window
    "includes(a, b)",  # two a never both hold one b
    "equal(start(b), start(a), 0.45)",
])
def test_fires_on_narrow_required_relations(tmp_path: Path, expr: str) -> None:
    assert len(_w314(tmp_path, expr)) == 1, expr


@pytest.mark.parametrize(("expr", "a_min", "a_rep"), [
    ("equal(start(a), stop(b), 0.3)", 1.0, 0),  # once-only: nothing to block
    ("equal(start(a), stop(b), 0.6)", 1.0, 1),  # starts within 1.2 s: two 1 s occurrences fit
    ("equal(start(a), stop(b), 0.3)", 0.5, 1),  # starts within 0.6 s: two 0.5 s occurrences fit
    ("precedes(b, a)", 1.0, 1),  # one-sided: every later a is fine
    ("includes(b, a)", 0.5, 1),  # b lasts up to 2 s: two 0.5 s a fit inside
    ("equal(start(a), stop(b), 0.3) or exists(a)", 1.0, 1),  # not required
    ("exists(a) implies equal(start(a), 3)", 1.0, 1),  # no partner signal
])
def test_quiet_when_two_occurrences_fit_or_nothing_is_required(tmp_path: Path, expr: str, a_min: float,
                                                               a_rep: int) -> None:
    assert _w314(tmp_path, expr, a_min, a_rep) == [], expr


def test_bundled_sets_are_quiet() -> None:
    from mse.ir.lint import blocking_relations

    for name in bundled_names():
        model = api.load(name)
        assert list(blocking_relations(model)) == [], name


@pytest.fixture(scope="module")
def greta_sets(greta_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("greta")
    assert main(["import-greta", str(greta_dir / "lexicon.xml"), str(greta_dir / "constraint.xml"),
                 "-o", f"{folder}/"]) == 0
    return folder


def test_fires_on_greta_tension_and_pride(greta_sets: Path) -> None:
    found = {}
    for path in sorted(greta_sets.glob("*.xml")):
        found[path.stem] = sorted(d.message.split("'")[1] for d in api.lint([path], deep=False)
                                  if d.code == "W314")
    assert found["tension"] == ["tension_label_1", "tension_label_2", "tension_label_3"]
    assert found["pride"] == ["pride_label_7"]  # s1 (repetitive, >= 2 s) within 0.3 s of s2's start
    # regret: s16 (repetitive, >= 1.5 s) must include each of s17, s18, s19, s25
    assert found["regret"] == ["reget_label_4", "reget_label_5", "reget_label_6", "reget_label_7"]
    assert {name for name, codes in found.items() if codes} == {"tension", "pride", "regret"}
