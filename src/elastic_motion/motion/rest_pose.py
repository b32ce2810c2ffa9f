"""Rest poses: how two skeletons with the same joints differ at rest, and re-expressing a motion
in other rest frames without changing what it does in the world.

A motion's local rotations are relative to its skeleton's rest pose. Two files with the same
joint names can come from conversions with different rest poses (CMU 107_02_30hz, a cgspeed
conversion, and 07_01, another one: their feet's rest bones point 160 degrees apart), so the
same local rotation means different poses and a blend or a distance between them is
meaningless (a blend of the two stood on its knees, hips 0.17 m above the floor).

**Change of rest frames** (:func:`change_rest_frames`). Turning joint ``j``'s frame by a
constant rotation ``C_j`` gives the local rotations ``L'_j = C_p^T L_j C_j`` (``C_p`` of the
parent; the identity above the root), the offsets ``o'_c = C_j^T o_c`` of ``j``'s children
and end sites (and their per-frame translations). By induction the global rotations are
``G'_j = G_j C_j`` and every position ``p'_c = p_j + G_j C_j C_j^T o_c = p_c``: forward
kinematics is unchanged, exactly, whatever the ``C_j``.

**Towards a reference** (:func:`rest_frames_towards`): ``C_j`` is the rotation that best takes
the reference's rest directions of ``j``'s bones (children and end sites) to this skeleton's
(Kabsch, weighted by bone length; the smallest rotation for bones on one line, which leaves
their twist as it is; bones are matched by their child's name, micrometre bones left out; a
joint with no bone to compare turns with its parent). After the change the skeleton's bones
point as the reference's do, up to the differences of its own proportions, and its local
rotations mean the reference's poses.
"""

from __future__ import annotations

import numpy as np

from elastic_motion.groups import SO3
from elastic_motion.motion.ik import rotation_between
from elastic_motion.motion.skeleton import Motion, Skeleton

_SO3 = SO3()

__all__ = ["change_rest_frames", "rest_frames_towards", "rest_pose_difference"]


def _bones(skeleton: Skeleton) -> list[dict]:
    """Per joint, the rest offsets of its children (keyed by name) and end sites (keyed by
    their order under the joint)."""
    out: list[dict] = [{} for _ in skeleton.names]
    for c, p in enumerate(skeleton.parents):
        if p >= 0:
            out[p][skeleton.names[c]] = skeleton.offsets[c]
    for e, p in enumerate(skeleton.end_site_parents):
        here = out[int(p)]
        here[("end site", sum(isinstance(k, tuple) for k in here))] = skeleton.end_site_offsets[e]
    return out


def rest_pose_difference(
    reference: Skeleton, skeleton: Skeleton, *, min_length: float = 0.0
) -> tuple[float, str]:
    """The largest angle between the rest directions of the same bone in two skeletons.

    Parameters
    ----------
    reference, skeleton : Skeleton
        Compared over the joints they share (a bone is named by its child joint; roots are
        not bones).
    min_length : float, default 0
        Bones shorter than this in either skeleton (its own length units) are left out: a
        bone of a few micrometres (CMU's ``LHipJoint`` in some conversions) has no direction.

    Returns
    -------
    angle : float
        Degrees; 0 when no bone is compared.
    bone : str
        The child joint of that bone ("" when none).
    """
    worst, name = 0.0, ""
    ref = {n: k for k, n in enumerate(reference.names)}
    for c, n in enumerate(skeleton.names):
        k = ref.get(n)
        if k is None or skeleton.parents[c] < 0 or reference.parents[k] < 0:
            continue
        a, b = reference.offsets[k], skeleton.offsets[c]
        la, lb = np.linalg.norm(a), np.linalg.norm(b)
        if min(la, lb) <= max(min_length, 0.0) or min(la, lb) == 0.0:
            continue
        ang = float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b)))  # exact near 0
        if ang > worst:
            worst, name = ang, n
    return worst, name


