"""Steps 1-4 of the LMA + HMM method (docs/motion.md, "Generation"): the desired path, the
RMLR saliency on LMA features and the target style's nearest neighbours."""

from __future__ import annotations

import time

from mse.diagnostics import Diagnostic, MseError, Span
from mse.motion.base import cache
from mse.motion.base.bvh import Motion
from mse.motion.base.heading import heading, straightened, turned
from mse.motion.base.kinematics import FloatArray
from mse.motion.base.library import Clip, MotionLibrary, MotionUnavailable
from mse.motion.base.lma import FEATURE_NAMES
from mse.motion.lma_hmm.params import GenerationParams
from mse.motion.lma_hmm.pose import pose_features
from mse.motion.lma_hmm.search import clip_features, feature_table, nearest_neighbours, saliency_for


def pick_desired(library: MotionLibrary, action: str, clip_id: str | None) -> Clip:
    if clip_id is not None:
        clip = library.clip(clip_id)
        if clip is None:
            raise MseError([Diagnostic("E213", f"clip {clip_id!r} is not in the library", Span("<motion>"))])
        return clip
    clips = library.select(action)
    normal = [c for c in clips if c.style == "normal"]
    return (normal or clips)[0]


def rmlr_clips(library: MotionLibrary, action: str, exclude: set[str]) -> list[Clip]:
    """The action's clips when every style there has two or more, else the whole library."""
    own = [c for c in library.select(action) if c.id not in exclude]
    styles = [c.style for c in own]
    if len(set(styles)) >= 2 and min(styles.count(s) for s in set(styles)) >= 2:
        return own
    return [c for c in library.clips if c.id not in exclude]


def clip_motion(library: MotionLibrary, clip: Clip, turning: bool = False) -> Motion:
    """The clip; of turning locomotion, :func:`~mse.motion.base.heading.straightened` (its
    steps those of a straight walk: the heading is turned back frame by frame, cached)."""
    if not turning:
        return library.motion(clip)
    return cache.remembered(
        ("straightened", library.content_hash, clip.id), lambda: straightened(library.motion(clip))
    )


def facing_motion(library: MotionLibrary, clip: Clip, facing: float, turning: bool = False) -> Motion:
    motion = clip_motion(library, clip, turning)
    return turned(motion, facing - heading(motion))


def pose_of(library: MotionLibrary, clip: Clip, turning: bool = False) -> FloatArray:
    """:func:`~mse.motion.lma_hmm.pose.pose_features` of :func:`clip_motion` (cached): the
    body frame is the first frame's, so a turning clip's poses turned with its path."""
    return cache.remembered(
        ("pose", library.content_hash, clip.id, turning),
        lambda: pose_features(clip_motion(library, clip, turning)),
    )


def find_neighbours(
    library: MotionLibrary,
    action: str,
    style: str,
    desired_clip: Clip,
    original: str | None,
    params: GenerationParams,
    exclude: set[str],
    timings: dict[str, float],
) -> tuple[list[Clip], tuple[str, ...]]:
    clock = time.perf_counter()
    desired = library.motion(desired_clip)
    candidates = [
        c
        for c in library.select(action, style)
        if c.id not in exclude and c.id != desired_clip.id and library.motion(c).skeleton.same_layout(desired.skeleton)
    ]
    if not candidates:
        if desired_clip.style != style:
            raise MotionUnavailable(f"no {style!r} clip of action {action!r}")
        return [desired_clip], ()
    desired_features = clip_features(library, desired_clip)
    candidate_features = feature_table(library, candidates)
    training = rmlr_clips(library, action, exclude)
    feature_table(library, training)
    timings["lma"] = time.perf_counter() - clock

    clock = time.perf_counter()
    saliency = saliency_for(library, training)
    components = saliency.search_components(style, original)
    timings["rmlr"] = time.perf_counter() - clock

    clock = time.perf_counter()
    chosen = nearest_neighbours(
        desired_features,
        candidate_features,
        components,
        saliency,
        params.epsilon_fraction,
        minimum=params.min_neighbours,
        maximum=params.max_neighbours,
    )
    timings["nn_search"] = time.perf_counter() - clock
    return [candidates[i] for i in chosen], tuple(FEATURE_NAMES[i] for i in components)
