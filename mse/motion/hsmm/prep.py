"""From BVH clips to aligned static feature sequences, and back (paper §4).

* The *root joint* is the branching joint whose position channels move most (Bandai:
  ``Hips``; CMU: the BVH root).  Its position is dropped and recomputed at synthesis time; its ancestors are
  assumed static (Bandai's ``joint_Root`` is, but for a few seconds of one take).
* Directions are aligned: each clip is turned about the vertical (Y) axis so that its mean
  heading (forward = up × the vector between the two leg roots) points along +Z; turning
  locomotion (``Template.turning``) is turned frame by frame by the heading of its path
  (:func:`mse.motion.base.heading.smoothed_yaws`), so that its steps are steps of a straight
  walk and the turn is a rate of its own (``synth``).
* Every joint with rotation channels is a feature: the exponential map of its local
  rotation relative to a reference rotation (the chordal mean over the training clips),
  three values per joint.
* The two legs are the root's children whose subtrees reach lowest; the last two joints of
  each leg (foot and toes) are the contact points used for steps and root translation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mse.motion.base.bvh import Motion, Skeleton
from mse.motion.base.contacts import find_root_joint
from mse.motion.base.heading import smoothed_yaws
from mse.motion.base.kinematics import forward_kinematics
from mse.motion.hsmm.features import (
    FloatArray,
    continuous_expmaps,
    expmap_from_matrix,
    matrix_from_expmap,
    mean_rotation,
    quaternion_from_matrix,
    yaw_matrix,
)


@dataclass(frozen=True, eq=False)
class Template:
    """Everything about the skeleton that synthesis needs besides the features."""

    skeleton: Skeleton
    frame_time: float
    translations: FloatArray  # (J, 3) per-joint translation (median over the reference clip)
    root_joint: int
    rotated: tuple[int, ...]  # joints whose rotations are features, in feature order
    references: FloatArray  # (len(rotated), 3, 3) reference rotations
    legs: tuple[int, int]  # the two leg roots (children of the root joint)
    contacts: tuple[tuple[int, ...], tuple[int, ...]]  # contact joints of each leg
    contact_height: float  # typical height of the lowest contact point above the floor
    #: the root joint's features are swing-twist (:func:`twist_features`), not an exp map
    twisted_root: bool = False
    #: how far the training clips lift one foot over the other (:func:`feet_lift`, median
    #: over the clips, share of the leg length): standing actions whose real legs act (a
    #: kick, a punch's step) are not stilled at synthesis (``synth.still_legs``)
    feet_lift: float = 0.0
    #: turning locomotion (:func:`mse.motion.base.heading.turning_rate`): clips are aligned
    #: frame by frame to their path's heading, and synthesis turns the root at the model's
    #: ``info["turn_rate"]``. Aligned to their mean heading alone, a turning walk's steps
    #: faced anywhere from -50 to +50 deg, each unit's states averaged them, and the
    #: generated walk turned only in its first and last steps
    turning: bool = False

    @property
    def feature_count(self) -> int:
        return 3 * len(self.rotated)


def _subtree(skeleton: Skeleton, joint: int) -> list[int]:
    out = [joint]
    for child in skeleton.children(joint):
        out.extend(_subtree(skeleton, child))
    return out


def _chain_end(skeleton: Skeleton, joint: int) -> list[int]:
    """The joints from ``joint`` down its first-child chain to the leaf."""
    chain = [joint]
    while skeleton.children(chain[-1]):
        chain.append(skeleton.children(chain[-1])[0])
    return chain


def find_legs(
    skeleton: Skeleton, root: int, positions: FloatArray
) -> tuple[tuple[int, int], tuple[tuple[int, ...], tuple[int, ...]]]:
    """The two leg roots and their contact joints (last two joints of each leg chain)."""
    children = list(skeleton.children(root))
    if len(children) < 2:
        raise ValueError("the root joint needs two legs among its children")
    lowest = {
        c: float(np.min(np.mean(positions[:, _subtree(skeleton, c), 1], axis=0))) for c in children
    }
    legs = sorted(sorted(children, key=lambda c: lowest[c])[:2])
    contacts = []
    for leg in legs:
        chain = _chain_end(skeleton, leg)
        contacts.append(tuple(chain[-2:]) if len(chain) >= 2 else tuple(chain))
    return (legs[0], legs[1]), (contacts[0], contacts[1])


def _ancestor_rotation(motion: Motion, root: int) -> FloatArray:
    """World rotation of the root joint's parent at frame 0 (assumed constant)."""
    parent = motion.skeleton.parents[root]
    if parent < 0:
        return np.eye(3)
    _, rotations = forward_kinematics(
        motion.skeleton.parents, motion.translations()[:1], motion.local_rotations()[:1]
    )
    result: FloatArray = rotations[0, parent]
    return result


