"""The eight bundled behaviour sets: shape, lint, and a hand-built consistent 10 s witness.

Each witness is a timeline written by hand from the constraints (see docs/behaviour_sets.md);
the evaluator must accept it, and breaking one ordering in it must be caught, so the
constraints are known to be satisfiable together and to mean something.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import mse.api
from mse.cli import main as cli_main
from mse.diagnostics import Diagnostic, Severity
from mse.ir import model as ir
from mse.ir.lint import LEXEME_CLASS_MODALITY
from mse.resources import behaviour_sets_dir, bundled_names
from mse.timeline import Timeline, TimelineSignal

EMOTIONS = (
    "anger",
    "anxiety",
    "cheerfulness",
    "embarrassment",
    "panic_fear",
    "pride",
    "relief",
    "tension",
)
BODY_MODALITIES = {"gesture", "torso", "posture"}

Occurrences = list[tuple[str, float, float]]

#: One consistent 10 s timeline per emotion: (signal, start, stop) in seconds.
WITNESSES: dict[str, Occurrences] = {
    "embarrassment": [
        ("head_down", 0.0, 3.0), ("bow", 0.2, 3.5), ("gaze_down", 0.5, 2.5),
        ("neutral_expression", 0.0, 2.0), ("tensed_smile", 3.0, 6.0), ("gaze_right", 4.0, 5.0),
        ("gaze_left", 5.5, 6.5), ("hand_on_mouth", 5.0, 7.5), ("head_left", 6.0, 9.5),
        ("smile", 6.5, 8.5),
    ],
    "pride": [
        ("head_up", 0.0, 5.0), ("proud_smile", 0.2, 3.2), ("chest_out", 0.0, 6.0),
        ("gaze_direct", 0.5, 4.5), ("pressed_lips", 3.5, 5.5), ("hands_on_hips", 1.0, 5.0),
        ("arms_crossed", 5.5, 9.0),
    ],
    "anxiety": [
        ("fear_mouth", 0.0, 3.0), ("blinking", 1.0, 2.5), ("blinking", 6.0, 7.0),
        ("gaze_right", 2.0, 3.5), ("gaze_left", 4.0, 5.0), ("lip_stretch", 3.5, 5.5),
        ("social_smile", 6.0, 8.0), ("hand_on_face", 1.0, 4.0), ("hands_clasp", 4.5, 8.0),
    ],
    "anger": [
        ("frown_teeth", 0.0, 4.0), ("lean_forward", 0.5, 3.5), ("head_forward", 1.0, 2.5),
        ("head_nod", 3.0, 4.5), ("hands_on_hips", 0.5, 4.5), ("fist_raise", 5.0, 8.0),
        ("frown", 5.0, 8.5), ("pressed_lips", 8.6, 10.0),
    ],
    "cheerfulness": [
        ("open_mouth_smile", 0.0, 3.0), ("arms_raised", 0.5, 3.5), ("head_nod", 1.0, 2.0),
        ("head_tilt", 4.0, 5.5), ("laugh", 3.5, 6.0), ("lean_back", 3.0, 6.5),
        ("duchenne_smile", 6.5, 10.0),
    ],
    "panic_fear": [
        ("fear_face_open_mouth", 0.0, 2.5), ("head_back", 0.1, 2.5), ("step_back", 0.0, 4.0),
        ("fear_face_lips_down", 3.0, 6.0), ("hand_on_mouth", 1.0, 4.0),
        ("hands_on_face", 5.0, 8.0), ("gaze_scan", 3.0, 4.5), ("gaze_scan", 6.0, 7.5),
    ],
    "relief": [
        ("open_mouth", 0.0, 2.5), ("head_up", 0.2, 2.2), ("head_tilt_right", 1.5, 4.0),
        ("hands_thrust_up", 1.0, 3.5), ("torso_forward", 0.0, 5.0), ("relief_smile", 4.5, 8.0),
        ("gaze_away", 3.0, 4.5), ("hands_outward", 5.0, 8.0),
    ],
    "tension": [
        ("brow_lower", 0.0, 1.5), ("pressed_lips", 1.6, 3.2), ("lip_bite", 3.3, 4.8),
        ("jaw_clench", 5.0, 6.5), ("jaw_clench", 7.0, 8.5), ("gaze_fixed", 1.0, 4.0),
        ("fist_clench", 5.0, 8.0), ("shoulders_up", 4.5, 9.0), ("head_lowered", 5.0, 8.0),
    ],
}

#: One edit of each witness that a constraint forbids: (signal, new start, new stop, constraint).
BREAKS: dict[str, tuple[str, float, float, str]] = {
    "embarrassment": ("tensed_smile", 2.0, 4.5, "looks_down_first"),
    "pride": ("chest_out", 1.0, 7.0, "posture_with_head_up"),
    "anxiety": ("hands_clasp", 6.0, 9.5, "hands_come_down"),
    "anger": ("fist_raise", 4.0, 7.0, "fist_after_nod"),
    "cheerfulness": ("laugh", 2.5, 4.0, "laugh_after_smile"),
    "panic_fear": ("fear_face_lips_down", 1.0, 3.0, "fear_face_sequence"),
    "relief": ("relief_smile", 2.0, 5.0, "smile_after_exhale"),
    "tension": ("lip_bite", 4.0, 5.5, "bite_follows_press"),
}


def _timeline(model: ir.Model, occurrences: Occurrences) -> Timeline:
    info = model.signal_info
    return Timeline(
        expression=model.name,
        duration=10.0,
        signals=tuple(
            TimelineSignal(name, info[name][0], info[name][1], start, stop)
            for name, start, stop in occurrences
        ),
        solver="hand",
    )


@pytest.fixture(scope="module")
def models() -> dict[str, ir.Model]:
    return {name: mse.api.load(name) for name in EMOTIONS}


def test_the_eight_sets_are_bundled() -> None:
    assert set(EMOTIONS) <= set(bundled_names())


@pytest.mark.parametrize("name", EMOTIONS)
def test_witness_is_consistent(models: dict[str, ir.Model], name: str) -> None:
    model = models[name]
    timeline = _timeline(model, WITNESSES[name])
    assert [v.render() for v in mse.api.check(model, timeline)] == []
    assert len({entry.id for entry in timeline.signals}) >= 6  # several signals


@pytest.mark.parametrize("name", EMOTIONS)
def test_breaking_the_witness_is_caught(models: dict[str, ir.Model], name: str) -> None:
    signal, start, stop, constraint = BREAKS[name]
    edited = [(s, start, stop) if s == signal else (s, a, b) for s, a, b in WITNESSES[name]]
    violations = mse.api.check(models[name], _timeline(models[name], edited))
    assert constraint in {v.constraint for v in violations}


@pytest.mark.parametrize("name", EMOTIONS)
def test_set_shape(models: dict[str, ir.Model], name: str) -> None:
    model = models[name]
    assert model.name == name
    assert 6 <= len(model.signals) <= 12
    assert len(model.constraints) >= 5
    assert all(c.explicit_id for c in model.constraints)  # readable ids everywhere
    assert model.description
    for signal in model.signals:
        assert signal.max_duration is not None and signal.max_duration >= 1.0
        lexeme_class = signal.lexeme.split("=", 1)[0]
        family = "torso" if signal.modality == "posture" else signal.modality
        assert LEXEME_CLASS_MODALITY[lexeme_class] == family, signal.id
        # body signals carry a motion leaf, the others do not
        assert (signal.motion is not None) == (signal.modality in BODY_MODALITIES), signal.id


def _errors_and_warnings(found: list[Diagnostic]) -> list[str]:
    """Notes (N codes) say what may well be meant, e.g. Greta's "if both occur" relations."""
    return [d.render() for d in found if d.severity is not Severity.NOTE]