def rest_frames_towards(skeleton: Skeleton, reference: Skeleton, *, min_length: float = 0.0) -> np.ndarray:
    """Per joint of ``skeleton``, the rotation ``C_j`` that best takes ``reference``'s rest bone
    directions out of that joint to ``skeleton``'s (module docstring).

    Parameters
    ----------
    skeleton : Skeleton
    reference : Skeleton
        Holds every joint of ``skeleton`` under the same name. A joint's bones are matched
        by the child's name (end sites by their order under the joint); bones one skeleton
        lacks are left out.
    min_length : float, default 0
        Bones shorter than this in either skeleton (lengths in each skeleton's own units)
        are left out: a bone of a few micrometres has no direction.

    Returns
    -------
    ndarray, shape (J, 3, 3)
        The Kabsch rotation (``C a ~ b`` for the reference's directions ``a`` and the
        skeleton's ``b``, weighted by length); the smallest rotation when the bones lie on
        one line; the parent's ``C`` for a joint without a bone to compare (a hand whose
        only bones are of zero length turns with its forearm), the identity for such a root.

    Raises
    ------
    ValueError
        A joint of ``skeleton`` missing in ``reference``.
    """
    missing = [n for n in skeleton.names if n not in reference.names]
    if missing:
        raise ValueError(f"reference: expected the joints of the skeleton; it lacks {missing[:5]}")
    mine, theirs = _bones(skeleton), _bones(reference)
    out = np.tile(np.eye(3), (skeleton.n_joints, 1, 1))
    floor = max(float(min_length), 0.0)
    for j, name in enumerate(skeleton.names):  # topological order: a parent's C comes first
        k = reference.names.index(name)
        both = [(theirs[k][key], b) for key, b in mine[j].items() if key in theirs[k]]
        pairs = [(a, b) for a, b in both if min(np.linalg.norm(a), np.linalg.norm(b)) > floor]
        parent = skeleton.parents[j]
        if not pairs:
            out[j] = out[parent] if parent >= 0 else np.eye(3)
            continue
        a = np.array([x for x, _ in pairs])
        b = np.array([y for _, y in pairs])
        ua = a / np.linalg.norm(a, axis=1)[:, None]
        h = b.T @ ua  # sum of |b| (b / |b|) a^T: the skeleton's unit directions weighted by length
        u, sv, vt = np.linalg.svd(h)
        if sv[1] <= 1e-9 * sv[0]:
            # the bones on one line (one bone, or opposite ones): its direction, twist kept
            out[j] = rotation_between(vt[0], u[:, 0])
        else:
            out[j] = _SO3.project(h)
    return out


def change_rest_frames(motion: Motion, frames: np.ndarray) -> Motion:
    """The same world motion with each joint's rest frame turned by ``frames[j]`` (module
    docstring): local rotations ``C_p^T L_j C_j``, offsets, end sites and per-frame joint
    translations turned into the new frames; forward kinematics unchanged.

    Parameters
    ----------
    motion : Motion
    frames : ndarray, shape (J, 3, 3)
        Rotations ``C_j``.

    Returns
    -------
    Motion
    """
    c = np.asarray(frames, dtype=np.float64)
    sk = motion.skeleton
    if c.shape != (sk.n_joints, 3, 3):
        raise ValueError(f"frames: expected shape ({sk.n_joints}, 3, 3); got {c.shape}")
    c = _SO3.check_points(c, "frames")  # only rotations keep the world motion
    parents = np.asarray(sk.parents)
    cp = np.where((parents >= 0)[:, None, None], c[np.maximum(parents, 0)], np.eye(3))  # (J, 3, 3)
    rot = np.swapaxes(cp, -1, -2)[None] @ motion.rotations @ c[None]
    offsets = sk.offsets.copy()
    child = parents >= 0
    offsets[child] = np.einsum("jki,jk->ji", c[parents[child]], sk.offsets[child])  # C_p^T o
    ends = sk.end_site_offsets.copy()
    if ends.size:
        ep = np.asarray(sk.end_site_parents, dtype=np.int64)
        ends = np.einsum("eki,ek->ei", c[ep], sk.end_site_offsets)
    jt = motion.joint_translations
    if jt is not None:
        jt = jt.copy()
        jt[:, child] = np.einsum("jki,fjk->fji", c[parents[child]], jt[:, child])
    new_sk = Skeleton(sk.names, sk.parents, offsets, sk.channels, sk.end_site_parents, ends)
    return motion.replace(skeleton=new_sk, rotations=rot, joint_translations=jt)
