"""Waves' ``second`` context: the unit after the rise is labelled, adapted and played as a
context of its own (its duration is not the swings'), and older models without it still load
and play ``inner`` there; a run on real Bandai dataset 2 waves (skipped without the data)."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mse.motion.base.library import MotionLibrary
from mse.motion.hsmm import api
from mse.motion.hsmm.adapt import adapt_units, regression_class
from mse.motion.hsmm.io import load_model, model_bytes
from mse.motion.hsmm.model import HsmmModel, Instance, UnitModel
from mse.motion.hsmm.segment import segment_clip
from mse.motion.hsmm.synth import plan_units


def _sway(frames: int) -> np.ndarray:
    return np.sin(2 * np.pi * np.arange(frames) / 30.0)  # a turn every 15 frames


def test_the_unit_after_the_first_is_second_only_when_asked_and_not_last() -> None:
    plain = segment_clip(120, True, _sway(120))
    marked = segment_clip(120, True, _sway(120), second=True)
    assert [s.unit.split("-")[0] for s in plain][:3] == ["first", "inner", "inner"]
    assert [s.unit.split("-")[0] for s in marked][:3] == ["first", "second", "inner"]
    assert [(s.start, s.stop, s.unit[-1]) for s in plain] == [(s.start, s.stop, s.unit[-1]) for s in marked]
    short = segment_clip(25, True, _sway(25), second=True)  # first, then last: no second
    assert [s.unit.split("-")[0] for s in short] == ["first", "last"]


def test_second_has_the_swings_output_class_and_a_tempo_class_of_its_own() -> None:
    assert regression_class("second-a", by_context=True) == "inner"
    assert regression_class("second-a", by_context=True, timing=True) == "second"
    assert regression_class("second-b") == "b"
    assert regression_class("inner-b", by_context=True, timing=True) == "inner"


def test_a_quick_return_keeps_its_duration_beside_long_holds() -> None:
    # The rise's return lasts as long as the model expects, the swings (holds) five times
    # as long: the return keeps its own tempo instead of the holds'.
    units = {
        name: UnitModel(np.zeros((3, 3)), np.ones((3, 3)), np.full(3, 4.0), np.full(3, 1.0))
        for name in ("first-a", "second-b", "inner-a", "inner-b", "last-a")
    }
    instances = [
        Instance("first-a", "x", np.zeros((12, 3)), (0, 4, 8, 12)),
        Instance("second-b", "x", np.zeros((12, 3)), (0, 4, 8, 12)),
        Instance("inner-a", "x", np.zeros((60, 3)), (0, 20, 40, 60)),
        Instance("inner-b", "x", np.zeros((60, 3)), (0, 20, 40, 60)),
    ]
    blocks = [np.array([i]) for i in range(3)]
    adapted, _, _ = adapt_units(units, instances, np.full(3, 1e-4), blocks, by_context=True)
    assert float(adapted["second-b"].duration_means.sum()) < 16.0
    assert float(adapted["inner-b"].duration_means.sum()) > 40.0


def _model(names: tuple[str, ...]) -> HsmmModel:
    unit = UnitModel(np.zeros((2, 3)), np.ones((2, 3)), np.full(2, 3.0), np.ones(2))
    units = {name: unit for name in names}
    return HsmmModel("wave-both-hands", "x", "hands", units, None, np.ones(1), np.ones(1), np.ones(3))  # type: ignore[arg-type]


def test_plans_play_second_after_the_first_only_in_models_that_have_it() -> None:
    with_second = _model(("first-a", "second-b", "inner-a", "inner-b", "last-a", "last-b"))
    without = _model(("first-a", "inner-a", "inner-b", "last-a", "last-b"))
    assert plan_units(with_second, steps=5) == ["first-a", "second-b", "inner-a", "inner-b", "last-a"]
    assert plan_units(without, steps=5) == ["first-a", "inner-b", "inner-a", "inner-b", "last-a"]
    assert plan_units(with_second, steps=2) == ["first-a", "last-b"]
    assert without.resolve("second-b") == "inner-b"  # a wave model of format /6


def test_a_plan_for_a_length_ends_on_a_unit_its_clips_end_on() -> None:
    # Each unit lasts 6 frames: 33 frames are 5.5 units, rounded to 6 (first, 4 inner, last),
    # which from leg a ends on last-b; a model whose clips end on last-a plays 5 or 7 instead
    # (5: 30 frames, the nearer), one whose clips end on last-b keeps its 6.
    free = replace(_model(("first-a", "inner-a", "inner-b", "last-a", "last-b")), cycle="steps")
    ends_a = replace(free, info={"last_units": ["last-a"]})
    ends_b = replace(free, info={"last_units": ["last-b"]})
    assert plan_units(free, frames=33)[-1] == "last-b" and len(plan_units(free, frames=33)) == 6
    assert plan_units(ends_b, frames=33) == plan_units(free, frames=33)
    assert plan_units(ends_a, frames=33) == ["first-a", "inner-b", "inner-a", "inner-b", "last-a"]
    assert plan_units(ends_a, frames=12) == ["first-a", "inner-b", "last-a"]  # never fewer than 2
    assert plan_units(ends_a, steps=4)[-1] == "last-b"  # a count asked for is kept
    wave = replace(ends_a, cycle="hands")  # a hand cycle's ending is its fall: kept
    assert plan_units(wave, frames=33) == plan_units(free, frames=33)


def test_models_record_the_units_their_clips_end_on() -> None:
    names = ("first-a", "inner-b", "last-a", "first-b", "last-a")
    instances = [Instance(name, "x", np.zeros((4, 3)), (0, 2, 4)) for name in names]
    assert api._last_units(instances) == {"last_units": ["last-a"]}
    assert api._last_units(instances[:2]) == {}


@pytest.fixture(scope="module")
def wave_models(bandai_ds2: MotionLibrary) -> tuple[HsmmModel, HsmmModel]:
    library = bandai_ds2
    clips = sorted(library.select(action="wave-both-hands"), key=lambda c: c.id)
    styles = sorted({c.style for c in clips})
    training = [(library.motion(c), c.style) for s in styles for c in [c for c in clips if c.style == s][:2]]
    average = api.train_average(training, "wave-both-hands")
    feminine = next(c for c in clips if c.style == "feminine")
    return average, api.adapt_model(average, [library.motion(feminine)], "feminine")


@pytest.mark.slow
def test_bandai_feminine_wave_returns_from_its_rise_quickly(wave_models: tuple[HsmmModel, HsmmModel]) -> None:
    average, adapted = wave_models
    assert {"second-a", "second-b"} <= set(average.units)
    # The feminine take (dataset 2, first take): rise 13 frames, return 10, holds 83 and 94.
    second = adapted.unit(f"second-{'b' if adapted.first_leg == 'a' else 'a'}")
    inner = adapted.unit("inner-a")
    assert float(second.duration_means.sum()) < 15.0 < 40.0 < float(inner.duration_means.sum())


@pytest.mark.slow
def test_a_format_6_wave_model_still_loads_and_plays(wave_models: tuple[HsmmModel, HsmmModel], tmp_path: Path) -> None:
    average, _ = wave_models
    arrays = dict(np.load(io.BytesIO(model_bytes(average)), allow_pickle=False))
    meta = json.loads(str(arrays["meta"]))
    meta["format"] = "mse-hsmm/6"
    del meta["cycle"]  # formats before /8 said whether the model cycles, not by which limbs
    meta["cyclic"] = True
    meta["units"] = [u for u in meta["units"] if not u.startswith("second")]
    arrays = {k: v for k, v in arrays.items() if not k.startswith("unit:second")}
    arrays["meta"] = np.array(json.dumps(meta))
    path = tmp_path / "wave6.npz"
    np.savez(path, **arrays)
    old = load_model(path)
    assert old.cycle == "hands"  # a cyclic model without flight profiles
    assert not any(u.startswith("second") for u in old.units)
    assert plan_units(old, steps=4)[1].startswith("inner")
    assert api.synthesize(old, duration_s=2.0).frame_count == round(2.0 / old.template.frame_time)
