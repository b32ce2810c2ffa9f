"""Grammar-based fuzzing of the motion readers: files valid by construction, and near-valid ones.

Beside the mutation fuzzer (``mutations.py``: bytes of a few seed files changed at random),
this package *generates* files from the formats' grammars, so that every rule of a reader is
reached, including those a mutation of a few real files never gets to (a joint with the two
rotation channels ``Xrotation Zrotation``, position channels on a non-root joint, an ASF
bone with ``dof rz rx`` and limits, a DeepMimic clip of unequal frame durations):

* **BVH** (:func:`bvh_case`, ``bvh.py``): random trees (1 to 40 joints; chains, bushes, anything),
  joint names with odd characters (spaces, Unicode, ``<!--<script>``, ``=HYPERLINK(..)``,
  ``}``), 0 to 6 channels per joint in any order (position channels on any joint, two
  rotation channels), End Sites (none, several, named, before or after the children),
  ``Frames:`` / ``Frame Time:`` spellings, numbers in every form the format allows (``.5``,
  ``5.``, ``+1E+02``, ``007.5``, 20 decimals), layouts (tabs or spaces, braces on the name's
  line, CRLF or CR line ends, tokens one per line, blank lines, keyword case).
* **ASF/AMC** (:func:`asfamc_case`, ``asfamc.py``): ``:version``, ``:name``, ``:units`` (``length`` from
  1e-300 to 1e308, ``angle deg`` or ``rad``), ``:documentation``, ``:root`` (any ``order``
  subset and permutation, ``axis``, ``position``, ``orientation``), bones with any ``dof``
  subset and order, ``axis`` in any Euler order, ``limits`` (with ``inf``, over several
  lines), ``id`` / ``bodymass`` fields in any order, comments, ``:hierarchy`` lines in any
  order (a parent's children split over lines); the AMC: any first frame number, bone lines
  in any order, ``:RADIANS``, dof-less bones listed or not.
* **DeepMimic** (:func:`deepmimic_case`, ``deepmimic.py``): ``Loop``, ``Frames`` of 44 numbers (JSON number
  forms, integers, quaternions far from unit length), equal or unequal durations (the
  reader resamples), a last duration of 0, one-frame clips, extra members, JSON layouts.

A file is built as a list of grammar items (``core.Item``, one line of tokens of one kind:
``offset``, ``channels``, ``row``, ``length``, ``bone_line``...) and rendered in a random
layout. A case (:class:`Case`) is either valid (``expect == "ok"``: the reader must accept
it) or one grammar-level perturbation of a valid file, named by ``rule``: an item dropped
(``drop:offset``) or duplicated (``dup:name``), a value out of range (``range:frame_time``),
a malformed token (``token:number``), a count that disagrees (``count:channels``), a limit
passed (``limit:joints``). ``expect`` is ``"error"`` when the grammar makes the file invalid
(the reader must raise ``ParseError``), ``"ok"`` when the change keeps it valid, ``"any"``
when either is right (a value of 1e300 may be a valid angle yet overflow the skeleton).

Everything is driven by one ``numpy.random.Generator``: a seed gives the same cases.
"""

from __future__ import annotations

from collections.abc import Callable

from .asfamc import ASF_RULES, asfamc_case
from .bvh import BVH_RULES, bvh_case
from .core import Case
from .deepmimic import DM_RULES, DM_TEXT_RULES, deepmimic_case

__all__ = ["GENERATORS", "RULES", "Case", "asfamc_case", "bvh_case", "deepmimic_case"]

#: The generators by format.
GENERATORS: dict[str, Callable[..., Case]] = {
    "bvh": bvh_case,
    "asfamc": asfamc_case,
    "deepmimic": deepmimic_case,
}

#: The perturbation rules of each format (``"valid"`` aside).
RULES: dict[str, tuple[str, ...]] = {
    "bvh": tuple(BVH_RULES),
    "asfamc": tuple(ASF_RULES),
    "deepmimic": (*DM_RULES, *DM_TEXT_RULES),
}
