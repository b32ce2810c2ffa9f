"""Closing curves: seamless loops (paper 000, sec. 4; paper 001, Thm. 2).

A curve is *closed* when its last sample equals its first; closing changes its SRV function
so that the curve integrated from the original first sample ends there. The modules:

* :mod:`~elastic_motion.closing.problem`: the closing problem (conventions, residuals, the
  exact Jacobian, the state) and :func:`closing_gap`, :func:`closing_mask`;
* :mod:`~elastic_motion.closing.options`: :class:`ClosingOptions`, one object for every solver;
* :mod:`~elastic_motion.closing.flows`: :func:`close_curve`, Gauss-Newton and gradient flows
  (closed, nearest the input to first order), and :func:`closing_gradient`;
* :mod:`~elastic_motion.closing.kkt`: :func:`project_closed`, the closed curve nearest the
  input in SRV L2 (a KKT point), with :class:`ExtraConstraints` solved in the same projection;
* :mod:`~elastic_motion.closing.euclidean`: :func:`project_closed_rd`, paper 001's Newton
  projection in ``R^d``;
* :mod:`~elastic_motion.closing.result`: :class:`ClosingResult`, what every solver returns.
"""

from elastic_motion.closing.euclidean import project_closed_rd
from elastic_motion.closing.flows import ClosingGradient, close_curve, closing_gradient
from elastic_motion.closing.kkt import ExtraConstraints, kkt_residual, project_closed
from elastic_motion.closing.options import CLOSING_METHODS, ClosingMethod, ClosingOptions
from elastic_motion.closing.problem import SeamGap, closing_gap, closing_mask
from elastic_motion.closing.result import ClosingResult

__all__ = [
    "CLOSING_METHODS",
    "ClosingGradient",
    "ClosingMethod",
    "ClosingOptions",
    "ClosingResult",
    "ExtraConstraints",
    "SeamGap",
    "close_curve",
    "closing_gap",
    "closing_gradient",
    "closing_mask",
    "kkt_residual",
    "project_closed",
    "project_closed_rd",
]
