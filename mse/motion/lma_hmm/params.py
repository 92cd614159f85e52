"""The LMA + HMM method's parameters (docs/motion.md, "Generation"): the options a user sets,
each deviation from the paper a field with the paper's choice one value away. Modes are
typed (``Literal``); a value outside its type is refused."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Literal, get_args, get_type_hints

from mse.motion.lma_hmm.hmm import Topology
from mse.motion.lma_hmm.search import EPSILON_FRACTION
from mse.motion.lma_hmm.stride import Stride

__all__ = ["GenerationParams", "Regenerate", "Timing", "Velocity"]

#: "means": the paper's sequence of state means; "frames": the neighbours' own frames of each
#: state in the desired path's state order and timing (keeps within-state motion)
Regenerate = Literal["means", "frames"]
#: "neighbours": each state run of the desired path lasts as the neighbours' runs of that state
#: (:func:`~mse.motion.lma_hmm.timing.retimed`: the target style's tempo); "desired": the
#: desired path's own Viterbi timing (the paper's)
Timing = Literal["neighbours", "desired"]
#: when the phase space also holds the movement's velocity (see ``GenerationParams.velocity``)
Velocity = Literal["standing", "always", "never"]


@dataclass(frozen=True, slots=True)
class GenerationParams:
    states: int = 12
    nd: int = 0
    epsilon_fraction: float = EPSILON_FRACTION
    cutoff_hz: float = 3.0
    n_iter: int = 10
    regenerate: Regenerate = "means"
    #: HMM topology: "auto" (fully connected when the neighbours cycle, else left-to-right),
    #: "full" (the paper's), "left-to-right"
    topology: Topology = "auto"
    #: the ε-neighbourhood is widened to the nearest ``min_neighbours`` and cut to the nearest
    #: ``max_neighbours`` (the HMM's cost grows with them)
    min_neighbours: int = 8
    max_neighbours: int = 8
    timing: Timing = "neighbours"
    #: when the HMM is fully connected (the neighbours cycle), the phase space also holds the
    #: movement's velocity (:func:`~mse.motion.lma_hmm.pose.with_velocity`) and the HMM is
    #: fitted again, and a run where the desired path's decoding sat in one state is played
    #: by the neighbours' own sequence (``retimed(refill_stuck=True)``): "standing" (default)
    #: when the neighbours stand (waves), "always", "never" (the paper's positions only).
    #: With positions only, waves decoded against slower styles turned back in the middle of
    #: the swing: Samadani fold 1 wave jerk over 2x real in 8 of 42 conversions, 0 with it
    velocity: Velocity = "standing"
    #: weight of the velocity against the positions in the phase space
    velocity_weight: float = 0.3
    #: travelling neighbours (``stride.travels``): the state means' swing widened, joint by joint,
    #: to the neighbours' own (:mod:`mse.motion.lma_hmm.stride`): "legs", "all", "off" (the paper's)
    stride: Stride = "legs"

    def __post_init__(self) -> None:
        hints = get_type_hints(GenerationParams)
        for field in fields(self):
            allowed = get_args(hints[field.name])
            value = getattr(self, field.name)
            if allowed and value not in allowed:
                raise ValueError(f"{field.name} must be one of {', '.join(map(str, allowed))}, not {value!r}")