def headings(positions: FloatArray, legs: tuple[int, int]) -> FloatArray:
    """Per-frame yaw (radians) of forward = (leg a − leg b) × up, measured from +Z.

    With leg a on the left of a Y-up, right-handed body this is the facing direction.
    """
    lateral = positions[:, legs[0]] - positions[:, legs[1]]
    forward_x, forward_z = -lateral[:, 2], lateral[:, 0]
    result: FloatArray = np.arctan2(forward_x, forward_z)
    return result


def alignment_yaws(positions: FloatArray, template: Template) -> FloatArray:
    """(T,) the yaw each frame of a clip is turned back by: the clip's mean heading, or for
    turning locomotion its path's heading frame by frame."""
    yaw = headings(positions, template.legs)
    if template.turning:
        return smoothed_yaws(np.unwrap(yaw), template.frame_time)
    mean_yaw = float(np.arctan2(np.mean(np.sin(yaw)), np.mean(np.cos(yaw))))
    return np.full(yaw.shape, mean_yaw)


def aligned_rotations(motion: Motion, template: Template) -> FloatArray:
    """(T, J, 3, 3) local rotations with the clip turned to face +Z on average (turning
    locomotion: frame by frame, :func:`alignment_yaws`)."""
    local = motion.local_rotations()
    positions = motion.positions()
    ancestors = _ancestor_rotation(motion, template.root_joint)
    if template.turning:
        turns = ancestors.T[None] @ yaw_matrix(-alignment_yaws(positions, template)) @ ancestors[None]
        local[:, template.root_joint] = turns @ local[:, template.root_joint]
        return local
    yaw = headings(positions, template.legs)
    mean_yaw = float(np.arctan2(np.mean(np.sin(yaw)), np.mean(np.cos(yaw))))
    turn = ancestors.T @ yaw_matrix(np.array(-mean_yaw)) @ ancestors
    local[:, template.root_joint] = turn @ local[:, template.root_joint]
    return local


def build_template(motions: list[Motion], turning: bool = False) -> Template:
    """The template of a training set: skeleton of the first clip, references from all
    (``turning``: aligned frame by frame, see :attr:`Template.turning`)."""
    first = motions[0]
    skeleton = first.skeleton
    root = find_root_joint(first)
    positions = first.positions()
    legs, contacts = find_legs(skeleton, root, positions)
    rotated = tuple(j for j in range(skeleton.joint_count) if len(skeleton.rotation_order(j)) == 3)
    contact_joints = list(contacts[0] + contacts[1])
    clip_positions = [m.positions() for m in motions]
    heights = [float(np.median(np.min(p[:, contact_joints, 1], axis=1))) for p in clip_positions]
    provisional = Template(
        skeleton=skeleton,
        frame_time=first.frame_time,
        translations=np.median(first.translations(), axis=0),
        root_joint=root,
        rotated=rotated,
        references=np.broadcast_to(np.eye(3), (len(rotated), 3, 3)).copy(),
        legs=legs,
        contacts=contacts,
        contact_height=float(np.median(heights)),
        turning=turning,
    )
    stacked = np.concatenate([aligned_rotations(m, provisional)[:, list(rotated)] for m in motions])
    references = np.stack([mean_rotation(stacked[:, k]) for k in range(len(rotated))])
    lifts = [feet_lift(p, provisional) for p in clip_positions]
    return Template(
        skeleton=provisional.skeleton,
        frame_time=provisional.frame_time,
        translations=provisional.translations,
        root_joint=root,
        rotated=rotated,
        references=references,
        legs=legs,
        contacts=contacts,
        contact_height=provisional.contact_height,
        feet_lift=float(np.median(lifts)),
        turning=turning,
    )


def feet_lift(positions: FloatArray, template: Template) -> float:
    """95th percentile over frames of the height of one foot's lowest point over the
    other's, as a share of the leg length (``positions``: (T, J, 3))."""
    lows = [positions[:, list(points), 1].min(axis=1) for points in template.contacts]
    hip = positions[:, template.legs[0]]
    foot = positions[:, template.contacts[0][0]]
    leg = float(np.median(np.linalg.norm(hip - foot, axis=-1)))
    return float(np.percentile(np.abs(lows[0] - lows[1]), 95)) / max(leg, 1e-9)


