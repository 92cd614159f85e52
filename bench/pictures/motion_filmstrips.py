"""Filmstrips for docs/images: real clip vs the two methods, a handful of cases.

    python -m bench.pictures.motion_filmstrips [--out docs/images] [--shared ../shared]
    python -m bench.pictures.motion_filmstrips --case bandai-ds1:run:normal:10 --factor 3 --max-seconds 3
    python -m bench.pictures.motion_filmstrips --case bandai-ds2:walk:elderly:8 --turning 20 --max-seconds 9

Each PNG has three rows: a real clip of the target style (first take), the LMA + HMM clip and
the HSMM clip generated for that style as long as the real clip (``--factor``: that many
times as long; ``--case LIBRARY:ACTION:STYLE:FRAMES``, repeatable, instead of the set); frames are spread evenly over
each clip and every clip is seen from the side in its own body frame (bench/pictures/filmstrip.py).
``--turning DEG_PER_S``: the action's clips bent along an arc of that rate
(:func:`bench.evaluation.turning.turning_library`: ../shared holds no turning walk), and a
second PNG (``_paths``) with the hips' paths seen from above (:func:`top_view`).
Models are cached under ``$MSE_CACHE_DIR``.
"""

from __future__ import annotations

import argparse
import os
import warnings
from pathlib import Path

import numpy as np

from bench.evaluation.turning import TURN_ACTION, turning_library
from bench.pictures.filmstrip import filmstrip, top_view
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.base.starter import starter_library
from mse.motion.generator import GenerationRequest, generator_for

CASES = (
    ("bandai-ds1", "bow", "angry", 7),
    ("bandai-ds1", "guide", "chimpira", 7),
    ("bandai-ds2", "wave-both-hands", "elderly", 8),
    ("bandai-ds2", "walk", "active", 8),
    ("bandai-ds2", "raise-up-both-hands", "exhausted", 6),
    ("starter", "hand_on_mouth", "not-confident", 6),
    ("starter", "bow", "normal", 6),
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="docs/images")
    parser.add_argument("--shared", default=os.environ.get("MSE_SHARED", "../shared"))
    parser.add_argument("--max-seconds", type=float, default=4.0, help="clips are cut to this length")
    parser.add_argument("--factor", type=float, default=1.0, help="generated clips last this many real lengths")
    parser.add_argument("--case", action="append", default=[], metavar="LIBRARY:ACTION:STYLE:FRAMES")
    parser.add_argument("--turning", type=float, default=0.0, metavar="DEG_PER_S", help="bend the clips (see above)")
    args = parser.parse_args()
    cases = [(n, a, s, int(f)) for n, a, s, f in (c.split(":") for c in args.case)] if args.case else CASES
    warnings.simplefilter("ignore")
    cache = os.environ.get("MSE_CACHE_DIR", ".cache-mse")
    libraries: dict[str, MotionLibrary] = {}
    for name, action, style, frames in cases:
        if name not in libraries:
            folder = Path(args.shared) / "motion" / name
            libraries[name] = starter_library() if name == "starter" else load_library(folder)
        library = libraries[name]
        if args.turning:
            library = turning_library(library, action, float(np.radians(args.turning)))
            name, action = f"{name}_turning", TURN_ACTION
        real = library.motion(sorted(library.select(action, style), key=lambda c: c.id)[0])
        rows = [(f"real {style}", real)]
        for method in ("lma-hmm", "hsmm"):
            request = GenerationRequest(action, style, args.factor * real.duration)
            motion = generator_for(method, cache).generate(library, request)
            rows.append((f"{method} {style}" + (f" x{args.factor:g}" if args.factor != 1.0 else ""), motion))
        cut = [(label, m.slice(0, min(m.frame_count, round(args.max_seconds / m.frame_time)))) for label, m in rows]
        times = f"_x{args.factor:g}" if args.factor != 1.0 else ""
        path = Path(args.out) / f"motion_{name}_{action}_{style}{times}.png"
        filmstrip(cut, path, frames=frames)
        print(path)
        if args.turning:
            top_view(rows, path.with_name(path.stem + "_paths.png"))
            print(path.with_name(path.stem + "_paths.png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
