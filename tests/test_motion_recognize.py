"""The style recognizer of the objective validation: descriptor shape, finiteness, and that
it tells apart the starter library's clearly different styles."""

from __future__ import annotations

import numpy as np
import pytest

from bench.evaluation.recognize import StyleRecognizer, style_descriptor
from mse.motion.base.starter import generate_clip


def test_descriptor_is_finite_and_fixed_length() -> None:
    short = style_descriptor(generate_clip("bow", "sad", 0))
    other = style_descriptor(generate_clip("nod", "angry", 1))
    assert short.shape == other.shape
    assert np.all(np.isfinite(short)) and np.all(np.isfinite(other))


@pytest.mark.slow
def test_recognizer_separates_starter_styles_on_a_held_out_performer() -> None:
    actions, styles = ("bow", "shrug"), ("sad", "angry", "proud")
    rows, labels, names = [], [], []
    for action in actions:
        for style in styles:
            for performer in (0, 1):
                rows.append(style_descriptor(generate_clip(action, style, performer)))
                labels.append(style)
                names.append(action)
    recognizer = StyleRecognizer.fit(np.array(rows), names, labels, c=1.0)
    hits = [
        recognizer.predict(style_descriptor(generate_clip(action, style, 2)), action) == style
        for action in actions
        for style in styles
    ]
    assert sum(hits) >= 5
    # an action never seen in training still gets a valid label
    assert recognizer.predict(rows[0], "unknown-action") in styles
