"""Generated expressions print and re-parse to the same IR; mutated files never crash."""

from __future__ import annotations

import random
from pathlib import Path
from xml.sax.saxutils import escape

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mse.api import compile_source, loads
from mse.ir.canonical import model_dumps, model_from_json
from mse.ir.printer import expr_text
from mse.resources import behaviour_sets_dir

SIGNALS = ("a", "b", "c_2", "and_x")
signal = st.sampled_from(SIGNALS)
number = st.decimals(min_value=0, max_value=60, places=3).map(lambda d: format(d.normalize(), "f"))
offset = st.lists(st.tuples(st.sampled_from("+-"), number), max_size=2).map(
    lambda parts: "".join(f" {sign} {value}" for sign, value in parts)
)
edge = st.sampled_from(["start", "stop"])
#: length(s) and differences of two times: only ever compared with a number (E216 otherwise)
difference = st.one_of(
    st.builds(lambda s, o: f"length({s}){o}", signal, offset),
    st.builds(lambda e, s, f, t, o: f"{e}({s}) - {f}({t}){o}", edge, signal, edge, signal, offset),
)
term = st.one_of(
    st.builds(lambda e, s, o: f"{e}({s}){o}", edge, signal, offset),
    st.builds(lambda o: f"duration{o}", offset),
    st.builds(lambda neg, n: f"{'-' if neg else ''}{n}", st.booleans(), number),
)
atom = st.one_of(
    st.builds(lambda s: f"exists({s})", signal),
    st.builds(
        lambda k, x, y: f"{k}({x}, {y})",
        st.sampled_from(["includes", "excludes", "precedes", "rightincludes"]),
        signal,
        signal,
    ),
    st.builds(lambda k, x, y: f"{k}({x},{y})", st.sampled_from(["lessthan", "morethan"]), term, term),
    st.builds(
        lambda x, y, t: f"equal({x}, {y}{t})", term, term, st.one_of(st.just(""), number.map(lambda n: f", {n}"))
    ),
    st.builds(lambda x, op, y: f"{x} {op} {y}", term, st.sampled_from(["<", ">", "=", "<=", ">="]), term),
    st.builds(
        lambda x, op, y, flip: f"{y} {op} {x}" if flip else f"{x} {op} {y}",
        difference,
        st.sampled_from(["<", ">", "=", "<=", ">="]),
        st.builds(lambda neg, n: f"{'-' if neg else ''}{n}", st.booleans(), number),
        st.booleans(),
    ),
    st.builds(lambda x, y: f"equal({x}, {y}, 0.25)", difference, number),
)


def _extend(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        st.builds(lambda e: f"not {e}", children),
        st.builds(lambda e: f"({e})", children),
        st.builds(lambda x, op, y: f"{x} {op} {y}", children, st.sampled_from(["and", "or", "implies"]), children),
    )


expression = st.recursive(atom, _extend, max_leaves=12)


def _document(constraint: str) -> str:
    signals = "".join(f'<signal id="{s}" modality="face"/>' for s in SIGNALS)
    return (
        f'<expression name="g"><signals>{signals}</signals><constraints>'
        f'<constraint id="k">{escape(constraint)}</constraint></constraints></expression>'
    )


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(expression)
def test_printed_expressions_reparse_to_the_same_ir(text: str) -> None:
    model = loads(_document(text))
    printed = expr_text(model.constraints[0].expr)
    again = loads(_document(printed))
    assert again.constraints[0].expr == model.constraints[0].expr, (text, printed)
    assert expr_text(again.constraints[0].expr) == printed


@settings(max_examples=50, deadline=None)
@given(expression)
def test_compiled_ir_json_reloads_to_the_same_model(text: str) -> None:
    import json

    model = loads(_document(text))
    assert model_from_json(json.loads(model_dumps(model))) == model


def _corpus() -> list[Path]:
    fixtures = Path(__file__).parent / "fixtures" / "valid"
    return sorted(behaviour_sets_dir().glob("*.xml")) + sorted(fixtures.glob("*.xml"))


def _mutate(data: bytes, rng: random.Random) -> bytes:
    buffer = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        choice = rng.random()
        position = rng.randrange(len(buffer) + 1)
        if choice < 0.3 and buffer:
            del buffer[position : position + rng.randint(1, 20)]
        elif choice < 0.6:
            buffer[position:position] = rng.choice(
                [
                    b"<",
                    b">",
                    b"&",
                    b"(",
                    b")",
                    b'"',
                    b"not ",
                    b" and ",
                    b"&lt;",
                    b"-1",
                    b"NaN",
                    b"\x00",
                    b"\xff",
                    b"<!--",
                    b"]]>",
                ]
            )
        elif buffer:
            start = rng.randrange(len(buffer))
            chunk = bytes(buffer[start : start + rng.randint(1, 40)])
            buffer[position:position] = chunk
    return bytes(buffer)


def test_random_mutations_of_real_files_never_raise() -> None:
    rng = random.Random(20261122)
    corpus = _corpus()
    assert corpus
    for round_number in range(400):
        source = corpus[round_number % len(corpus)]
        mutated = _mutate(source.read_bytes(), rng)
        model, diagnostics = compile_source(source.name, mutated)
        assert model is not None or diagnostics
        for diagnostic in diagnostics:
            assert diagnostic.span.path == source.name
            assert diagnostic.code[0] in "EW"
