"""BVH files from the grammar: random trees, channels, End Sites, frames; the BVH rules."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

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

_POS = ("Xposition", "Yposition", "Zposition")
_ROT = ("Xrotation", "Yrotation", "Zrotation")


def _bvh_normal(name: str) -> str:
    return " ".join(name.split())


def _bvh_name_ok(name: str) -> bool:
    return "{" not in name.split() and "\r" not in name and "\n" not in name


@dataclass
class _BvhJoint:
    name: str
    offset: np.ndarray
    channels: list[str]
    children: list[int] = field(default_factory=list)
    sites: list[tuple[str | None, np.ndarray, int]] = field(default_factory=list)
    wide: bool = False  # a 2-rotation-channel joint whose second angle passes +-90 degrees


def _bvh_channels(rng: np.random.Generator, root: bool) -> list[str]:
    """0 to 6 distinct channels: position then rotation channels, or any order."""
    if root:
        n = int(rng.choice([6, 6, 6, 3, 0, 1, 2, 4, 5]))
    else:
        n = int(rng.choice([3, 3, 3, 3, 0, 1, 2, 2, 6, 4, 5]))
    n_pos = 0 if n == 0 else int(rng.integers(max(0, n - 3), min(3, n) + 1))
    if not root and n <= 3 and chance(rng, 0.75):
        n_pos = 0  # mostly rotation channels below the root
    pos = [_POS[a] for a in sorted(rng.permutation(3)[:n_pos])]
    rot = [_ROT[a] for a in rng.permutation(3)[: n - n_pos]]
    if chance(rng, 0.2):
        return [str(c) for c in rng.permutation(pos + rot)]
    return pos + rot


def _bvh_tree(rng: np.random.Generator) -> list[_BvhJoint]:
    n = int(rng.choice([1, 2, 3, 5, 8, 8, 12, 12, 20, 40]))
    shape = pick(rng, ["chain", "bush", "random", "random"])
    unit = float(rng.choice([0.05, 1.0, 10.0, 100.0]))
    used: set[str] = set()
    joints: list[_BvhJoint] = []
    for j in range(n):
        off = rng.normal(0.0, unit, 3) if j else rng.normal(0.0, unit, 3) * float(rng.choice([0.0, 1.0]))
        name = unique_name(rng, used, _bvh_normal, _bvh_name_ok)
        joints.append(_BvhJoint(name, off, _bvh_channels(rng, j == 0)))
        if j:
            parent = {"chain": j - 1, "bush": min(j - 1, int(rng.integers(0, 3)))}.get(
                shape, int(rng.integers(j))
            )
            joints[parent].children.append(j)
    for jt in joints:
        n_sites = (
            (1 if chance(rng, 0.8) else int(rng.choice([0, 2]))) if not jt.children else int(chance(rng, 0.1))
        )
        for _ in range(n_sites):
            name = None if chance(rng, 0.8) else pick(rng, ["Site", "End", "tip", "Ünï", "x y"])
            jt.sites.append((name, rng.normal(0.0, unit, 3), int(rng.integers(len(jt.children) + 1))))
        jt.wide = sum(c in _ROT for c in jt.channels) == 2 and chance(rng, 0.04)
    return joints


def _bvh_order(joints: list[_BvhJoint]) -> list[int]:
    order, todo = [], [0]
    while todo:
        k = todo.pop()
        order.append(k)
        todo.extend(reversed(joints[k].children))
    return order


def _bvh_values(rng: np.random.Generator, joints: list[_BvhJoint], n_frames: int) -> np.ndarray:
    """Frame values ``(F, C)`` in file order: positions near the offsets, angles in degrees
    (mostly within +-180, some beyond; a 2-rotation-channel joint's second angle within
    +-90 degrees unless the joint is ``wide``)."""
    cols = []
    t = np.linspace(0.0, 1.0, n_frames)
    for j in _bvh_order(joints):
        jt = joints[j]
        size = max(float(np.abs(jt.offset).max()), 1.0)
        n_rot = sum(c in _ROT for c in jt.channels)
        slot = 0
        for c in jt.channels:
            if c in _POS:
                base = jt.offset[_POS.index(c)]
                amp = size * (10.0 if j == 0 else 0.2)
                cols.append(base + amp * np.sin(2 * np.pi * (t + rng.random())) * rng.random())
                continue
            second = n_rot == 2 and slot == 1
            if second and jt.wide:  # past +-90 degrees (or on it) in some frames
                cols.append(rng.uniform(-1.0, 1.0, n_frames) * 90.0 + float(rng.choice([-90.0, 90.0])))
            elif second:
                cols.append(rng.uniform(-89.0, 89.0, n_frames))  # "int" spelling keeps it off 90
            elif chance(rng, 0.05):
                cols.append(np.full(n_frames, float(rng.choice([90.0, -90.0, 180.0, 0.0]))))
            else:
                lim = float(rng.choice([180.0, 180.0, 720.0]))
                cols.append(rng.uniform(-lim, lim, n_frames))
            slot += 1
    return np.stack(cols, axis=1) if cols else np.zeros((n_frames, 0))


def _bvh_items(
    rng: np.random.Generator, joints: list[_BvhJoint], values: np.ndarray, frame_time: str
) -> list[Item]:
    """The grammar items of the file (hierarchy depth-first, End Sites among the children)."""
    num = number_writer(rng, TEXT_STYLES)
    items = [Item("hierarchy", 0, ["HIERARCHY"], 1)]
    stack: list[tuple[str, int, int, int]] = [("open", 0, 0, 0)]  # (action, joint, depth, site)
    while stack:
        action, j, d, s = stack.pop()
        jt = joints[j]
        if action == "close":
            items.append(Item("close", d, ["}"]))
        elif action == "site":
            name, off, _ = jt.sites[s]
            items.append(Item("end", d + 1, ["End", "Site", *([name] if name else [])], 2))
            items.append(Item("es_open", d + 1, ["{"]))
            items.append(Item("es_offset", d + 2, ["OFFSET", *map(num, off)], 1, {"splittable": True}))
            items.append(Item("es_close", d + 1, ["}"]))
        else:
            kw = "ROOT" if j == 0 else "JOINT"
            items.append(Item("root" if j == 0 else "joint", d, [kw, jt.name], 1))
            items.append(Item("open", d, ["{"]))
            body = [Item("offset", d + 1, ["OFFSET", *map(num, jt.offset)], 1, {"splittable": True})]
            if jt.channels or chance(rng, 0.5):  # "CHANNELS 0" or no line at all
                count = str(len(jt.channels)) if chance(rng, 0.95) else f"0{len(jt.channels)}"
                toks = ["CHANNELS", count, *jt.channels]
                body.insert(
                    0 if chance(rng, 0.1) else 1, Item("channels", d + 1, toks, 1, {"splittable": True})
                )
            items += body
            kids = [("open", c, d + 1, 0) for c in jt.children]
            for s2, (_, _, pos) in enumerate(jt.sites):
                kids.insert(pos + s2, ("site", j, d, s2))
            stack.append(("close", j, d, 0))
            stack.extend(reversed(kids))
    frames = pick(rng, ["Frames:", "Frames:", "FRAMES :", "frames:"])
    ft = pick(rng, ["Frame Time:", "Frame Time:", "Frame\tTime:", "frame time :"])
    items += [
        Item("motion", 0, ["MOTION"], 1),
        Item("frames", 0, [frames, pick(rng, ["", "", "", "00"]) + str(len(values))]),
    ]
    items.append(Item("frame_time", 0, [ft, frame_time]))
    items += [Item("row", 0, [num(v) for v in row]) for row in values]
    return items


def _bvh_frame_time(rng: np.random.Generator) -> str:
    fps = float(rng.choice([24.0, 25.0, 30.0, 30.0, 60.0, 120.0, 29.97, 7.5, 1000.0, 0.5]))
    if chance(rng, 0.5):
        return pick(rng, [f"{1 / fps:.7f}", f"{1 / fps:.8f}".rstrip("0")])  # as exporters write it
    return fmt_num(1 / fps, pick(rng, [s for s in TEXT_STYLES if s != "int"]))


def _bvh_drop(kind: str, expect: str | Callable[[Item, int], str]):
    def rule(rng, items, n_ch):
        idx = where(items, kind)
        if not idx:
            return None
        k = pick(rng, idx)
        it = items.pop(k)
        return expect(it, n_ch) if callable(expect) else expect

    return rule


def _bvh_dup(kind: str, expect: str | Callable[[Item, int], str], block: int = 1):
    def rule(rng, items, n_ch):
        idx = where(items, kind)
        if not idx:
            return None
        k = pick(rng, idx)
        items[k + block : k + block] = [copy_item(it) for it in items[k : k + block]]
        return expect(items[k], n_ch) if callable(expect) else expect

    return rule


def _bvh_dup_name(rng, items, n_ch):
    idx = where(items, ("root", "joint"))
    if len(idx) < 2:
        return None
    a, b = rng.choice(idx, 2, replace=False)
    items[int(b)].toks[1] = items[int(a)].toks[1]
    return "error"


def _bvh_empty_name(rng, items, n_ch):
    idx = where(items, ("root", "joint"))
    if not idx:
        return None
    items[pick(rng, idx)].toks[1:] = []
    return "error"


def _bvh_channel_count(rng, items, n_ch):
    idx = where(items, "channels")
    if not idx:
        return None
    it = items[pick(rng, idx)]
    n = int(it.toks[1])
    it.toks[1] = pick(rng, ["7", "99999999999", "-1", "x", "3.0", str(n + 1), str(n - 1) if n else "-1", "٣"])
    return "error"


def _bvh_channel_name(rng, items, n_ch):
    idx = [k for k in where(items, "channels") if len(items[k].toks) > 2]
    if not idx:
        return None
    it = items[pick(rng, idx)]
    t = int(rng.integers(2, len(it.toks)))
    dup = [it.toks[3 if t == 2 else 2]] if len(it.toks) > 3 else []
    it.toks[t] = pick(rng, ["xrotation", "Wrotation", "Xrot", "XROTATION", "Xposition,", *dup])
    return "error"


def _bvh_frames(rng, items, n_ch):
    idx = where(items, "frames")
    if not idx:
        return None
    it = items[idx[0]]
    f = int(it.toks[1])
    new = pick(rng, ["0", str(f + 1), str(f - 1), "1000000000000", "1" + "0" * 40, "-1", "1e3", "5.0", ""])
    if new == "":
        del it.toks[1]
        return "error"
    it.toks[1] = new
    return "ok" if n_ch == 0 and new in (str(f + 1), str(f - 1)) and int(new) >= 1 else "error"


def _bvh_frame_time_range(rng, items, n_ch):
    idx = where(items, "frame_time")
    if not idx:
        return None
    it = items[idx[0]]
    it.toks[1] = pick(
        rng, ["0", "-0.0333", "1e-9", "1e-5", "20", "nan", "inf", "1e-320", "1e400", "0x1", "-0"]
    )
    return "error"


def _bvh_value(rng, items, n_ch):
    if chance(rng, 0.5):
        return "error" if replace_token(items, ("row",), rng, pick(rng, NON_FINITE), first=0) else None
    return "any" if replace_token(items, ("row",), rng, pick(rng, HUGE_OK), first=0) else None


def _bvh_offset_value(rng, items, n_ch):
    if chance(rng, 0.5):
        return "error" if replace_token(items, ("offset", "es_offset"), rng, pick(rng, NON_FINITE)) else None
    return "any" if replace_token(items, ("offset", "es_offset"), rng, pick(rng, HUGE_OK)) else None


def _bvh_token_number(rng, items, n_ch):
    kinds = ("offset", "es_offset") if chance(rng, 0.5) or n_ch == 0 else ("row",)
    return (
        "error"
        if replace_token(items, kinds, rng, pick(rng, BAD_TOKENS), first=int(kinds != ("row",)))
        else None
    )


def _bvh_keyword(rng, items, n_ch):
    kinds = {"hierarchy": "HIERARCH", "root": "ROOTS", "joint": "JOINTS", "offset": "OFFSETS"}
    kinds |= {"channels": "CHANNEL", "end": "Endsite", "motion": "MOTIONS"}
    kind = pick(rng, list(kinds))
    idx = where(items, kind)
    if not idx:
        return None
    items[pick(rng, idx)].toks[0] = kinds[kind]
    return "error"


def _bvh_row_width(rng, items, n_ch):
    idx = where(items, "row")
    if not idx:
        return None
    it = items[pick(rng, idx)]
    if it.toks and chance(rng, 0.5):
        it.toks.pop(int(rng.integers(len(it.toks))))
    else:
        it.toks.append("0.5")
    return "error"


def _bvh_deep(rng, items, n_ch):
    """More joints than the limit, nested: refused before the frames are read."""
    from elastic_motion import limits

    n = limits.current().max_joints + 1
    k = where(items, "open")[0] + 1
    chain = []
    for d in range(n):
        chain += [
            Item("joint", 1, ["JOINT", f"deep{d}"], 1),
            Item("open", 1, ["{"]),
            Item("offset", 1, ["OFFSET", "0", "1", "0"], 1),
        ]
    items[k:k] = chain + [Item("close", 1, ["}"]) for _ in range(n)]
    return "error"


BVH_RULES: dict[str, Callable] = {
    "drop:offset": _bvh_drop("offset", "error"),
    "drop:channels": _bvh_drop("channels", lambda it, n: "ok" if int(it.toks[1]) == 0 else "error"),
    "drop:open": _bvh_drop("open", "error"),
    "drop:close": _bvh_drop(("close", "es_close"), "error"),
    "drop:end_site_offset": _bvh_drop("es_offset", "error"),
    "drop:hierarchy": _bvh_drop("hierarchy", "error"),
    "drop:motion": _bvh_drop("motion", "error"),
    "drop:frames": _bvh_drop("frames", "error"),
    "drop:frame_time": _bvh_drop("frame_time", "error"),
    "drop:row": _bvh_drop("row", lambda it, n: "ok" if n == 0 else "error"),
    "dup:offset": _bvh_dup("offset", "error"),
    "dup:channels": _bvh_dup("channels", "error"),
    "dup:close": _bvh_dup("close", "error"),
    "dup:end_site": _bvh_dup("end", "ok", block=4),
    "dup:frames": _bvh_dup("frames", "error"),
    "dup:row": _bvh_dup("row", lambda it, n: "ok" if n == 0 else "error"),
    "dup:name": _bvh_dup_name,
    "drop:name": _bvh_empty_name,
    "count:channels": _bvh_channel_count,
    "token:channel": _bvh_channel_name,
    "range:frames": _bvh_frames,
    "range:frame_time": _bvh_frame_time_range,
    "range:value": _bvh_value,
    "range:offset": _bvh_offset_value,
    "token:number": _bvh_token_number,
    "token:keyword": _bvh_keyword,
    "count:row": _bvh_row_width,
    "limit:joints": _bvh_deep,
}


def bvh_case(rng: np.random.Generator, *, perturb: float = 0.5, rule: str | None = None) -> Case:
    """A BVH file: valid, or (with probability ``perturb``) grammar rules broken
    (:func:`.core.apply_rules`); ``rule``: that rule, always."""
    joints = _bvh_tree(rng)
    n_frames = int(rng.choice([1, 2, 3, 5, 10, 10, 30, 100]))
    values = _bvh_values(rng, joints, n_frames)
    items = _bvh_items(rng, joints, values, _bvh_frame_time(rng))
    only, (rule, expect) = rule, ("valid", "ok")
    if only or chance(rng, perturb):
        rule, expect = apply_rules(rng, BVH_RULES, items, values.shape[1], only=only)
    text = render(items, random_layout(rng), rng, inline_kinds=("open", "es_open"))
    return Case("grammar.bvh", text.encode("utf-8"), None, "bvh", rule, expect)
