"""``animate``: motion for every motion-leaf occurrence of a timeline.

``animate(timeline, model, out_dir, library=None)`` writes into ``out_dir``:

- one BVH per motion occurrence, ``<signal>_<start ms>.bvh``, lasting exactly the
  occurrence's scheduled duration (frame count ``round(duration / frame_time)``, frame time
  adjusted);
- ``timeline.bvh``: the whole timeline on one body, the overlapping tracks composed by body
  part with blends at their edges (:mod:`mse.motion.base.compose`). Its skeleton is the one
  most generated clips use; clips on another skeleton with the same joint names (starter
  fallbacks next to Bandai clips) are retargeted onto it (:mod:`mse.motion.base.retarget`),
  clips on unrelated skeletons are left out with a warning. The rest pose is the starter's
  for the starter skeleton, else the first frame of the first clip;
- ``lma.json``: the LMA Effort/Shape components of each generated clip, by file name;

and returns the timeline with ``"motion": {"action", "emotion", "style", "method", "file"}``
on those signals (``emotion`` is the expression's, ``style`` the library label it mapped to,
``method`` the one that made the clip).

Clips come from :func:`mse.motion.generator.generator_for` (the leaf's ``method``: lma-hmm
or hsmm), with trained models and paths cached on disk (``cache_dir``; default the user
cache). The emotion of the expression (``timeline.expression``, else ``model.name``; a leaf's
own ``emotion`` attribute wins) maps to a style through
:data:`mse.motion.base.library.EMOTION_STYLES`, overridden by the library index and then by
``emotion_styles``. Fallbacks, each with a :class:`MotionWarning` naming the action: an hsmm
leaf the HSMM method cannot serve goes to lma-hmm; an action (or style) the library lacks
goes to the starter library. Warnings go through :mod:`warnings` so that front-ends decide
how to show them.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mse import progress
from mse.diagnostics import Span
from mse.fileio import write_atomic
from mse.ir.model import Model, MotionLeaf
from mse.motion.base.bvh import Motion, write_bvh
from mse.motion.base.compose import Track, compose
from mse.motion.base.library import MotionLibrary, MotionUnavailable
from mse.motion.base.lma import lma_features
from mse.motion.base.retarget import retarget
from mse.motion.base.starter import STYLE_EFFORT, rest_motion, starter_library, unknown_action_error
from mse.motion.generator import GenerationRequest, generator_for
from mse.timeline import Timeline, TimelineSignal

TIMELINE_BVH = "timeline.bvh"
LMA_JSON = "lma.json"


class MotionWarning(UserWarning):
    """A motion leaf was served by a fallback (starter library, another style)."""


def _where(leaf: MotionLeaf) -> str:
    span: Span = leaf.span
    return "" if span.path == "<none>" else f"{span.render()}: "


@dataclass
class _Leaves:
    """Generation of the leaves of one call: generators, warnings already given."""

    library: MotionLibrary
    cache_dir: str | os.PathLike[str] | None
    warned: set[str] = field(default_factory=set)

    def warn(self, key: str, message: str) -> None:
        if key not in self.warned:  # once per call
            self.warned.add(key)
            warnings.warn(MotionWarning(message), stacklevel=4)

    def generate(self, leaf: MotionLeaf, style: str, duration: float, seed: int) -> tuple[Motion, str, str, str]:
        """(motion, library name used, style used, method used) for one occurrence."""
        library = self.library
        clip = leaf.clip if leaf.clip and library.clip(leaf.clip) else None
        if leaf.clip and clip is None and library is not starter_library():
            message = f"{_where(leaf)}clip {leaf.clip!r} is not in {library.name!r}; using the default"
            self.warn(f"clip:{leaf.clip}", message)
        action = library.action_named(leaf.action)
        request = GenerationRequest(action, style, duration, clip, leaf.states, leaf.nd, seed)
        methods = [leaf.method] + (["lma-hmm"] if leaf.method != "lma-hmm" else [])
        for method in methods:
            try:
                motion = generator_for(method, self.cache_dir).generate(library, request)
                return motion, library.name, style, method
            except MotionUnavailable as reason:
                if method != "lma-hmm":
                    self.warn(
                        f"{method}:{leaf.action}",
                        f"{_where(leaf)}the {method} method cannot serve {leaf.action!r} ({reason}); using lma-hmm",
                    )
                elif library is not starter_library():
                    self.warn(
                        leaf.action,
                        f"{_where(leaf)}motion library {library.name!r} lacks action {leaf.action!r} "
                        f"({reason}); using the starter library",
                    )
        starter = starter_library()
        if not starter.select(leaf.action):
            raise unknown_action_error(leaf.action, leaf.span)
        if style not in STYLE_EFFORT:
            self.warn(f"style:{style}", f"the starter library has no style {style!r}; using 'normal'")
            style = "normal"
        request = GenerationRequest(leaf.action, style, duration, None, leaf.states, leaf.nd, seed)
        motion = generator_for("lma-hmm", self.cache_dir).generate(starter, request)
        return motion, starter.name, style, "lma-hmm"


def animate(
    timeline: Timeline,
    model: Model,
    out_dir: str | os.PathLike[str],
    library: MotionLibrary | None = None,
    *,
    emotion_styles: Mapping[str, str] | None = None,
    cache_dir: str | os.PathLike[str] | None = "default",
) -> Timeline:
    """Generate and write the motion of every motion-leaf occurrence (module docstring);
    ``cache_dir``: see :func:`mse.motion.generator.generator_for`."""
    _check_limits(timeline, model)
    library = library or starter_library()
    leaves = _Leaves(library, cache_dir)
    out = Path(out_dir)
    emotion = timeline.expression or model.name
    style = library.style_for(emotion, emotion_styles)
    signals: list[TimelineSignal] = []
    tracks: list[Track] = []
    features: dict[str, Any] = {}
    for entry in progress.each(timeline.signals, "animate", unit="signal"):
        declared = model.signal_by_id.get(entry.id)
        leaf = declared.motion if declared is not None else None
        if leaf is None or entry.stop <= entry.start:
            signals.append(entry)
            continue
        duration = entry.stop - entry.start
        leaf_emotion = leaf.attributes.get("emotion") or emotion  # a leaf may set its own
        leaf_style = library.style_for(leaf_emotion, emotion_styles) if leaf_emotion != emotion else style
        motion, used_library, used_style, method = leaves.generate(leaf, leaf_style, duration, len(tracks))
        name = f"{entry.id}_{round(entry.start * 1000)}ms.bvh"
        write_bvh(out / name, motion)
        features[name] = {
            "signal": entry.id,
            "action": leaf.action,
            "style": used_style,
            "method": method,
            "library": used_library,
            "start": round(entry.start, 3),
            "stop": round(entry.stop, 3),
            **lma_features(motion, path=name).to_json(),
        }
        tracks.append(Track(entry.start, motion))
        annotation = dict(entry.motion or {})
        annotation.update(action=leaf.action, emotion=leaf_emotion, style=used_style, method=method, file=name)
        signals.append(TimelineSignal(entry.id, entry.modality, entry.lexeme, entry.start, entry.stop, annotation))
    _write_timeline_bvh(out, timeline.duration, tracks)
    write_atomic(out / LMA_JSON, json.dumps(features, indent=2) + "\n")
    extra = dict(timeline.extra)
    extra["animation"] = {
        "library": library.name,
        "style": style,
        "timeline_bvh": TIMELINE_BVH,
        "lma": LMA_JSON,
    }
    return Timeline(
        timeline.expression,
        timeline.duration,
        tuple(signals),
        timeline.solver,
        timeline.seed,
        extra,
    )


def _check_limits(timeline: Timeline, model: Model) -> None:
    """Refuse, before generating anything, a timeline or an occurrence too long to animate
    (docs/security.md: memory and time grow with the frames)."""
    from mse.diagnostics import Diagnostic, MseError
    from mse.limits import MAX_ANIMATE_SECONDS, MAX_MOTION_SECONDS

    if not timeline.duration <= MAX_ANIMATE_SECONDS:
        message = f"a timeline of {timeline.duration:g} s is too long to animate (at most {MAX_ANIMATE_SECONDS:g} s)"
        raise MseError([Diagnostic("E215", message, Span("<timeline>"))])
    total = 0.0
    for entry in progress.each(timeline.signals, "animate", unit="signal"):
        declared = model.signal_by_id.get(entry.id)
        if declared is None or declared.motion is None:
            continue
        total += max(entry.stop - entry.start, 0.0)
        if entry.stop - entry.start > MAX_MOTION_SECONDS or total > MAX_ANIMATE_SECONDS:
            message = (
                f"occurrence of {entry.id!r} at {entry.start:g} s lasts {entry.stop - entry.start:g} s; "
                f"a motion occurrence lasts at most {MAX_MOTION_SECONDS:g} s, and all of a "
                f"timeline's together at most {MAX_ANIMATE_SECONDS:g} s"
            )
            raise MseError([Diagnostic("E215", message, declared.motion.span)])


def _rest_of(motion: Motion) -> Motion:
    """The rest pose of a clip's skeleton: the starter's zero pose, else the first frame."""
    if motion.skeleton.names == rest_motion(1).skeleton.names:
        return rest_motion(1, motion.skeleton)
    return motion.slice(0, 1)


def _write_timeline_bvh(out: Path, duration: float, tracks: list[Track]) -> None:
    if tracks:
        # the skeleton that carries the most tracks (the first of them on ties)
        counts = [sum(t.motion.skeleton.same_layout(u.motion.skeleton) for u in tracks) for t in tracks]
        skeleton = tracks[counts.index(max(counts))].motion.skeleton
        rest = _rest_of(next(t for t in tracks if t.motion.skeleton.same_layout(skeleton)).motion)
    else:
        rest = rest_motion(1)
    usable = []
    for track in tracks:
        if track.motion.skeleton.same_layout(rest.skeleton):
            usable.append(track)
            continue
        # another skeleton (a starter fallback next to library clips): the same body if the
        # joint names match
        moved = retarget(track.motion, _rest_of(track.motion), rest)
        if moved is not None:
            usable.append(Track(track.start, moved))
    if len(usable) < len(tracks):
        warnings.warn(
            MotionWarning(f"{len(tracks) - len(usable)} clip(s) on an unrelated skeleton left out of {TIMELINE_BVH}"),
            stacklevel=3,
        )
    write_bvh(out / TIMELINE_BVH, compose(rest, usable, duration))