def _axis_rotation(axis: FloatArray, angles: FloatArray) -> FloatArray:
    """(T, 3, 3) rotations by ``angles`` about the unit ``axis``."""
    return matrix_from_expmap(np.asarray(angles, dtype=np.float64)[:, None] * axis[None, :])


def twist_features(relative: FloatArray, up: FloatArray) -> FloatArray:
    """(T, 3, 3) rotations to (T, 3) swing-twist features: ``relative = twist(yaw about up)
    @ swing``, the swing an exponential map perpendicular to ``up`` and the yaw, unwrapped
    along time (it may exceed π), put in its place along ``up``.

    The exponential map is singular at 2π: a performer who spins a full turn (Bandai's kick
    and dance-short) sends the root's map through that shell, where its direction changes in
    a few frames, and the state means cut the corner (the generated body tipped over for ~7
    frames). The yaw as a scalar has no such shell."""
    quats = quaternion_from_matrix(relative)
    yaw = np.unwrap(2.0 * np.arctan2(quats[:, 1:] @ up, quats[:, 0]))
    swing = np.swapaxes(_axis_rotation(up, yaw), -1, -2) @ relative
    features = expmap_from_matrix(swing)
    features += (yaw - features @ up)[:, None] * up[None, :]
    result: FloatArray = features
    return result


def twist_matrices(features: FloatArray, up: FloatArray) -> FloatArray:
    """Inverse of :func:`twist_features`."""
    yaw = features @ up
    swing = features - yaw[:, None] * up[None, :]
    result: FloatArray = _axis_rotation(up, yaw) @ matrix_from_expmap(swing)
    return result


def _root_up(template: Template) -> tuple[int, FloatArray] | None:
    """The root joint's feature index and the vertical in its reference frame, when the
    template models the root as swing-twist."""
    if not template.twisted_root or template.root_joint not in template.rotated:
        return None
    k = template.rotated.index(template.root_joint)
    up: FloatArray = template.references[k].T @ np.array([0.0, 1.0, 0.0])
    return k, up / np.linalg.norm(up)


def facing_as(pose: FloatArray, other: FloatArray, template: Template) -> FloatArray:
    """``pose`` (D,) static features with the root joint's yaw about the vertical taken from
    ``other`` (D,), when the template models the root as swing-twist (its swing, the lean or
    the bow, stays ``pose``'s); otherwise ``pose``."""
    root = _root_up(template)
    if root is None:
        return pose
    k, up = root
    columns = slice(3 * k, 3 * k + 3)
    result = pose.copy()
    result[columns] += (float(other[columns] @ up) - float(pose[columns] @ up)) * up
    return result


def static_features(motion: Motion, template: Template) -> FloatArray:
    """(T, 3·joints) exponential maps of the aligned rotations relative to the references
    (the root joint's as swing-twist when ``template.twisted_root``)."""
    if not motion.skeleton.same_layout(template.skeleton):
        raise ValueError("the clip's skeleton differs from the model's")
    local = aligned_rotations(motion, template)[:, list(template.rotated)]
    relative = np.swapaxes(template.references, -1, -2)[None] @ local
    features = continuous_expmaps(relative)
    root = _root_up(template)
    if root is not None:
        features[:, root[0]] = twist_features(relative[:, root[0]], root[1])
    return features.reshape(local.shape[0], -1)


def local_rotations_from_features(statics: FloatArray, template: Template) -> FloatArray:
    """(T, J, 3, 3) local rotations from static features (identity for unrotated joints)."""
    frames = statics.shape[0]
    rotations = np.broadcast_to(np.eye(3), (frames, template.skeleton.joint_count, 3, 3)).copy()
    per_joint = statics.reshape(frames, len(template.rotated), 3)
    relative = matrix_from_expmap(per_joint)
    root = _root_up(template)
    if root is not None:
        relative[:, root[0]] = twist_matrices(per_joint[:, root[0]], root[1])
    rotations[:, list(template.rotated)] = template.references[None] @ relative
    return rotations


def pose_positions(statics: FloatArray, template: Template) -> FloatArray:
    """(T, J, 3) world positions with the root joint's translation held at the template's."""
    frames = statics.shape[0]
    translations = np.broadcast_to(template.translations, (frames, *template.translations.shape))
    positions, _ = forward_kinematics(
        template.skeleton.parents,
        translations.copy(),
        local_rotations_from_features(statics, template),
    )
    return positions