@pytest.mark.slow
def test_lint_strict_is_clean() -> None:
    assert _errors_and_warnings(mse.api.lint([behaviour_sets_dir()])) == []


@pytest.mark.slow
def test_solver_backed_lint_is_clean() -> None:
    """No dead, forced or never-instantiated signal, no redundant constraint (W4xx)."""
    assert _errors_and_warnings(mse.api.lint([behaviour_sets_dir()], deep=True)) == []


def test_operators_used_across_the_sets(models: dict[str, ir.Model]) -> None:
    relations: set[str] = set()
    kinds: set[str] = set()
    offsets = False
    for model in models.values():
        for constraint in model.constraints:
            for node in ir.walk(constraint.expr):
                kinds.add(type(node).__name__)
                if isinstance(node, ir.Relation):
                    relations.add(node.kind)
                if isinstance(node, ir.Compare):
                    terms = (node.left, node.right)
                    offsets |= any(isinstance(t, ir.SignalTime) and t.offset for t in terms)
    assert relations == {"includes", "excludes", "precedes", "rightincludes"}
    assert {"Exists", "Compare", "Not", "And", "Or", "Implies"} <= kinds
    assert offsets


def test_embarrassment_has_the_papers_ten_signals(models: dict[str, ir.Model]) -> None:
    model = models["embarrassment"]
    by_modality: dict[str, set[str]] = {}
    for signal in model.signals:
        by_modality.setdefault(signal.modality, set()).add(signal.id)
    assert by_modality == {
        "head": {"head_down", "head_left"},
        "gaze": {"gaze_down", "gaze_right", "gaze_left"},
        "face": {"smile", "tensed_smile", "neutral_expression"},
        "gesture": {"hand_on_mouth"},
        "torso": {"bow"},
    }
    assert "Keltner" in model.description


@pytest.mark.parametrize(
    ("name", "source"),
    [("pride", "Shiota"), ("anxiety", "Harrigan"), ("relief", "Fig."), ("anger", "Greta")],
)
def test_descriptions_cite_sources(models: dict[str, ir.Model], name: str, source: str) -> None:
    assert source in models[name].description


def test_mse_check_accepts_a_witness_file(tmp_path: Path, models: dict[str, ir.Model]) -> None:
    timeline = _timeline(models["embarrassment"], WITNESSES["embarrassment"])
    path = tmp_path / "t.json"
    path.write_text(json.dumps(timeline.to_json()), encoding="utf-8")
    assert cli_main(["check", "embarrassment", str(path), "--quiet"]) == 0


def test_docs_list_every_signal_and_constraint(models: dict[str, ir.Model]) -> None:
    docs = (Path(__file__).resolve().parent.parent / "docs" / "behaviour_sets.md").read_text(
        encoding="utf-8")
    for model in models.values():
        assert f"## {model.name}" in docs
        assert f"| {model.name} | {len(model.signals)} | {len(model.constraints)} |" in docs
        for signal in model.signals:  # the tables show the numbers of the files
            row = (f"| `{signal.id}` | {signal.modality} | `{signal.lexeme}` | "
                   f"{signal.min_duration:g}–{signal.max_duration:g} | "
                   f"{signal.probability_start:g} → {signal.probability_end:g} | "
                   f"{signal.repetitivity} | {signal.motion.action if signal.motion else ''} |")
            assert row in docs, row
        for constraint in model.constraints:
            assert f"| `{constraint.id}` | `" in docs, (model.name, constraint.id)
    actions = sorted({s.motion.action for m in models.values() for s in m.signals if s.motion})
    assert ", ".join(f"`{a}`" for a in actions) in " ".join(docs.split())
