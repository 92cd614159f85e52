"""Library level of the HSMM method: train and adapt from a motion library, and the cached
leaf entry point of ``animate``.

``synthesize_leaf`` chains training, adaptation and synthesis with an in-process and on-disk
cache keyed by the library's content hash, the action, the style and the options.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from mse import progress
from mse.diagnostics import Diagnostic, MseError, Span
from mse.fileio import user_cache_dir
from mse.motion.base import cache
from mse.motion.base.bvh import Motion
from mse.motion.base.library import MotionLibrary, load_library
from mse.motion.hsmm.api import Options, adapt_model, train_average, train_scratch
from mse.motion.hsmm.io import FORMAT, load_model, save_model
from mse.motion.hsmm.model import HsmmModel
from mse.motion.hsmm.synth import synthesize

__all__ = ["adapt_from_library", "default_cache_dir", "synthesize_leaf", "train_from_library"]


def _library(source: str | os.PathLike[str] | MotionLibrary) -> MotionLibrary:
    return source if isinstance(source, MotionLibrary) else load_library(source)


def _where(source: str | os.PathLike[str] | MotionLibrary) -> str:
    return source.name if isinstance(source, MotionLibrary) else os.fspath(source)


def _no_clips(source: str | os.PathLike[str] | MotionLibrary, what: str, has: list[str] | None = None) -> MseError:
    listed = f"; it has: {', '.join(has) or 'none'}" if has is not None else ""
    return MseError([Diagnostic("E213", f"no {what} in the motion library{listed}", Span(_where(source)))])


def _style_takes(
    library: MotionLibrary, where: str | os.PathLike[str] | MotionLibrary, action: str, style: str, takes: int | None
) -> list[Motion]:
    """The first ``takes`` clips (by id; None: all) of ``action`` in ``style``."""
    chosen = sorted(library.select(action=action, style=style), key=lambda c: c.id)
    if not chosen:
        styles = sorted({c.style for c in library.select(action=action)})
        if styles:
            raise _no_clips(where, f"{action!r} clips of style {style!r}", [f"{action} in {', '.join(styles)}"])
        raise _no_clips(where, f"clips of action {action!r}", library.actions())
    if takes is not None:
        chosen = chosen[: max(1, takes)]
    return [library.motion(c) for c in progress.each(chosen, "read clips", unit="clip")]


def train_from_library(
    source: str | os.PathLike[str] | MotionLibrary,
    action: str,
    options: Options = Options(),
    style: str | None = None,
    takes: int | None = None,
) -> HsmmModel:
    """The average model of ``action`` over every style of the library, or with ``style`` a
    model of that style trained on its first ``takes`` clips alone (no average model)."""
    library = _library(source)
    if style is not None:
        motions = _style_takes(library, source, action, style, takes)
        return train_scratch([(m, style) for m in motions], action, options)
    selected = list(library.select(action=action))
    clips = [(library.motion(c), c.style) for c in progress.each(selected, "read clips", unit="clip")]
    if not clips:
        raise _no_clips(source, f"clips of action {action!r}", library.actions())
    return train_average(clips, action, options)


def adapt_from_library(
    average: HsmmModel,
    source: str | os.PathLike[str] | MotionLibrary,
    style: str,
    takes: int | None = 1,
    options: Options = Options(),
) -> HsmmModel:
    library = _library(source)
    motions = _style_takes(library, source, average.action, style, takes)
    return adapt_model(average, motions, style, options)


def default_cache_dir() -> Path:
    return user_cache_dir("hsmm")


def _cached(key: str, cache_dir: Path | None, build: Callable[[], HsmmModel]) -> HsmmModel:
    """The model for ``key`` from memory (:mod:`mse.motion.base.cache`), then disk, else
    ``build()`` (and store it)."""
    return cache.remembered(("hsmm", key), lambda: _from_disk(key, cache_dir, build))


def _from_disk(key: str, cache_dir: Path | None, build: Callable[[], HsmmModel]) -> HsmmModel:
    path = cache.disk_entry(cache_dir, f"{key}.npz")
    model: HsmmModel | None = None
    if path is not None and path.is_file():
        try:
            model = load_model(path)
        except MseError:
            model = None  # a stale or broken cache entry: rebuild it
    if model is None:
        model = build()
        if path is not None:
            # The cache is an optimisation: a read-only disk (E105) must not fail a leaf.
            with contextlib.suppress(OSError, MseError):
                save_model(path, model)
    return model


def synthesize_leaf(
    source: str | os.PathLike[str] | MotionLibrary,
    action: str,
    style: str,
    duration_s: float,
    seed: int | None = None,
    options: Options = Options(),
    cache_dir: str | os.PathLike[str] | None = "default",
    takes: int | None = 1,
) -> Motion:
    """A clip of ``action`` in ``style`` lasting exactly ``duration_s`` seconds.

    It has ``round(duration_s / frame_time)`` frames; the frame time is adjusted (by under
    half a frame over the clip) so that the total is exact, as lma-hmm's time warp does.

    The average model of the action and its adaptation to the style are cached (memory and
    ``cache_dir``; ``None`` disables the disk cache).  A style without clips of the action
    uses the average model.
    """
    library = _library(source)
    directory = default_cache_dir() if cache_dir == "default" else cache_dir
    folder = Path(directory) if directory is not None else None
    settings = hashlib.sha256(f"{FORMAT}|{options!r}".encode()).hexdigest()[:8]
    base_key = f"{library.content_hash}-{action}-{settings}"
    where = Span(_where(source))
    try:
        average = _cached(
            f"{base_key}-average", folder, lambda: train_from_library(library, action, options)
        )
        model = average
        if library.select(action=action, style=style):
            model = _cached(
                f"{base_key}-{style}-{takes}",
                folder,
                lambda: adapt_from_library(average, library, style, takes, options),
            )
        motion = synthesize(model, duration_s=duration_s, seed=seed)
    except ValueError as error:  # e.g. a skeleton without two legs under its root
        message = f"HSMM {action!r} failed: {error}"
        raise MseError([Diagnostic("E213", message, where)]) from None
    if motion.frame_count and duration_s > 0:
        # Like lma-hmm's time warp: the frame time absorbs the rounding to whole frames, so
        # the clip lasts exactly the scheduled duration (the change is under half a frame).
        motion = replace(motion, frame_time=duration_s / motion.frame_count)
    return motion
