"""What determines the numbers of a distance matrix: :class:`DatabaseSettings` and its JSON form.

The JSON form is stored three times in an output folder (``manifest.json`` as the identity
of the run, ``srv_cache.npz`` and ``report.json``)::

    {"n_samples": 64, "representations": ["lie", "euler"],
     "warp": {"method": "dp", "neighbourhood": 10, "coarse_to_fine": false,
              "sample_fps": 30.0, "sample_smoothing": 0.016666666666666666, ...},
     "joints": "all", "drop_fingers": true, "align_heading": true, "tile_size": 32}

plus ``"pose_weight"``, ``"cyclic": true``, ``"up"`` and ``"units"`` when they are set
(written only then, so a file of the default distance reads as before in earlier releases;
a missing field reads as its default, the numbers the file was computed with).

Format 1 (releases before :class:`~elastic_motion.warp.WarpOptions`) stored the warp as
``"pair": {"warp": "dp", "neighbourhood": 6, "coarse_to_fine": false}``;
:meth:`DatabaseSettings.from_json` reads it as the same numbers (``warp`` -> ``method``), so
a run started then can be resumed with the same settings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.apps.statistics import MEAN_WARP, as_warp_options
from elastic_motion.errors import OptionError
from elastic_motion.motion.representations import EULER, LIE, METHODS, Representation, representation
from elastic_motion.vocabulary import JOINT_SELECTIONS
from elastic_motion.warp import WarpOptions

__all__ = [
    "DEFAULT_WARP",
    "FORMAT_VERSION",
    "JOINT_SELECTIONS",
    "QUERY_FIELDS",
    "DatabaseSettings",
    "flat_settings",
    "ignored_settings_note",
    "joint_selection",
    "representation_keys",
    "settings_differences",
]


def representation_keys(value: Any, option: str = "representations") -> tuple[str, ...]:
    """The stored keys (:attr:`~elastic_motion.motion.representations.Representation.key`:
    ``"lie"``, ``"euler"``) of one representation or a sequence of distinct ones.

    Parameters
    ----------
    value : str, Representation or sequence of them
        Names as :func:`~elastic_motion.motion.representations.representation` accepts them
        (``"lie"``, ``"euler-elastic"``, ``"euler"``).
    option : str, default "representations"
        Named in the error.

    Raises
    ------
    OptionError
        No entry, an unknown one, or one representation twice (``"euler"`` and
        ``"euler-elastic"`` are one).
    """
    reps = (value,) if isinstance(value, str | Representation) else tuple(value)
    try:
        keys = tuple(representation(r, option).key for r in reps)
    except OptionError:
        keys = ()
    if not reps or len(keys) != len(reps) or len(set(keys)) != len(keys):
        raise OptionError(option, f"expected distinct entries of {list(METHODS)}; got {list(reps)}")
    return keys


# The joint selections by name (DatabaseSettings.joints; otherwise a list of joint names):
# JOINT_SELECTIONS, the values of JointSelection (elastic_motion.vocabulary).


def joint_selection(value: str | Sequence[str]) -> str | tuple[str, ...]:
    """``value`` as a joint selection: one of :data:`JOINT_SELECTIONS`, or a tuple of joint names.

    Raises
    ------
    OptionError
        Another string, or an empty list of names.
    """
    if isinstance(value, str):
        if value not in JOINT_SELECTIONS:
            raise OptionError(
                "joints", f"expected 'all', 'common', 'map' or a list of joint names; got {value!r}"
            )
        return value
    names = tuple(str(n) for n in value)
    if not names:
        raise OptionError("joints", "expected at least one joint name; got none")
    return names


#: Version of the files of an output folder. 1: settings with ``"pair"``; 2: with ``"warp"``
#: (:class:`~elastic_motion.warp.WarpOptions`); 3: the SRV arrays low-passed by
#: ``warp.sample_smoothing`` before the grid is sampled, as ``distance`` samples its curves
#: (formats 1 and 2 did not low-pass: their settings read with ``sample_smoothing = 0``, the
#: numbers they were computed with).
FORMAT_VERSION = 3
#: Versions :meth:`DatabaseSettings.from_json` reads.
READABLE_FORMATS = (1, 2, 3)
#: The last format whose SRV arrays were not low-passed (:meth:`DatabaseSettings.from_json`).
_UNSMOOTHED_FORMAT = 2

#: The warp of a database: :class:`~elastic_motion.warp.WarpOptions`' defaults (neighbourhood
#: 10, the low-pass) with the DP alone (``method="dp"``), the warp of a Karcher mean
#: (:data:`elastic_motion.apps.statistics.MEAN_WARP`: its energy is non-increasing only with the
#: DP) and the one ``cyclic`` needs. ``distance`` and ``blend`` refine off the grid
#: (``"dp+refine"``); a database does not by default because its exact search would miss its
#: speed target: with ``dp+refine`` each distance the bounds cannot exclude costs one
#: ``optimal_warp`` call (about 9-13 ms at 64 cells, against 0.9 ms in the batched DP), and the
#: search over 2,500 windows was 1.50x faster than brute-force DTW (median of 12 queries,
#: ``benchmarks/search.py``, load 5-7 on 2 cores; 6.5x with the DP) where issue 34 asks 3x
#: (``docs/database.md``, "What is compared"). An all-pairs matrix is also 4.7 times slower
#: (31 CMU windows, 465 pairs: 0.84 s against 3.99 s) for distances 0.6 % lower (median; at
#: most 12 %). Pass ``WarpOptions()`` (``--warp dp+refine``) for ``distance``'s warp: the search
#: stays exact with it (its bounds hold for every warp, :mod:`.bounds`).
DEFAULT_WARP = MEAN_WARP


@dataclass(frozen=True)
class DatabaseSettings:
    """Everything that determines the numbers of a distance matrix.

    Attributes
    ----------
    n_samples : int, default 64
        Cells of the common grid: each motion is resampled to ``n_samples + 1`` frames
        uniformly over its duration (normalised to 1).
    representations : tuple of {"lie", "euler-elastic"}, default ("lie", "euler")
        Curve representations (``method`` names or
        :class:`~elastic_motion.motion.representations.Representation` objects), held as their
        stored keys ``"lie"`` / ``"euler"`` (:func:`representation_keys`), which name the
        matrix files.
    warp : WarpOptions, default :data:`DEFAULT_WARP` (``WarpOptions(method="dp")``)
        How a pair distance is computed (:func:`~elastic_motion.apps.database.pair_distance`):
        ``method`` ``"dp"`` / ``"dp+refine"`` (elastic distance) or ``"none"`` (distance of
        the parametrised curves), the DP ``neighbourhood`` (default 10), ``coarse_to_fine``,
        and ``sample_smoothing``: the Gaussian low-pass (seconds) of each motion before its grid
        is sampled, the one ``distance`` applies before sampling its curves. A method name is
        accepted for ``WarpOptions(method=name)``. ``sample_fps`` and ``landmark_weight`` are
        not used here (the grid is ``n_samples``; no landmarks).
    joints : "all", "common", "map" or tuple of str, default "all"
        ``"all"``: every joint of each file; motions with different joint names form
        separate groups (entries between groups are ``+inf``). ``"common"``: the joints
        every readable motion has (one group). ``"map"``: every motion on the 13-joint
        common body model through the joint-name maps of
        :mod:`~elastic_motion.apps.database.jointmap` (CMU BVH/ASF, Bandai, DeepMimic: one
        group; a skeleton no map fits is skipped, naming the joints it lacks). A tuple:
        exactly these joints (files lacking one are skipped with the reason).
    drop_fingers : bool, default True
        Remove finger/thumb/hand-index joints (CMU's 180-degree flips).
    align_heading : bool, default True
        Remove the yaw and floor position of the root at frame 0 before comparing.
    tile_size : int, default 32
        Motions per tile side (a tile holds up to ``tile_size**2`` pairs).
    pose_weight : float or "balanced", default 0
        Weight ``lam`` of a pose term beside the SRV (``docs/database.md``, "Retrieval
        quality"): each cell's array gets ``sqrt(lam) * pose`` appended
        (:func:`~elastic_motion.apps.database.preparation.pose_arrays`: the non-root joints'
        ``(R - I) / sqrt(2)``, weighted like the Lie joints), so the squared distance is the
        SRV term's plus ``lam`` times the pose term's, both under the same warp. The SRV sees
        velocities only; the pose term sees where the joints are. ``"balanced"``: ``lam`` such
        that both terms have the same mean squared pair distance over the database's motions
        (:func:`~elastic_motion.apps.database.preparation.balanced_pose_weight`, per skeleton
        group; no labels). 0: the SRV alone.
    cyclic : bool, default False
        Phase-free matching: the distance is the least over the ``n_samples`` cyclic shifts of
        either motion's cells of the elastic distance (exact DP of every shift, both ways:
        ``2 n_samples`` times the cost of a pair). For windows of periodic motions (gait)
        started at different phases. Needs the exact DP (``warp.method == "dp"``, no
        ``coarse_to_fine``).
    up : {"x", "y", "z"} or None, default None
        Up axis of every file read (:attr:`elastic_motion.apps.prepare.PrepareOptions.up`):
        the database's files and a query measured against it. None: each file's as
        detected when reading (BVH) or its format's.
    units : str or None, default None
        Length unit of every BVH file read (``"m"``, ``"cm"``, ``"mm"``, ``"inch"``,
        ``"cmu"``; :attr:`elastic_motion.apps.prepare.PrepareOptions.units`). None: guessed
        from each skeleton's size.

    Raises
    ------
    OptionError
        A value out of range, naming the field.
    """

    n_samples: int = 64
    representations: tuple[str, ...] = (LIE.key, EULER.key)
    warp: WarpOptions = DEFAULT_WARP
    joints: str | tuple[str, ...] = "all"
    drop_fingers: bool = True
    align_heading: bool = True
    tile_size: int = 32
    pose_weight: float | str = 0.0
    cyclic: bool = False
    up: str | None = None
    units: str | None = None

    def __post_init__(self) -> None:
        PrepareOptions(up=self.up, units=self.units)  # type: ignore[arg-type]  # checks them, naming the field
        if isinstance(self.n_samples, bool) or not isinstance(self.n_samples, int) or self.n_samples < 2:
            raise OptionError("n_samples", f"expected an integer >= 2; got {self.n_samples!r}")
        object.__setattr__(self, "representations", representation_keys(self.representations))
        object.__setattr__(self, "warp", as_warp_options(self.warp, default=None))
        object.__setattr__(self, "joints", joint_selection(self.joints))
        if isinstance(self.tile_size, bool) or not isinstance(self.tile_size, int) or self.tile_size < 1:
            raise OptionError("tile_size", f"expected an integer >= 1; got {self.tile_size!r}")
        if self.pose_weight != "balanced":
            try:
                lam = float(self.pose_weight)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                lam = float("nan")
            if isinstance(self.pose_weight, bool) or not (lam >= 0 and lam < float("inf")):
                raise OptionError(
                    "pose_weight", f"expected a number >= 0 or 'balanced'; got {self.pose_weight!r}"
                )
            object.__setattr__(self, "pose_weight", lam)
        if not isinstance(self.cyclic, bool):
            raise OptionError("cyclic", f"expected True or False; got {self.cyclic!r}")
        if self.cyclic and (self.warp.method != "dp" or self.warp.coarse_to_fine):
            got = f"warp {self.warp.method!r}" + (" with coarse to fine" if self.warp.coarse_to_fine else "")
            raise OptionError(
                "cyclic", f"phase-free matching needs the DP warp (warp 'dp', no coarse to fine); got {got}"
            )

    def to_json(self) -> dict[str, Any]:
        """Plain-JSON form (module docstring): lists for tuples, the warp options as a dict."""
        return {
            "n_samples": self.n_samples,
            "representations": list(self.representations),
            "warp": self.warp.to_json(),
            "joints": self.joints if isinstance(self.joints, str) else list(self.joints),
            "drop_fingers": self.drop_fingers,
            "align_heading": self.align_heading,
            "tile_size": self.tile_size,
            # only when set: files of the default distance stay readable by earlier releases
            **({"pose_weight": self.pose_weight} if self.pose_weight else {}),
            **({"cyclic": True} if self.cyclic else {}),
            **({"up": self.up} if self.up is not None else {}),
            **({"units": self.units} if self.units is not None else {}),
        }

    def read_options(self) -> PrepareOptions:
        """How each file is read and prepared (:func:`elastic_motion.apps.prepare.load_motion`):
        the defaults with :attr:`up` and :attr:`units`."""
        return PrepareOptions(up=self.up, units=self.units)  # type: ignore[arg-type]

    @classmethod
    def from_json(cls, data: dict[str, Any], file_format: int = FORMAT_VERSION) -> DatabaseSettings:
        """Inverse of :meth:`to_json`; also reads format 1 (``"pair"``, module docstring).

        ``file_format``: of the file ``data`` was stored in (:data:`FORMAT_VERSION`); its SRV arrays
        were computed without the low-pass before format 3, so the settings of such a file read
        with ``warp.sample_smoothing = 0`` (the numbers stored), whatever its JSON says.

        Raises
        ------
        OptionError
            Unknown or missing fields, naming them.
        """
        d = dict(data)
        if "pair" in d and "warp" not in d:  # format 1
            pair = dict(d.pop("pair"))
            if "warp" in pair:
                pair["method"] = pair.pop("warp")
            d["warp"] = pair
        known = set(cls.__dataclass_fields__)
        bad = sorted(set(d) - known)
        if bad:
            raise OptionError("settings", f"expected fields among {sorted(known)}; got unknown {bad}")
        if isinstance(d.get("warp"), str):  # a method's name, as DatabaseSettings(warp="dp") takes
            d["warp"] = {"method": d["warp"]}
        if isinstance(d.get("warp"), dict):
            w = dict(d["warp"])
            if file_format <= _UNSMOOTHED_FORMAT:
                w["sample_smoothing"] = 0.0
            d["warp"] = WarpOptions.from_json(w)
        elif (
            "warp" not in d and file_format <= _UNSMOOTHED_FORMAT
        ):  # no warp stored: the DP of those releases' default
            d["warp"] = WarpOptions(method=MEAN_WARP.method, sample_smoothing=0.0)
        if "representations" in d:
            d["representations"] = tuple(d["representations"])
        if "joints" in d and not isinstance(d["joints"], str):
            d["joints"] = tuple(d["joints"])
        return cls(**d)


#: The fields (``warp.<field>`` for the warp's) that change a query's distances to a stored
#: database (:func:`~elastic_motion.apps.database.knn_search`); the others name the files
#: (``representations``) or how a matrix run is cut into tiles (``tile_size``), and the warp's
#: ``sample_fps`` and ``landmark_weight`` are not used by a database.
QUERY_FIELDS = (
    "n_samples",
    "warp.method",
    "warp.sample_smoothing",
    "warp.neighbourhood",
    "warp.coarse_to_fine",
    "joints",
    "drop_fingers",
    "align_heading",
    "pose_weight",
    "cyclic",
    "up",
    "units",
)


def flat_settings(data: dict[str, Any]) -> dict[str, Any]:
    """A settings JSON form (:meth:`DatabaseSettings.to_json`) as one level: the warp's fields
    as ``warp.<field>``, the fields written only when set (``pose_weight``, ``cyclic``, ``up``,
    ``units``) at
    their defaults when absent, a list of joints sorted (the preparation keeps the skeleton's
    order whatever the list's)."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        if isinstance(v, dict):
            out.update({f"{k}.{f}": fv for f, fv in v.items()})
        elif k == "joints" and isinstance(v, list | tuple):
            out[k] = sorted(v)
        else:
            out[k] = v
    out.setdefault("pose_weight", DatabaseSettings.pose_weight)
    out.setdefault("cyclic", DatabaseSettings.cyclic)
    out.setdefault("up", None)
    out.setdefault("units", None)
    return out


def settings_differences(
    old: dict[str, Any], new: dict[str, Any], fields: tuple[str, ...] | None = None
) -> list[tuple[str, Any, Any]]:
    """The fields in which two settings JSON forms (:meth:`DatabaseSettings.to_json`) differ.

    Parameters
    ----------
    old, new : dict
        JSON forms; a field written only when set reads as its default when absent, the warp's
        fields are compared one by one (``"warp.neighbourhood"``).
    fields : tuple of str, optional
        Compare only these (flat names, e.g. :data:`QUERY_FIELDS`); default every field of
        either form, ``new``'s first.

    Returns
    -------
    list of (field, old value, new value)
    """
    fo, fn = flat_settings(old), flat_settings(new)
    names = fields if fields is not None else (*fn, *(k for k in fo if k not in fn))
    return [(k, fo.get(k), fn.get(k)) for k in names if fo.get(k) != fn.get(k)]


def ignored_settings_note(
    asked: DatabaseSettings, stored: DatabaseSettings, fields: tuple[str, ...]
) -> str | None:
    """The note for settings asked of a stored database (an index or a matrix folder), which is
    measured as it was built: the ``fields`` (of :data:`QUERY_FIELDS`) in which ``asked``
    differs from ``stored``; None when it does not."""
    # in QUERY_FIELDS' order, whichever order the fields come in (the CLI's and the API's notes agree)
    diffs = settings_differences(
        stored.to_json(), asked.to_json(), tuple(f for f in QUERY_FIELDS if f in fields)
    )
    if not diffs:
        return None
    what = ", ".join(f"{k}={new!r} (built with {old!r})" for k, old, new in diffs)
    return (
        f"settings ignored: {what}; a stored database is measured with the settings it was built with "
        "(build it again with these to use them)"
    )
