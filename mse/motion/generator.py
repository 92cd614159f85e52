"""One interface for the motion methods: what ``animate``, the benches and the CLI call.

``generator_for(method)`` returns a :class:`MotionGenerator` (``"lma-hmm"``: Samadani et al.,
:mod:`mse.motion.lma_hmm`; ``"hsmm"``: Tilmanne et al., :mod:`mse.motion.hsmm`);
``generator.generate(library, request)`` returns a :class:`mse.motion.base.bvh.Motion` that
lasts exactly ``request.duration`` seconds, or raises :class:`MotionUnavailable` when the
library cannot serve the request (no clip of that action or style, a skeleton the method
cannot use), so that callers can fall back. Methods are imported when first used.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Protocol

from mse.diagnostics import MseError
from mse.fileio import user_cache_dir
from mse.motion.base.bvh import Motion
from mse.motion.base.library import MotionLibrary, MotionUnavailable

__all__ = ["METHODS", "GenerationRequest", "MotionGenerator", "MotionUnavailable", "generator_for"]

METHODS = ("lma-hmm", "hsmm")


@dataclass(frozen=True, slots=True)
class GenerationRequest:
    """One clip to generate. ``clip`` (a desired path), ``states`` and ``nd`` are the LMA +
    HMM leaf attributes; ``seed`` varies HSMM durations between repeated leaves."""

    action: str
    style: str
    duration: float
    clip: str | None = None
    states: int = 12
    nd: int = 0
    seed: int = 0


class MotionGenerator(Protocol):
    @property
    def name(self) -> str: ...

    def generate(self, library: MotionLibrary, request: GenerationRequest) -> Motion:
        """A clip of exactly ``request.duration`` seconds; raises MotionUnavailable."""
        ...


@dataclass(frozen=True, slots=True)
class LmaHmmGenerator:
    """Samadani et al.: a desired path modulated by an HMM of target-style neighbours;
    modulated paths are kept in ``cache_dir`` (None: memory only)."""

    cache_dir: str | None = None
    name: str = "lma-hmm"

    def generate(self, library: MotionLibrary, request: GenerationRequest) -> Motion:
        from mse.motion.lma_hmm.generate import GenerationParams, generate_motion

        params = GenerationParams(states=request.states, nd=request.nd)
        result = generate_motion(
            library,
            request.action,
            request.style,
            duration=request.duration,
            clip=request.clip,
            params=params,
            cache_dir=self.cache_dir,
        )
        return result.motion


@dataclass(frozen=True, slots=True)
class HsmmGenerator:
    """Tilmanne et al.: an average HSMM adapted to the style from ``takes`` takes; models
    are kept in ``cache_dir`` (None: memory only)."""

    cache_dir: str | None = None
    takes: int | None = 1
    name: str = "hsmm"

    def generate(self, library: MotionLibrary, request: GenerationRequest) -> Motion:
        from mse.motion.hsmm.leaf import synthesize_leaf

        if not library.select(request.action):
            raise MotionUnavailable(f"no clip of action {request.action!r}")
        folder = self.cache_dir
        try:
            return synthesize_leaf(
                library,
                request.action,
                request.style,
                request.duration,
                seed=request.seed,
                cache_dir=folder,
                takes=self.takes,
            )
        except (MseError, ValueError) as reason:
            raise MotionUnavailable(str(reason)) from None


def generator_for(method: str, cache_dir: str | os.PathLike[str] | None = "default") -> MotionGenerator:
    """The generator of ``method`` (:data:`METHODS`). Trained models and modulated paths are
    kept between runs in ``cache_dir/<method>``; ``"default"``: the user cache
    (``$MSE_CACHE_DIR/<method>``, else ``~/.cache/mse/<method>``); None: memory only."""
    if method not in METHODS:
        raise ValueError(f"unknown motion method {method!r} (one of {', '.join(METHODS)})")
    if cache_dir == "default":
        folder: str | None = os.fspath(user_cache_dir(method))
    else:
        folder = os.path.join(os.fspath(cache_dir), method) if cache_dir is not None else None
    if method == "lma-hmm":
        return LmaHmmGenerator(folder)
    return HsmmGenerator(folder)
