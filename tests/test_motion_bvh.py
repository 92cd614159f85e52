"""BVH reading/writing and forward kinematics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mse.diagnostics import MseError
from mse.motion.base.bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from mse.motion.base.kinematics import euler_to_matrix, matrix_to_euler

TWO_BONES = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Arm
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Hand
    {
      OFFSET 2 0 0
      CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0.5 0 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 0 0 0 0 0 0 0 0 2 0 0 0 0 0
1 2 3 90 0 0 0 0 0 0 3 0 0 0 0
"""


def test_forward_kinematics_matches_hand_computed_poses() -> None:
    motion = parse_bvh(TWO_BONES)
    positions = motion.positions()
    # frame 0: rest pose along +X
    assert np.allclose(positions[0], [[0, 0, 0], [1, 0, 0], [3, 0, 0]])
    # frame 1: root moved to (1,2,3) and turned 90 deg about Z: +X maps to +Y; the hand's
    # position channels (0, 3, 0) replace its OFFSET, so it sits 3 along the arm's +Y -> -X.
    assert np.allclose(positions[1], [[1, 2, 3], [1, 3, 3], [-2, 3, 3]])
    assert motion.frame_count == 2 and motion.duration == pytest.approx(0.08)


def test_euler_round_trip_all_orders() -> None:
    rng = np.random.default_rng(3)
    angles = rng.uniform(-85, 85, (200, 3))
    for order in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"):
        back = matrix_to_euler(euler_to_matrix(angles, order), order)
        assert np.allclose(back, angles, atol=1e-8), order
    # the composition order is the channel order: ZXY means Rz @ Rx @ Ry
    sample = np.array([10.0, 20.0, 30.0])
    rz, rx, ry = (euler_to_matrix(np.array(v), "XYZ") for v in ([0, 0, 10], [20, 0, 0], [0, 30, 0]))
    assert np.allclose(euler_to_matrix(sample, "ZXY"), rz @ rx @ ry)


def test_round_trip_synthetic(tmp_path: Path) -> None:
    motion = parse_bvh(TWO_BONES)
    target = tmp_path / "clip.bvh"
    write_bvh(target, motion)
    again = read_bvh(target)
    assert again.skeleton.same_layout(motion.skeleton)
    assert again.skeleton.end_sites == motion.skeleton.end_sites
    assert np.allclose(again.values, motion.values, atol=1e-6)
    assert format_bvh(again) == format_bvh(motion)


@pytest.mark.parametrize(
    "relative",
    [
        "motion/bandai-ds1/data/dataset-1_bow_angry_001.bvh",
        "motion/cmu-131/131_01.bvh",
        "motion/moda/AV_8Walk_Meredith_HVHA_Rep1.bvh",
    ],
)
def test_round_trip_real_files(shared_dir: Path, relative: str) -> None:
    path = shared_dir / relative
    if not path.is_file():
        pytest.skip(f"{relative} not found in {shared_dir}")
    motion = read_bvh(path)
    again = parse_bvh(format_bvh(motion))
    assert np.abs(again.values - motion.values).max() <= 1e-6
    assert np.abs(again.skeleton.offsets - motion.skeleton.offsets).max() <= 1e-6
    assert np.abs(again.positions() - motion.positions()).max() <= 1e-6


def test_bandai_skeleton_is_upright(bandai_dir: Path) -> None:
    motion = read_bvh(bandai_dir / "data" / "dataset-1_bow_normal_001.bvh")
    skeleton = motion.skeleton
    assert skeleton.joint_count == 22
    assert all(len(c) == 6 for c in skeleton.channels)
    assert skeleton.rotation_order(1) == "ZXY"
    first = motion.positions()[0]
    head, foot = first[skeleton.index("Head")], first[skeleton.index("Foot_L")]
    assert head[1] - foot[1] > 100  # cm, Y up


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("", 0),
        ("HIERARCHY\nROOT a\n{\n OFFSET 0 0\n", 4),
        (TWO_BONES.replace("CHANNELS 3 Zrotation", "CHANNELS 3 Qrotation"), 9),
        (TWO_BONES.replace("Frames: 2", "Frames: 3"), 25),
        (TWO_BONES.replace("1 2 3 90", "1 2 x 90"), 25),
        (TWO_BONES.replace("1 2 3 90 0 0 0 0 0 0 3 0 0 0 0", "1 2 3"), 25),
    ],
)
def test_bad_input_reports_file_and_line(text: str, line: int) -> None:
    with pytest.raises(MseError) as caught:
        parse_bvh(text, "bad.bvh")
    diagnostic = caught.value.diagnostics[0]
    assert diagnostic.span.path == "bad.bvh"
    assert diagnostic.span.line == line
    assert diagnostic.code == "E100"


def test_missing_file_is_an_mse_error(tmp_path: Path) -> None:
    with pytest.raises(MseError):
        read_bvh(tmp_path / "nope.bvh")
