"""ASF/AMC pairs from the grammar: units, root, bones, hierarchy, AMC frames; their rules."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .core import (
    BAD_TOKENS,
    HUGE_OK,
    NON_FINITE,
    TEXT_STYLES,
    Case,
    Item,
    apply_rules,
    chance,
    copy_item,
    fmt_num,
    number_writer,
    pick,
    random_layout,
    render,
    replace_token,
    unique_name,
    where,
)

_ROOT_TOKENS = ("TX", "TY", "TZ", "RX", "RY", "RZ")
_UNITS_OK = ["0.45", "1", "1.0", "2.54", "0.01", "1e-3", "100", "1e-300", "1e308", "4.5E-1"]


def _asf_name_ok(name: str) -> bool:
    return (
        len(name.split()) == 1
        and name == name.strip()
        and name != "root"
        and name.lower() not in ("begin", "end")
        and not (name.isascii() and name.isdigit())
        and not name.startswith((":", "#"))  # a section, a comment
    )


@dataclass
class _Bone:
    name: str
    parent: int  # -1: the root
    direction: np.ndarray
    length: float
    axis: np.ndarray
    axis_order: str
    dof: list[str]
    limits: list[tuple[str, str]]


@dataclass
class _Asf:
    bones: list[_Bone]
    order: list[str]
    root_axis: str
    length_unit: str
    radians: bool  # the ASF's angle unit
    amc_radians: bool  # the AMC's (:RADIANS / :DEGREES, or the ASF's)


def _asf_model(rng: np.random.Generator) -> _Asf:
    n = int(rng.choice([1, 2, 4, 8, 12, 20, 30]))
    used: set[str] = {"root"}
    bones = []
    for b in range(n):
        parent = -1 if b == 0 or chance(rng, 0.2) else int(rng.integers(-1, b))
        d = rng.normal(size=3)
        dof = [str(x) for x in rng.permutation(["rx", "ry", "rz"])[: int(rng.choice([0, 1, 2, 3, 3, 3]))]]
        if chance(rng, 0.5):
            dof = sorted(dof)
        limits = []
        if dof and chance(rng, 0.6):
            for _ in dof:
                lo, hi = sorted(rng.uniform(-180, 180, 2))
                lo_s, hi_s = fmt_num(lo, "fixed"), fmt_num(hi, "fixed")
                if chance(rng, 0.1):
                    lo_s, hi_s = pick(rng, [("-inf", "inf"), (hi_s, lo_s), ("-INF", "+inf")])
                limits.append((lo_s, hi_s))
        name = unique_name(rng, used, lambda s: s, _asf_name_ok)
        length = float(rng.choice([0.0, 1.0, 1.0, 1.0, 7.5])) * float(rng.uniform(0.5, 2.0))
        axis_order = "".join(str(a) for a in rng.permutation(list("XYZ")))
        bones.append(_Bone(name, parent, d, length, rng.uniform(-180, 180, 3), axis_order, dof, limits))
    k = int(rng.choice([6, 6, 6, 3, 1, 4]))
    order = [
        str(t) for t in (rng.permutation(_ROOT_TOKENS)[:k] if chance(rng, 0.3) or k < 6 else _ROOT_TOKENS)
    ]
    radians = chance(rng, 0.2)
    amc_radians = radians if chance(rng, 0.8) else not radians
    root_axis = "".join(str(a) for a in rng.permutation(list("XYZ")))
    return _Asf(bones, order, root_axis, pick(rng, _UNITS_OK), radians, amc_radians)


def _asf_items(rng: np.random.Generator, asf: _Asf) -> list[Item]:
    ang = (math.pi / 180.0) if asf.radians else 1.0
    num = number_writer(rng, TEXT_STYLES)
    items = [Item("comment", 0, ["#", "ASF", "written", "by", "grammar.py"])] if chance(rng, 0.5) else []
    items += [Item("version", 0, [":version", "1.10"], 1), Item("aname", 0, [":name", "VICON"], 1)]
    if chance(rng, 0.9):
        items.append(Item("units", 0, [":units"], 1))
        units = [Item("u_mass", 1, ["mass", "1.0"], 1), Item("u_length", 1, ["length", asf.length_unit], 1)]
        units.append(Item("u_angle", 1, ["angle", "rad" if asf.radians else "deg"], 2))
        items += [units[int(k)] for k in rng.permutation(3)]
    items += [
        Item("doc", 0, [":documentation"], 1),
        Item("doc_text", 1, ["Generated", "(fuzzing)", "1", "2"]),
    ]
    items.append(Item("root", 0, [":root"], 1))
    root = [
        Item("r_order", 1, ["order", *asf.order], 1 + len(asf.order)),
        Item("r_axis", 1, ["axis", asf.root_axis], 2),
    ]
    root.append(Item("r_position", 1, ["position", "0", "0", "0"], 1))
    root.append(Item("r_orientation", 1, ["orientation", *map(num, rng.uniform(-90, 90, 3) * ang)], 1))
    items += [root[int(k)] for k in rng.permutation(4)]
    items.append(Item("bonedata", 0, [":bonedata"], 1))
    for b, bone in enumerate(asf.bones):
        fields = [Item("b_id", 2, ["id", str(b + 1)], 1), Item("b_name", 2, ["name", bone.name], 1)]
        fields.append(Item("b_direction", 2, ["direction", *map(num, bone.direction)], 1))
        fields.append(Item("b_length", 2, ["length", num(bone.length)], 1))
        fields.append(Item("b_axis", 2, ["axis", *map(num, bone.axis * ang), bone.axis_order], 1))
        if bone.dof or chance(rng, 0.2):
            fields.append(Item("b_dof", 2, ["dof", *bone.dof], 1 + len(bone.dof)))
        if chance(rng, 0.2):
            fields.append(Item("b_extra", 2, [pick(rng, ["bodymass", "cofmass", "unknownkey"]), "3.0"]))
        fields = [fields[int(k)] for k in rng.permutation(len(fields))]
        if bone.limits:
            pairs = [f"({lo} {hi})" if chance(rng, 0.8) else f"( {lo}  {hi} )" for lo, hi in bone.limits]
            if chance(rng, 0.7):
                block = [Item("b_limits", 2, ["limits", pairs[0]], 1)]
                block += [Item("b_limits_cont", 3, [p]) for p in pairs[1:]]
            else:
                block = [Item("b_limits", 2, ["limits", *pairs], 1)]
            at = int(rng.integers(len(fields) + 1))
            fields[at:at] = block
        for it in fields:
            it.extra["bone"] = b
        items += [
            Item("begin", 1, ["begin"], 1, {"bone": b}),
            *fields,
            Item("end", 1, ["end"], 1, {"bone": b}),
        ]
    items += [Item("hierarchy", 0, [":hierarchy"], 1), Item("h_begin", 1, ["begin"], 1)]
    names = ["root"] + [bone.name for bone in asf.bones]
    links = []
    for p in range(-1, len(asf.bones)):
        kids = [bone.name for bone in asf.bones if bone.parent == p]
        while kids:  # a parent's children, on one line or split over several
            cut = len(kids) if chance(rng, 0.8) else int(rng.integers(1, len(kids) + 1))
            links.append(Item("h_link", 2, [names[p + 1], *kids[:cut]]))
            kids = kids[cut:]
    items += [links[int(k)] for k in rng.permutation(len(links))] if chance(rng, 0.3) else links
    items.append(Item("h_end", 1, ["end"], 1))
    return items


def _amc_items(rng: np.random.Generator, asf: _Asf) -> list[Item]:
    num = number_writer(rng, TEXT_STYLES)
    ang = (math.pi / 180.0) if asf.amc_radians else 1.0
    items = [Item("a_comment", 0, ["#!OML:ASF", "F:\\\\grammar.asf"])] if chance(rng, 0.5) else []
    items.append(Item("a_full", 0, [":FULLY-SPECIFIED"], 1))
    if asf.amc_radians != asf.radians or chance(rng, 0.5):
        items.append(Item("a_unit", 0, [":RADIANS" if asf.amc_radians else ":DEGREES"], 1))
    n_frames = int(rng.choice([1, 2, 3, 5, 10, 30]))
    first = int(rng.choice([1, 1, 1, 0, 1000]))
    for f in range(n_frames):
        items.append(Item("frame_no", 0, [str(first + f)]))
        lines = [
            [
                "root",
                *(
                    num(rng.uniform(-50, 50) if t[0] == "T" else rng.uniform(-180, 180) * ang)
                    for t in asf.order
                ),
            ]
        ]
        for bone in asf.bones:
            if bone.dof or chance(rng, 0.3):
                lines.append([bone.name, *(num(rng.uniform(-180, 180) * ang) for _ in bone.dof)])
        for k in rng.permutation(len(lines)) if chance(rng, 0.3) else range(len(lines)):
            items.append(Item("bone_line", 0, lines[int(k)], 0, {"dof": len(lines[int(k)]) - 1}))
    return items


def _drop(
    kind: str | tuple[str, ...], expect: str, side: int = 0, only: Callable[[Item], bool] | None = None
):
    """A rule dropping one item of ``kind`` from the ASF (``side`` 0) or the AMC (1)."""

    def rule(rng, files, model):
        items = files[side]
        idx = [k for k in where(items, kind) if only is None or only(items[k])]
        if not idx:
            return None
        del items[pick(rng, idx)]
        return expect

    return rule


def _dup(kind: str | tuple[str, ...], expect: str, side: int = 0, only: Callable[[Item], bool] | None = None):
    """A rule repeating one item of ``kind`` (right after itself)."""

    def rule(rng, files, model):
        items = files[side]
        idx = [k for k in where(items, kind) if only is None or only(items[k])]
        if not idx:
            return None
        k = pick(rng, idx)
        items.insert(k + 1, copy_item(items[k]))
        return expect

    return rule


def _token(kind: str | tuple[str, ...], new: list[str], expect: str, side: int = 0, first: int = 1):
    """A rule replacing one token (from index ``first``) of an item of ``kind``."""

    def rule(rng, files, model):
        return expect if replace_token(files[side], kind, rng, pick(rng, new), first) else None

    return rule


def _asf_dup_bone(rng, files, model):
    asf = files[0]
    begins = where(asf, "begin")
    if not begins:
        return None
    k = pick(rng, begins)
    end = next(i for i in range(k, len(asf)) if asf[i].kind == "end")
    asf[end + 1 : end + 1] = [copy_item(it) for it in asf[k : end + 1]]
    return "error"


def _asf_dup_child(rng, files, model):
    links = where(files[0], "h_link")
    if not links:
        return None
    a, b = pick(rng, links), pick(rng, links)
    files[0][b].toks.append(pick(rng, files[0][a].toks[1:]))
    return "error"


def _asf_cycle(rng, files, model):
    """A bone re-attached below its own subtree: a cycle cut off from the root."""
    bones = model.bones
    if not bones:
        return None
    x = int(rng.integers(len(bones)))
    below = [x]
    for b in range(x + 1, len(bones)):
        if bones[b].parent in below:
            below.append(b)
    for it in where(files[0], "h_link"):
        toks = files[0][it].toks
        if bones[x].name in toks[1:]:
            toks.remove(bones[x].name)
    files[0][:] = [it for it in files[0] if not (it.kind == "h_link" and len(it.toks) == 1)]
    k = where(files[0], "h_end")[0]
    files[0].insert(k, Item("h_link", 2, [bones[pick(rng, below)].name, bones[x].name]))
    return "error"


def _amc_width(rng, files, model):
    idx = where(files[1], "bone_line")
    it = files[1][pick(rng, idx)]
    if len(it.toks) > 1 and chance(rng, 0.5):
        it.toks.pop()
    else:
        it.toks.append("0.5")
    return "error"


def _amc_frame_no(rng, files, model):
    idx = where(files[1], "frame_no")
    k = pick(rng, idx)
    n = int(files[1][k].toks[0])
    files[1][k].toks[0] = pick(rng, [str(n + 1), "1" * 25] if k != idx[0] else ["1" * 25, "9" * 19])
    return "error"


def _amc_keyword_inside(rng, files, model):
    k = where(files[1], "frame_no")[0]
    files[1].insert(
        k + 1 + int(rng.integers(2)), Item("a_unit", 0, [pick(rng, [":DEGREES", ":RADIANS", ":FOO"])], 1)
    )
    return "error"


def _amc_drop_frames(rng, files, model):
    files[1][:] = [it for it in files[1] if it.kind not in ("frame_no", "bone_line")]
    return "error"


def _asf_units(rng, files, model):
    bad = chance(rng, 0.7)
    new = (
        ["0", "-1", "1e-320", "4e-324", "nan", "inf", "1e400", "-0", "zero"]
        if bad
        else ["1e-300", "1e308", "1e-5"]
    )
    return ("error" if bad else "ok") if replace_token(files[0], "u_length", rng, pick(rng, new)) else None


def _asf_limit_value(rng, files, model):
    idx = where(files[0], ("b_limits", "b_limits_cont"))
    if not idx:
        return None
    it = files[0][pick(rng, idx)]
    t = int(rng.integers(1 if it.kind == "b_limits" else 0, len(it.toks)))
    bad = chance(rng, 0.5)
    it.toks[t] = "(nan 1)" if bad else pick(rng, ["(-inf inf)", "(+inf -inf)", "(0 0)"])
    return "error" if bad else "ok"


def _asf_limit_count(rng, files, model):
    idx = where(files[0], ("b_limits", "b_limits_cont"))
    if not idx:
        return None
    k = pick(rng, idx)
    if chance(rng, 0.5):
        files[0][k].toks.append("(-5 5)")
    elif files[0][k].kind == "b_limits_cont":
        del files[0][k]
    else:
        files[0][k].toks[1:] = files[0][k].toks[2:] or ["(1 2 3)"]
    return "error"


def _asf_direction(rng, files, model):
    idx = where(files[0], "b_direction")
    it = files[0][pick(rng, idx)]
    choice = int(rng.integers(4))
    it.toks[1:] = [["0", "0", "0"], ["1", "0"], ["nan", "0", "1"], ["1e300", "-1e300", "0"]][choice]
    return ["ok", "error", "error", "ok"][choice]


def _asf_length(rng, files, model):
    idx = where(files[0], "b_length")
    it = files[0][pick(rng, idx)]
    choice = int(rng.integers(5))
    it.toks[1:] = [["1e308"], ["nan"], ["-5"], ["0"], ["1", "2"]][choice]
    return ["any", "error", "ok", "ok", "error"][choice]


def _amc_value(rng, files, model):
    bad = chance(rng, 0.5)
    new = pick(rng, NON_FINITE if bad else HUGE_OK)
    idx = [k for k in where(files[1], "bone_line") if len(files[1][k].toks) > 1]
    if not idx:
        return None
    it = files[1][pick(rng, idx)]
    it.toks[int(rng.integers(1, len(it.toks)))] = new
    return "error" if bad else "any"


def _has_values(it: Item) -> bool:
    return len(it.toks) > 1


def _no_values(it: Item) -> bool:
    return len(it.toks) == 1


ASF_RULES: dict[str, Callable] = {
    "drop:root_order": _drop("r_order", "error"),
    "drop:bone_name": _drop("b_name", "error"),
    "drop:bone_direction": _drop("b_direction", "error"),
    "drop:bone_length": _drop("b_length", "error"),
    "drop:bone_end": _drop("end", "error"),
    "drop:hierarchy_link": _drop("h_link", "error"),
    "drop:section": _drop(("root", "bonedata", "hierarchy"), "error"),
    "drop:dof": _drop("b_dof", "error", only=lambda it: len(it.toks) > 1),
    "drop:bone_line": _drop("bone_line", "error", side=1, only=_has_values),
    "drop:bone_line_without_dof": _drop("bone_line", "ok", side=1, only=_no_values),
    "drop:frame_number": _drop("frame_no", "error", side=1),
    "drop:frames": _amc_drop_frames,
    "dup:bone": _asf_dup_bone,
    "dup:section": _dup(("version", "aname", "units", "root", "bonedata", "hierarchy"), "error"),
    "dup:documentation": _dup("doc", "ok"),
    "dup:hierarchy_child": _asf_dup_child,
    "dup:bone_line": _dup("bone_line", "error", side=1),
    "dup:frame_number": _dup("frame_no", "error", side=1),
    "dup:comment": _dup("comment", "ok"),
    "range:units_length": _asf_units,
    "range:angle_unit": _token("u_angle", ["grad", "degrees", "radian"], "error"),
    "token:dof": _token("b_dof", ["tx", "l", "rw", "rx,", "r x"], "error"),
    "dup:dof": _token("b_dof", ["rx", "ry", "rz"], "any"),
    "range:axis_order": _token("b_axis", ["XXY", "XY", "XYZW", "ABC"], "error", first=4),
    "range:root_axis": _token("r_axis", ["XY", "XXZ", "XYZ Z"], "error"),
    "token:root_order": _token("r_order", ["TW", "RX2", "T", "X"], "error"),
    "count:limits": _asf_limit_count,
    "range:limit": _asf_limit_value,
    "cycle:hierarchy": _asf_cycle,
    "token:hierarchy_bone": _token("h_link", ["no_such_bone", "ROOT", "begin"], "error"),
    "range:direction": _asf_direction,
    "range:length": _asf_length,
    "range:amc_value": _amc_value,
    "count:amc_values": _amc_width,
    "token:amc_bone": _token("bone_line", ["no_such_bone", "Root", ":x"], "error", side=1, first=0),
    "range:frame_number": _amc_frame_no,
    "order:amc_keyword": _amc_keyword_inside,
    "token:amc_number": _token("bone_line", BAD_TOKENS, "error", side=1),
    "token:asf_number": _token(("b_direction", "b_length", "r_orientation"), BAD_TOKENS, "error"),
}


def asfamc_case(rng: np.random.Generator, *, perturb: float = 0.5, rule: str | None = None) -> Case:
    """An ASF/AMC pair (the AMC is the case's file, the ASF its skeleton): valid, or (with
    probability ``perturb``) grammar rules broken in either file (:func:`.core.apply_rules`);
    ``rule``: that rule, always."""
    model = _asf_model(rng)
    files = [_asf_items(rng, model), _amc_items(rng, model)]
    only, (rule, expect) = rule, ("valid", "ok")
    if only or chance(rng, perturb):
        rule, expect = apply_rules(rng, ASF_RULES, files, model, only=only)
    layout = random_layout(rng)
    asf = render(files[0], layout, rng).encode("utf-8")
    amc = render(files[1], layout if chance(rng, 0.5) else random_layout(rng), rng).encode("utf-8")
    return Case("grammar.amc", amc, asf, "asfamc", rule, expect)
