"""LMA Effort and Shape components."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mse.motion.base.bodyparts import body_map, split_name
from mse.motion.base.bvh import read_bvh
from mse.motion.base.lma import FEATURE_NAMES, PART_KEYS, WHOLE_BODY_KEYS, lma_features


def _bow(bandai_dir: Path, style: str) -> dict[str, float]:
    motion = read_bvh(bandai_dir / "data" / f"dataset-1_bow_{style}_001.bvh")
    return lma_features(motion).whole_body


def test_energetic_bows_have_more_weight_and_time(bandai_dir: Path) -> None:
    features = {s: _bow(bandai_dir, s) for s in ("active", "angry", "sad", "not-confident")}
    for component in ("weight", "time"):
        for strong in ("active", "angry"):
            for weak in ("sad", "not-confident"):
                assert features[strong][component] > features[weak][component], (
                    component,
                    strong,
                    weak,
                )


def test_json_shape(bandai_dir: Path) -> None:
    motion = read_bvh(bandai_dir / "data" / "dataset-1_bow_normal_001.bvh")
    features = lma_features(motion)
    decoded = json.loads(json.dumps(features.to_json()))
    assert list(decoded) == ["whole_body", "parts"]
    assert tuple(decoded["whole_body"]) == WHOLE_BODY_KEYS
    assert set(decoded["parts"]) == {
        "head",
        "left_hand",
        "right_hand",
        "left_foot",
        "right_foot",
        "torso",
    }
    assert all(tuple(v) == PART_KEYS for v in decoded["parts"].values())
    vector = features.vector()
    assert vector.shape == (len(FEATURE_NAMES),) and np.all(np.isfinite(vector))


def test_still_clip_has_no_effort(bandai_dir: Path) -> None:
    motion = read_bvh(bandai_dir / "data" / "dataset-1_bow_normal_001.bvh")
    still = motion.with_values(np.repeat(motion.values[:1], 40, axis=0))
    features = lma_features(still)
    assert features.whole_body["weight"] == pytest.approx(0.0, abs=1e-9)
    assert features.whole_body["time"] == pytest.approx(0.0, abs=1e-9)
    assert features.whole_body["shaping_vertical"] == pytest.approx(0.0, abs=1e-9)


def test_faster_playback_means_more_weight(bandai_dir: Path) -> None:
    motion = read_bvh(bandai_dir / "data" / "dataset-1_bow_normal_001.bvh")
    slow = lma_features(motion).whole_body
    fast = lma_features(motion.with_values(motion.values[::2])).whole_body
    assert fast["weight"] > 2 * slow["weight"]
    assert fast["shape_flow"] == pytest.approx(slow["shape_flow"], rel=0.05)


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("Hand_L", ("left", "hand")),
        ("LeftHand", ("left", "hand")),
        ("lhand", ("left", "hand")),
        ("RightWrist", ("right", "wrist")),
        ("Foot_R", ("right", "foot")),
        ("lowerback", ("", "lowerback")),
        ("Chest", ("", "chest")),
    ],
)
def test_split_name(name: str, expected: tuple[str, str]) -> None:
    assert split_name(name) == expected


@pytest.mark.parametrize(
    ("relative", "hand", "foot", "torso"),
    [
        ("motion/bandai-ds1/data/dataset-1_bow_sad_001.bvh", "Hand_L", "Foot_L", "Chest"),
        ("motion/cmu-131/131_02.bvh", "lhand", "LeftAnkle", "Chest"),
        ("motion/moda/AV_8Walk_Meredith_HVHA_Rep1.bvh", "LeftHand", "LeftFoot", "Spine"),
    ],
)
def test_body_parts_across_datasets(shared_dir: Path, relative: str, hand: str, foot: str, torso: str) -> None:
    path = shared_dir / relative
    if not path.is_file():
        pytest.skip(f"{relative} not found")
    motion = read_bvh(path)
    body = body_map(motion.skeleton)
    names = motion.skeleton.names
    assert (names[body.left_hand], names[body.left_foot], names[body.torso]) == (hand, foot, torso)
    features = lma_features(motion.slice(0, 200))
    assert np.all(np.isfinite(features.vector()))
