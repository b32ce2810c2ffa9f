"""Optimal time warps between SRV arrays: dynamic programming, refinement, landmarks.

Conventions (fixed project-wide; this layer sees only arrays):

- An SRV function is piecewise constant: ``q`` of shape ``(n, D)``, ``q[i]`` holding on
  ``[t[i], t[i+1])`` of a strictly increasing grid ``t`` of shape ``(n+1,)`` with
  ``t[0] = 0``, ``t[-1] = 1`` (``linspace(0, 1, n+1)`` when not given).  ``q0`` and ``q1``
  may have different ``n`` and grids, not different D.
- ``q`` is expressed in an orthonormal basis of the Lie algebra (the curves layer whitens
  by the metric weights): the pointwise inner product is the plain dot product and
  ``||q||^2 = sum_i |q_i|^2 (t[i+1] - t[i])``.
- A warp ``phi`` (increasing, ``phi(0) = 0``, ``phi(1) = 1``) is piecewise linear, given by
  its vertices ``(K, 2)``; it acts on q1 by ``(q1 * phi)(t) = sqrt(phi'(t)) q1(phi(t))``.
- Objective (paper 001, eq. 21): ``E(phi) = int_0^1 |q0 - sqrt(phi') q1(phi)|^2 dt
  + lam * sum_m FM(phi(theta0_m), theta1_m)``; the elastic distance is ``sqrt(min E)``
  without landmarks.  :func:`warp_energy` evaluates the integral exactly.

Entry point: :func:`optimal_warp` (its options: :class:`WarpSolverOptions`; the app-level
:class:`WarpOptions` fills them). Modules: ``solver`` (:func:`optimal_warp`, the batched
:func:`~elastic_motion.warp.solver.dp_energies`), ``dp`` (the DP on a grid), ``dp_kernels``
(its numba loops), ``refine`` (the gradient refinement), ``seeds`` (closed curves' seed
search), ``landmarks``, ``energy`` (the exact objective, the algebra of warps), ``partial``
(a short curve inside a long one), ``options``.  The action ``q1 * phi`` itself (a new SRV function on
the merged grid) is :func:`elastic_motion.curves.reparametrize_srv`.  Method and numbers: ``docs/warp.md``.
"""

from elastic_motion.warp.energy import (
    compose_warps,
    invert_warp,
    shift_seed,
    swap_closed_match,
    warp_at,
    warp_energy,
)
from elastic_motion.warp.landmarks import Landmarks, landmark_cost
from elastic_motion.warp.options import (
    DEFAULT_LANDMARK_WEIGHT,
    DEFAULT_MAX_STEP,
    DEFAULT_SAMPLE_FPS,
    SOLVER_METHODS,
    WARP_METHODS,
    WarpOptions,
    WarpSolverOptions,
)
from elastic_motion.warp.solver import (
    WarpDiagnostics,
    WarpResult,
    coprime_steps,
    identity_energy,
    optimal_warp,
)

__all__ = [
    "DEFAULT_LANDMARK_WEIGHT",
    "DEFAULT_MAX_STEP",
    "DEFAULT_SAMPLE_FPS",
    "SOLVER_METHODS",
    "WARP_METHODS",
    "Landmarks",
    "WarpDiagnostics",
    "WarpOptions",
    "WarpResult",
    "WarpSolverOptions",
    "compose_warps",
    "coprime_steps",
    "identity_energy",
    "invert_warp",
    "landmark_cost",
    "optimal_warp",
    "shift_seed",
    "swap_closed_match",
    "warp_at",
    "warp_energy",
]
