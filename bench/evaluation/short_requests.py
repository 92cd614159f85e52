"""Requests shorter than one cycle of the action: do they end still on the rest pose?

    python -m bench.evaluation.short_requests --shared ../shared
    python -m bench.evaluation.short_requests --cases bandai-ds1:kick:normal_001 --factors 0.3,0.6

Each case is a small library of one action's takes (``folder:action:take+take``, a take named
``style_number`` as in the Bandai file names; the first take is the one requested and compared
with). Its cycle is the action's period measured on the takes (:func:`action_shape`; an action
that does not cycle: its first take's length). Every method generates the first take's style
lasting each factor of that cycle, and the bench prints: the distance of the last frame's
joints from the take's last pose (hips-relative, turned so that the hips face +Z, largest over
the joints but the floor root, cm), the largest joint speed in the last frame (cm/s), and the
RMS jerk of head and wrists (:func:`bench.evaluation.fidelity.measure`) against the take's.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

from bench.evaluation.fidelity import measure
from mse.motion.base.bodyparts import body_map
from mse.motion.base.bvh import Motion
from mse.motion.base.contacts import find_root_joint
from mse.motion.base.cycles import action_shape
from mse.motion.base.heading import facing_yaws
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.generator import METHODS, GenerationRequest, generator_for

#: one action of each kind: locomotion, one-shot (the kick spins three turns), a hand cycle
CASES = (
    "bandai-ds1:run:normal_001+tired_001",
    "bandai-ds1:walk:normal_001+sad_001",
    "bandai-ds1:kick:normal_001",
    "bandai-ds1:byebye:normal_001+sad_001",
    "bandai-ds1:bow:angry_001+normal_001",
    "bandai-ds2:wave-both-hands:normal_001+normal_002+active_001+active_002",
)


def aligned(motion: Motion, hips: int) -> np.ndarray:
    """(T, J-1, 3) joint positions from the hips, turned so that the hips face +Z (joint 0,
    Bandai's ``joint_Root`` on the floor, left out)."""
    positions = motion.positions()
    body = body_map(motion.skeleton)
    yaws = facing_yaws(positions, body.left_hip, body.right_hip)
    relative = positions - positions[:, hips : hips + 1]
    c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
    x, z = relative[..., 0].copy(), relative[..., 2].copy()
    relative[..., 0], relative[..., 2] = c * x - s * z, s * x + c * z
    return relative[:, 1:]


def case_library(shared: Path, case: str, folder: Path) -> tuple[MotionLibrary, str]:
    """The library of one case (written to ``folder``) and its action."""
    library_name, action, takes = case.split(":")
    data = shared / "motion" / library_name / "data"
    number = library_name.rsplit("ds", 1)[-1]
    entries = [
        {"file": str(data / f"dataset-{number}_{action}_{take}.bvh"), "action": action, "style": take.split("_")[0]}
        for take in takes.split("+")
    ]
    (folder / "library.json").write_text(json.dumps({"clips": entries}))
    return load_library(folder), action


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", default=os.environ.get("MSE_SHARED", "../shared"))
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated folder:action:take+take")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--factors", default="0.3,0.6", help="comma-separated shares of one cycle")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cache = os.environ.get("MSE_CACHE_DIR", ".cache-mse")
    generators = {m: generator_for(m, cache) for m in args.methods.split(",")}
    factors = [float(f) for f in args.factors.split(",")]
    print("case, method, factor: frames, distance to the rest pose (cm), last-frame speed (cm/s), jerk / take's")
    for case in args.cases.split(","):
        with tempfile.TemporaryDirectory() as folder:
            library, action = case_library(Path(args.shared), case, Path(folder))
            take = library.motion(library.clips[0])
            shape = action_shape([library.motion(c) for c in library.clips])
            cycle = shape.period_s if shape.cyclic else take.duration
            hips = find_root_joint(take)
            rest = aligned(take, hips)[-1]
            real_jerk = measure(take)["jerk"]
            print(f"== {case} ({shape.cycle}, cycle {cycle:.2f} s)")
            for method, generator in generators.items():
                for factor in factors:
                    request = GenerationRequest(action, library.clips[0].style, factor * cycle)
                    motion = generator.generate(library, request)
                    pose = aligned(motion, hips)
                    distance = float(np.max(np.linalg.norm(pose[-1] - rest, axis=-1)))
                    speed = float(np.max(np.linalg.norm(pose[-1] - pose[-2], axis=-1))) / motion.frame_time
                    jerk = f"{measure(motion)['jerk'] / real_jerk:.1f}" if motion.frame_count > 4 else "-"
                    frames = motion.frame_count
                    print(f"  {method:8s} x{factor:<4g} {frames:4d} {distance:6.1f} {speed:6.1f} {jerk:>6s}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
