"""Bone lengths of a motion against a reference skeleton (conventions:
:mod:`elastic_motion.apps.metrics`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.metrics.feet import metres
from elastic_motion.motion import Motion, Skeleton, forward_kinematics

__all__ = ["BoneLengthError", "bone_length_error"]


@dataclass(frozen=True, eq=False)
class BoneLengthError:
    """Bone lengths of a motion against a reference skeleton (:func:`bone_length_error`).

    Attributes
    ----------
    max_relative : float
        Largest ``| |p_j - p_parent| - L_j | / L_j`` over frames and compared bones.
    max_absolute : float
        Largest ``| |p_j - p_parent| - L_j |`` (m, or length units when unknown).
    worst_joint : str
        Joint (child end of the bone) where ``max_relative`` occurs; ``""`` if none compared.
    n_bones : int
        Bones compared (joints present in both skeletons, with a parent, a rest length
        above 1 % of the reference's median bone and no position channels in either
        skeleton: a file with position channels on every joint, as Bandai's, compares none).
    """

    max_relative: float
    max_absolute: float
    worst_joint: str
    n_bones: int

    def summary(self) -> dict[str, float | str | int]:
        """The fields, for a JSON report."""
        return {
            "max_relative": self.max_relative,
            "max_absolute_m": self.max_absolute,
            "worst_joint": self.worst_joint,
            "bones": self.n_bones,
        }


def bone_length_error(motion: Motion, reference: Motion | Skeleton | None = None) -> BoneLengthError:
    """Relative bone-length error of ``motion`` against a reference skeleton.

    Parameters
    ----------
    motion : Motion
    reference : Motion or Skeleton, optional
        Default: the motion's own skeleton. Bones are matched by the child joint's name;
        the reference's rest lengths are converted to the motion's unit when both units
        are known.

    Returns
    -------
    BoneLengthError
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion; got {type(motion).__name__}")
    ref_sk = motion.skeleton
    ref_scale = 1.0
    if isinstance(reference, Motion):
        ref_sk = reference.skeleton
        if reference.metres_per_unit is not None and motion.metres_per_unit is not None:
            ref_scale = reference.metres_per_unit / motion.metres_per_unit
    elif isinstance(reference, Skeleton):
        ref_sk = reference
    elif reference is not None:
        raise ValueError(f"reference: expected a Motion, a Skeleton or None; got {type(reference).__name__}")
    sk = motion.skeleton
    scale, _ = metres(motion)
    pos_ch = sk.has_position_channels
    ref_pos_ch = ref_sk.has_position_channels
    ref_len = ref_sk.bone_lengths * ref_scale
    # a bone of a few micrometres (CMU's LHipJoint in some files) has no meaningful relative
    # error: bones under 1 % of the median bone are left out
    positive = ref_len[ref_len > 1e-9]
    tiny = 0.01 * float(np.median(positive)) if positive.size else 0.0
    pairs = []
    for j in range(1, sk.n_joints):
        name = sk.names[j]
        if name not in ref_sk.names:
            continue
        k = ref_sk.index(name)
        if pos_ch[j] or ref_pos_ch[k] or ref_len[k] <= max(1e-9, tiny):
            continue
        pairs.append((j, k))
    if not pairs:
        return BoneLengthError(0.0, 0.0, "", 0)
    idx = np.array([j for j, _ in pairs])
    rest = np.array([ref_len[k] for _, k in pairs])
    p = forward_kinematics(motion)
    lengths = np.linalg.norm(p[:, idx] - p[:, sk.parents[idx]], axis=-1)  # (F, B)
    err = np.abs(lengths - rest)
    rel = err / rest
    worst = np.unravel_index(int(np.argmax(rel)), rel.shape)
    return BoneLengthError(
        max_relative=float(rel.max()),
        max_absolute=float(err.max() * scale),
        worst_joint=sk.names[int(idx[worst[1]])],
        n_bones=len(pairs),
    )
