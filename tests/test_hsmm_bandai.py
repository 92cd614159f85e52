"""HSMM method on real Bandai clips (skipped without the shared data): training on a few
walks and bows, adaptation, synthesis length/finiteness/bone lengths, files, CLI, leaf."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

from mse.motion.base import cache
from mse.motion.base.bvh import Motion, read_bvh
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.hsmm import api, leaf
from mse.motion.hsmm.io import load_model, save_model
from mse.motion.hsmm.model import HsmmModel

WALK_STYLES = ("normal", "sad", "happy")


@pytest.fixture(scope="module")
def small_library(bandai_dir: Path) -> MotionLibrary:
    """Walks of three styles (two takes each) and bows of the same styles."""
    library = load_library(bandai_dir)
    keep = [c for c in library.clips if c.style in WALK_STYLES and c.action in ("walk", "bow")]
    return MotionLibrary("bandai-small", tuple(keep))


@pytest.fixture(scope="module")
def walk_average(small_library: MotionLibrary) -> HsmmModel:
    clips = [
        (small_library.motion(c), c.style)
        for c in small_library.select(action="walk")
        if c.id.endswith("_001") and c.style != "sad"
    ]
    return api.train_average(clips, "walk")


@pytest.fixture(scope="module")
def walk_sad(walk_average: HsmmModel, small_library: MotionLibrary) -> HsmmModel:
    return leaf.adapt_from_library(walk_average, small_library, "sad", takes=1)


def _bone_lengths(motion: Motion, root: int) -> np.ndarray:
    """Parent-child distances, per frame (the root's own translation is not a bone)."""
    positions = motion.positions()
    parents = motion.skeleton.parents
    return np.stack(
        [
            np.linalg.norm(positions[:, j] - positions[:, p], axis=1)
            for j, p in enumerate(parents)
            if p >= 0 and j != root
        ],
        axis=1,
    )


@pytest.mark.slow
def test_average_walk_model_has_step_units(walk_average: HsmmModel) -> None:
    assert walk_average.cyclic
    assert {"inner-a", "inner-b"} <= set(walk_average.units)
    assert walk_average.states == 5
    for unit in walk_average.units.values():
        assert np.all(np.isfinite(unit.means)) and np.all(unit.variances > 0)
        assert np.all(unit.duration_means >= 1.0)


@pytest.mark.slow
def test_adapted_walk_is_slower_like_the_sad_data(
    walk_average: HsmmModel, walk_sad: HsmmModel
) -> None:
    # Sad walks in Bandai take about 25 frames per step against 15-17 for normal/happy.
    average_step = walk_average.unit("inner-a").duration_means.sum()
    sad_step = walk_sad.unit("inner-a").duration_means.sum()
    assert sad_step > average_step + 3


@pytest.mark.slow
@pytest.mark.parametrize("seconds", [0.1, 1.0, 5.0])
def test_synthesized_walk_has_requested_length_and_rigid_bones(
    walk_sad: HsmmModel, seconds: float
) -> None:
    motion = api.synthesize(walk_sad, duration_s=seconds, seed=3)
    assert motion.frame_count == round(seconds / motion.frame_time)
    assert np.all(np.isfinite(motion.values))
    root = walk_sad.template.root_joint
    lengths = _bone_lengths(motion, root)
    assert np.max(lengths.std(axis=0)) < 1e-6
    template = walk_sad.template.translations
    expected = [
        np.linalg.norm(template[j])
        for j, p in enumerate(motion.skeleton.parents)
        if p >= 0 and j != root
    ]
    assert np.allclose(lengths[0], expected)


def test_synthesized_walk_travels_without_foot_sliding(walk_sad: HsmmModel) -> None:
    motion = api.synthesize(walk_sad, steps=6)
    positions = motion.positions()
    root = positions[:, walk_sad.template.root_joint]
    assert root[-1, 2] - root[0, 2] > 100.0  # several steps forward along +Z (cm)
    contacts = list(walk_sad.template.contacts[0] + walk_sad.template.contacts[1])
    points = positions[:, contacts]
    stance = np.argmin(points[:, :, 1], axis=1)
    slide = [
        np.linalg.norm(points[t, stance[t], [0, 2]] - points[t - 1, stance[t], [0, 2]])
        for t in range(1, motion.frame_count)
    ]
    # the stance foot is pinned; only the blend of a change of stance foot (a Gaussian of one
    # frame, mse.motion.base.contacts) moves it, by a centimetre or two in that one frame
    # (1.9 cm since the 6 Hz output low-pass rounds off the heel strike)
    assert np.median(slide) < 1e-6
    assert max(slide) < 2.5


@pytest.mark.slow
def test_bow_model_synthesizes_in_place(small_library: MotionLibrary) -> None:
    clips = [(small_library.motion(c), c.style) for c in small_library.select(action="bow")]
    model = api.train_average(clips, "bow")
    assert not model.cyclic and list(model.units) == ["whole"]
    motion = api.synthesize(model, duration_s=3.0)
    assert motion.frame_count == 90
    root = motion.positions()[:, model.template.root_joint]
    assert np.ptp(root[:, 0]) < 30 and np.ptp(root[:, 2]) < 30


def test_model_file_round_trip(walk_sad: HsmmModel, tmp_path: Path) -> None:
    path = tmp_path / "walk.sad"
    save_model(path, walk_sad)
    loaded = load_model(path)
    assert loaded.style == "sad" and set(loaded.units) == set(walk_sad.units)
    a = api.synthesize(walk_sad, duration_s=2.0)
    b = api.synthesize(loaded, duration_s=2.0)
    assert np.allclose(a.values, b.values)


@pytest.mark.slow
def test_leaf_gets_its_scheduled_duration(small_library: MotionLibrary, tmp_path: Path) -> None:
    two_walks = MotionLibrary(
        "two-walks",
        tuple(c for c in small_library.select(action="walk") if c.id.endswith("_001"))[:2],
    )
    style = two_walks.clips[1].style
    motion = leaf.synthesize_leaf(two_walks, "walk", style, 2.5, seed=1, cache_dir=tmp_path)
    assert motion.frame_count == 75
    assert len(list(tmp_path.glob("*.npz"))) == 2  # average and adapted models cached on disk
    cache.forget("hsmm")  # the next call must come from the disk cache
    again = leaf.synthesize_leaf(two_walks, "walk", style, 2.5, seed=1, cache_dir=tmp_path)
    assert np.allclose(motion.values, again.values)


def _run(*argv: str) -> int:
    from mse.cli import cmd_style

    parser = argparse.ArgumentParser(prog="mse")
    cmd_style.register(parser.add_subparsers())
    args = parser.parse_args(list(argv))
    return int(args.handler(args))


@pytest.mark.slow
def test_cli_train_adapt_synth(
    bandai_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    index = tmp_path / "library.json"
    clips = [
        f'{{"file": "{p}", "action": "walk", "style": "{p.stem.split("_")[2]}"}}'
        for p in sorted((bandai_dir / "data").glob("dataset-1_walk_*_001.bvh"))
        if p.stem.split("_")[2] in ("normal", "sad")
    ]
    index.write_text('{"clips": [' + ", ".join(clips) + "]}")
    avg, sad, out = tmp_path / "walk.avg", tmp_path / "walk.sad", tmp_path / "sad.bvh"
    assert _run("style", "train", "--library", str(index), "--action", "walk", "-o", str(avg)) == 0
    assert (
        _run("style", "adapt", str(avg), "--library", str(index), "--style", "sad", "-o", str(sad))
        == 0
    )
    assert _run("style", "synth", str(sad), "--steps", "6", "-o", str(out)) == 0
    assert read_bvh(out).frame_count > 60
    assert _run("style", "synth", str(tmp_path / "missing"), "--duration", "2", "-o", str(out)) == 1
    assert (
        _run("style", "adapt", str(avg), "--library", str(index), "--style", "nope", "-o", str(sad))
        == 1
    )
    err = capsys.readouterr().err
    assert "E100" in err and "E213" in err and "Traceback" not in err


def test_cli_trains_a_style_on_its_own_takes(
    small_library: MotionLibrary, bandai_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``mse style train --style S`` is the no-average-model baseline, from the style's takes."""
    alone = tmp_path / "walk.sad-only"
    argv = ("style", "train", "--library", str(bandai_dir), "--action", "walk")
    assert _run(*argv, "--style", "sad", "--takes", "1", "-o", str(alone)) == 0
    model = load_model(alone)
    assert (model.style, model.info["takes"], model.info["trained_on"]) == ("sad", 1, "style data only")
    take = small_library.motion(min(small_library.select(action="walk", style="sad"), key=lambda c: c.id))
    expected = api.train_scratch([(take, "sad")], "walk")
    assert set(model.units) == set(expected.units)
    assert all(np.allclose(model.units[u].means, expected.units[u].means) for u in model.units)
    assert _run(*argv, "--takes", "1", "-o", str(tmp_path / "x")) == 1  # --takes needs --style
    assert _run(*argv, "--style", "nope", "-o", str(tmp_path / "x")) == 1
    assert not (tmp_path / "x").exists()
    err = capsys.readouterr().err
    assert "--takes goes with --style" in err and "E213" in err and "Traceback" not in err


def test_adaptation_from_labelled_steps_of_a_take(walk_average: HsmmModel, small_library: MotionLibrary) -> None:
    """A run of steps from the middle of a take keeps the labels it has in the take (inner
    steps, not a mislabelled 'first'), and only those frames are used."""
    take = small_library.motion(next(c for c in small_library.select(action="walk") if c.style == "sad"))
    segments = api.segment_motion(take, walk_average.template, "steps")
    assert segments[0].unit.startswith("first-") and segments[-1].unit.startswith("last-")
    run = segments[2:4]
    assert all(s.unit.startswith("inner-") for s in run)
    instances, statics = api.clip_instances(take, "sad", walk_average.template, "steps", 5, run)
    assert [i.unit for i in instances] == [s.unit for s in run]
    assert statics.shape[0] == run[-1].stop - run[0].start
    adapted = api.adapt_model(walk_average, [take], "sad", segmentation=[run])
    scratch = api.train_scratch([(take, "sad")], "walk", segmentation=[run])
    assert set(scratch.units) == {s.unit for s in run}
    assert set(adapted.units) == set(walk_average.units)  # unseen units come from the average
    for model in (adapted, scratch):
        clip = api.synthesize(model, duration_s=3.0, seed=0)
        assert clip.frame_count == round(3.0 / take.frame_time) and np.all(np.isfinite(clip.values))


def test_adapted_gv_spread_is_the_styles_not_the_averages(walk_sad: HsmmModel, walk_average: HsmmModel) -> None:
    """The average model's GV variance spans several styles; one style's (a single take
    here) gets the same rule as a model trained on it alone: 10 % of its GV."""
    assert np.allclose(walk_sad.gv_var, (0.1 * walk_sad.gv_mean) ** 2 + 1e-12)
    moving = walk_average.gv_mean > 1e-8
    assert np.median(walk_average.gv_var[moving] / walk_average.gv_mean[moving] ** 2) > 0.01


def test_walks_generate_the_root_rotation_without_gv(walk_sad: HsmmModel) -> None:
    """GV widened the root's swing around the mean heading (the first frame of diagonal
    walks faced up to 21 deg off the real take's): the root's columns are plain MLPG, the
    other columns keep GV (every dimension is independent in both)."""
    from mse.motion.hsmm import synth

    names = synth.plan_units(walk_sad, steps=4)
    frames = round(sum(float(walk_sad.unit(n).duration_means.sum()) for n in names))
    with_gv, _ = synth.generate(walk_sad, names, frames, gv=True)
    without, _ = synth.generate(walk_sad, names, frames, gv=False)
    root = synth._root_columns(walk_sad.template)
    others = [c for c in range(with_gv.shape[1]) if c not in root]
    np.testing.assert_allclose(with_gv[:, root], without[:, root], atol=1e-9)
    assert not np.allclose(with_gv[:, others], without[:, others])


def test_adapted_model_starts_on_the_leg_its_takes_start_on(
    walk_sad: HsmmModel, walk_average: HsmmModel, small_library: MotionLibrary
) -> None:
    """Adaptation used to keep the average model's first leg; a style that starts on the
    other leg then swayed its pelvis in the opposite phase (dataset 1 walk-left proud)."""
    take = sorted(small_library.select(action="walk", style="sad"), key=lambda c: c.id)[0]
    segments = api.segment_motion(small_library.motion(take), walk_average.template, "steps")
    first = next(s.unit for s in segments if s.unit.startswith("first-"))
    assert walk_sad.first_leg == first.rpartition("-")[2]
    assert api.synthesize(walk_sad, steps=3).frame_count > 0


def test_feet_lift_tells_standing_actions_from_acting_legs(
    small_library: MotionLibrary, walk_sad: HsmmModel, tmp_path: Path
) -> None:
    """Bows keep both feet down (legs stilled at synthesis); walks lift a foot every step.
    The template keeps the value through the model file."""
    from mse.motion.hsmm import synth
    from mse.motion.hsmm.prep import build_template

    bows = [small_library.motion(c) for c in small_library.select(action="bow")]
    assert build_template(bows).feet_lift <= synth.ACTING_LEGS_LIFT
    assert walk_sad.template.feet_lift > synth.ACTING_LEGS_LIFT
    path = tmp_path / "walk.sad"
    save_model(path, walk_sad)
    assert load_model(path).template.feet_lift == pytest.approx(walk_sad.template.feet_lift)
