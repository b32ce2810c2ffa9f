"""The refusal stage of a loop: a loop that rewrites its clip is an error unless forced.

A clip that does not repeat can always be closed, but closing it whole may change it beyond
what an animator would accept: CMU 09_11 (a run) closed whole moves a joint by 0.69 m, the
cartwheels of 49_08 by 0.60 m and a slide of its feet appears that the input does not have.
:func:`check_loop` refuses such a loop (:class:`LoopRefused`, a
:class:`~elastic_motion.errors.OptionError` naming ``force``: the command line exits 2) when

* it moves a closed joint or end site by more than ``change_bound`` relative to the root
  (:attr:`LoopResult.change_m`), or
* its feet skid more than the input's (the skid count of
  :func:`~elastic_motion.apps.metrics.floor.foot_quality`, the same measure on both),

unless ``force=True`` (``--force``). The message gives the numbers and the window that
closes with the least change, when the clip has one.
"""

from __future__ import annotations

from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.loop.result import LoopResult
from elastic_motion.errors import OptionError

__all__ = ["LoopRefused", "check_loop", "refusal_reasons"]


class LoopRefused(OptionError):
    """A loop that changes its clip beyond ``change_bound`` or adds skids (module docstring).

    Attributes
    ----------
    result : LoopResult or None
        The refused loop (None after pickling).
    """

    def __init__(self, message: str, result: LoopResult | None = None) -> None:
        super().__init__("force", message)
        self.result = result

    def __reduce__(self):
        return (type(self), (self.message,))


def refusal_reasons(result: LoopResult, options: LoopOptions) -> list[str]:
    """What makes ``result`` unacceptable without ``force`` (module docstring); empty when it is fine."""
    reasons = []
    if result.change_m > options.change_bound:
        reasons.append(
            f"it moves a joint by up to {result.change_m:.3g} m relative to the root, more than "
            f"{options.change_bound:g} m (change_bound, --change-bound)"
        )
    before, after = result.feet_before, result.feet_after
    if before is not None and after is not None and after.skid_count > before.skid_count:
        reasons.append(
            f"its feet slide along the floor {after.skid_count} times ({after.slid_m:.2f} m), the input's "
            f"{before.skid_count} times"
        )
    return reasons


def check_loop(result: LoopResult, options: LoopOptions) -> LoopResult:
    """``result`` when acceptable or ``force``; else :class:`LoopRefused`."""
    reasons = refusal_reasons(result, options)
    if not reasons or options.force:
        return result
    w = result.window
    if w is None:
        where = "the whole clip"
        suggestion = "; window='auto' (--window auto) loops the sub-clip that closes with the least change"
    else:
        where = f"frames {w.start}..{w.stop - 1}"
        suggestion = (
            "; it is the window of this clip that closes with the least change"
            if options.window in ("auto", "safe")
            else "; window='auto' (--window auto) looks for the window that closes with the least change"
        )
    raise LoopRefused(
        f"not given, so the loop of {where} is refused: "
        + "; ".join(reasons)
        + suggestion
        + "; force=True (--force) keeps it anyway",
        result,
    )
