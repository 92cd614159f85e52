"""The LMA + HMM method's parameters (docs/motion.md, "Generation"): each deviation from the
paper is a field here, with the paper's choice one value away."""

from __future__ import annotations

from dataclasses import dataclass

from mse.motion.lma_hmm.hmm import TOPOLOGIES
from mse.motion.lma_hmm.search import EPSILON_FRACTION
from mse.motion.lma_hmm.standing import ARM_SPREAD_CAP, CYCLE_VELOCITY_WEIGHT
from mse.motion.lma_hmm.stride import STRIDE_CHOICES

__all__ = ["VELOCITY_CHOICES", "GenerationParams"]


VELOCITY_CHOICES = ("standing", "always", "never")


@dataclass(frozen=True, slots=True)
class GenerationParams:
    states: int = 12
    nd: int = 0
    epsilon_fraction: float = EPSILON_FRACTION
    cutoff_hz: float = 3.0
    n_iter: int = 10
    #: "means": the paper's sequence of state means; "frames": the neighbours' own frames of
    #: each state in the desired path's state order and timing (keeps within-state motion)
    regenerate: str = "means"
    #: HMM topology: "auto" (fully connected when the neighbours cycle, else left-to-right),
    #: "full" (the paper's), "left-to-right"
    topology: str = "auto"
    #: the ε-neighbourhood is widened to the nearest ``min_neighbours`` and cut to the nearest
    #: ``max_neighbours`` (the HMM's cost grows with them)
    min_neighbours: int = 8
    max_neighbours: int = 8
    #: "neighbours": each state run of the desired path lasts as the neighbours' runs of that
    #: state (:func:`~mse.motion.lma_hmm.timing.retimed`: the target style's tempo); "desired":
    #: the desired path's own Viterbi timing (the paper's)
    timing: str = "neighbours"
    #: legs of a clip whose neighbours stand still low-passed at this cut-off (0: off, the
    #: default: at 0.5 Hz the feminine wave's free foot stopped sliding, 1.07 -> 0.23 cm/s,
    #: but active waves lost their legs' rhythm and were all rated youthful, fold 1)
    standing_legs_hz: float = 0.0
    #: when the HMM is fully connected (the neighbours cycle), the phase space also holds the
    #: movement's velocity (:func:`~mse.motion.lma_hmm.pose.with_velocity`) and the HMM is
    #: fitted again, and a run where the desired path's decoding sat in one state is played
    #: by the neighbours' own sequence (``retimed(refill_stuck=True)``): "standing" (default)
    #: when the neighbours stand (waves), "always", "never" (the paper's positions only).
    #: With positions only, waves decoded against slower styles turned back in the middle of
    #: the swing: Samadani fold 1 wave jerk over 2x real in 8 of 42 conversions, 0 with it
    velocity: str = "standing"
    #: weight of the velocity against the positions in the phase space
    velocity_weight: float = 0.3
    #: a standing body (the neighbours' carried root speed under 0.1 leg lengths per second)
    #: pins whichever foot point is lowest, without the walks' stance hysteresis
    standing_pin: bool = True
    #: travelling neighbours (``stride.travels``): the state means' swing widened, joint by joint,
    #: to the neighbours' own (:mod:`mse.motion.lma_hmm.stride`): "legs", "all", "off"
    stride: str = "legs"
    #: travelling neighbours that cycle: a change of state they never make in the desired
    #: path's decoding goes through the states by which they do (``timing.retimed(bridge=True)``),
    #: and a path shorter than the clip is continued, not stretched (``modulated.path_for``)
    travel_cycles: bool = True
    #: a standing body's arm rotations widened towards the neighbours' spread, by at most this
    #: factor (:func:`~mse.motion.lma_hmm.standing.arm_variance`; 1: off, the method before)
    arm_spread_cap: float = ARM_SPREAD_CAP
    #: a standing body's neighbours share one leg posture before the state means are taken
    #: (:func:`~mse.motion.lma_hmm.standing.shared_stance`; False: the method before). Samadani
    #: waves over ten folds: feminine targets rated youthful for their free foot's slide, 13
    #: of 60 before, none with it (docs/motion.md, "Samadani")
    shared_stance: bool = True
    #: a standing body whose neighbours do not cycle by their positions is judged again with
    #: their velocity at this weight, and when they cycle so, fitted fully connected on it
    #: (:func:`~mse.motion.lma_hmm.standing.cycles_by_velocity`: slow, small feminine waves;
    #: 0: off, the method before)
    cycle_velocity_weight: float = CYCLE_VELOCITY_WEIGHT

    def __post_init__(self) -> None:
        if self.regenerate not in ("means", "frames"):
            raise ValueError(f"regenerate must be 'means' or 'frames', not {self.regenerate!r}")
        if self.timing not in ("neighbours", "desired"):
            raise ValueError(f"timing must be 'neighbours' or 'desired', not {self.timing!r}")
        if self.velocity not in VELOCITY_CHOICES:
            raise ValueError(f"velocity must be one of {', '.join(VELOCITY_CHOICES)}, not {self.velocity!r}")
        if self.stride not in STRIDE_CHOICES:
            raise ValueError(f"stride must be one of {', '.join(STRIDE_CHOICES)}, not {self.stride!r}")
        if not self.arm_spread_cap >= 1.0:
            raise ValueError(f"arm_spread_cap must be at least 1 (1: off), not {self.arm_spread_cap!r}")
        if not self.cycle_velocity_weight >= 0.0:
            raise ValueError(f"cycle_velocity_weight must be at least 0 (0: off), not {self.cycle_velocity_weight!r}")
        if self.topology not in TOPOLOGIES:
            raise ValueError(f"topology must be one of {', '.join(TOPOLOGIES)}, not {self.topology!r}")
