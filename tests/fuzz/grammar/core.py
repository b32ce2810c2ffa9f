"""The grammar generators' common parts: cases, grammar items and their layout as text,
number spellings, names, and helpers of the perturbation rules (see the package docstring)."""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

# ------------------------------------------------------------------------------------------
# Cases, items, layout
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """A generated file: ``name`` (its extension selects the reader), ``data``, the ASF an AMC
    is read with, the format, the perturbation ``rule`` (``"valid"`` for none) and what the
    reader must do (``expect``: ``"ok"``, ``"error"`` or ``"any"``)."""

    name: str
    data: bytes
    asf: bytes | None
    fmt: str
    rule: str
    expect: str


@dataclass
class Item:
    """One line of the grammar: its ``kind``, nesting ``depth`` and tokens (the first ``kw``
    of which are keywords, whose case the layout may change)."""

    kind: str
    depth: int
    toks: list[str]
    kw: int = 0
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Layout:
    """How items become text: line end, indentation, token separator, keyword case, blank
    lines, trailing whitespace, braces on the name's line, tokens one per line."""

    nl: str
    indent: str
    sep: str
    case: str
    blank: float
    trailing: str
    brace_inline: bool
    split: bool
    final_nl: bool


def pick(rng: np.random.Generator, seq):
    return seq[int(rng.integers(len(seq)))]


def chance(rng: np.random.Generator, p: float) -> bool:
    return bool(rng.random() < p)


def random_layout(rng: np.random.Generator) -> Layout:
    """A layout: mostly ordinary (LF, tabs, one space), now and then every variant."""
    odd = chance(rng, 0.4)
    return Layout(
        nl=pick(rng, ["\n", "\r\n", "\r"]) if odd else "\n",
        indent=pick(rng, ["\t", "  ", "    ", "", " \t"]) if odd else "\t",
        sep=pick(rng, [" ", "\t", "   ", " \t "]) if odd else " ",
        case=pick(rng, ["asis", "upper", "lower", "title"]) if odd else "asis",
        blank=pick(rng, [0.0, 0.05, 0.3]) if odd else 0.0,
        trailing=pick(rng, ["", " ", "\t", "  \t"]) if odd else "",
        brace_inline=chance(rng, 0.3),
        split=odd and chance(rng, 0.3),
        final_nl=not (odd and chance(rng, 0.3)),
    )


def _case_kw(tok: str, case: str) -> str:
    return {"upper": tok.upper(), "lower": tok.lower(), "title": tok.title()}.get(case, tok)


def render(items: list[Item], layout: Layout, rng: np.random.Generator, *, inline_kinds=()) -> str:
    """Text of ``items`` in ``layout``: items of ``inline_kinds`` (opening braces) join the
    previous line when ``layout.brace_inline``; with ``layout.split`` the tokens of items
    marked ``extra["splittable"]`` go one per line."""
    lines: list[str] = []
    for it in items:
        toks = [_case_kw(t, layout.case) if k < it.kw else t for k, t in enumerate(it.toks)]
        ind = layout.indent * it.depth
        if it.kind in inline_kinds and layout.brace_inline and lines and lines[-1].strip():
            lines[-1] = lines[-1] + layout.sep + layout.sep.join(toks)
            continue
        if layout.split and it.extra.get("splittable") and len(toks) > 1:
            lines.append(ind + toks[0])
            lines += [ind + layout.indent + t for t in toks[1:]]
        else:
            lines.append(ind + layout.sep.join(toks))
        if layout.blank and chance(rng, layout.blank):
            lines.append(pick(rng, ["", layout.trailing, " "]))
    text = layout.nl.join(line + layout.trailing if line.strip() else line for line in lines)
    return text + layout.nl if layout.final_nl else text


# ------------------------------------------------------------------------------------------
# Numbers
# ------------------------------------------------------------------------------------------

#: Number spellings of the text formats (BVH, ASF, AMC); JSON allows only :data:`JSON_STYLES`.
TEXT_STYLES = ("repr", "fixed", "g", "exp", "EXP", "plus", "bare_point", "long", "lead_zero", "int")
JSON_STYLES = ("repr", "fixed", "g", "exp", "EXP", "long", "int")


def fmt_num(x: float, style: str) -> str:
    """``x`` written in ``style`` (the value read back may be rounded; it is never changed in
    kind: a finite number stays one)."""
    x = float(x)
    if style == "fixed":
        s = f"{x:.6f}"
    elif style == "g":
        s = f"{x:.10g}"
    elif style == "exp":
        s = f"{x:.12e}"
    elif style == "EXP":
        s = f"{x:.8E}"
    elif style == "long":
        s = f"{x:.20f}" if abs(x) < 1e6 else repr(x)
    elif style == "int":
        s = str(round(x)) if abs(x) < 1e15 else repr(x)
    elif style == "plus":
        s = ("+" if math.copysign(1.0, x) > 0 else "") + repr(x)
    elif style == "bare_point":
        s = f"{x:.7f}".rstrip("0")  # "5." for 5, "-0.25" -> "-.25"
        s = s.replace("0.", ".", 1) if s.lstrip("-").startswith("0.") and s.lstrip("-") != "0." else s
    elif style == "lead_zero":
        s = ("-" if x < 0 else "") + "00" + f"{abs(x):.6f}"
    else:
        s = repr(x)
    return s


def number_writer(
    rng: np.random.Generator, styles: tuple[str, ...], mix: float = 0.1
) -> Callable[[float], str]:
    """A writer of numbers for one file: one spelling of ``styles`` mostly, another one
    for a fraction ``mix`` of the numbers (drawn from a fast generator seeded by ``rng``)."""
    main = pick(rng, styles)
    fast = random.Random(int(rng.integers(1 << 62)))

    def write(x: float) -> str:
        return fmt_num(x, main if fast.random() >= mix else fast.choice(styles))

    return write


# ------------------------------------------------------------------------------------------
# Names
# ------------------------------------------------------------------------------------------

ODD_NAMES = [
    "Bip01 L Thigh",
    "mixamorig:Hips",
    "Bone.001",
    "joint-3",
    "Genou_gauche",
    "Ünïcödé",
    "日本語",
    "😀",
    "<!--<script>",
    '=HYPERLINK("http://x","y")',
    "a&b;",
    "'quote'",
    '"dq"',
    "}",
    "{",
    "()",
    "#hash",
    "%s%d",
    "back\\slash",
    "tab\tinside",
    "nbsp\u00a0inside",
    "ideo\u3000space",
    "line\u2028sep",
    "nel\x85x",
    "MOTION",
    "OFFSET",
    "End",
    "Site",
    "123",
    "-1.5",
    "x" * 300,
]
PLAIN_NAMES = ["Hips", "Spine", "Chest", "Neck", "Head", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightArm"]
PLAIN_NAMES += ["RightForeArm", "RightHand", "l_knee", "r_elbow", "lfemur", "rtibia", "thorax", "toe"]


def unique_name(
    rng: np.random.Generator, used: set[str], normal: Callable[[str], str], ok: Callable[[str], bool]
) -> str:
    """A name, unique once normalised by ``normal``, passing ``ok``."""
    for attempt in range(100):
        base = pick(rng, ODD_NAMES) if chance(rng, 0.15) else pick(rng, PLAIN_NAMES)
        name = base if attempt == 0 and chance(rng, 0.5) else f"{base}{len(used)}"
        if ok(name) and normal(name) and normal(name) not in used:
            used.add(normal(name))
            return name
    name = f"j{len(used)}_{int(rng.integers(1 << 30))}"
    used.add(normal(name))
    return name


# ------------------------------------------------------------------------------------------
# Shared perturbation helpers
# ------------------------------------------------------------------------------------------


def where(items: list[Item], kind: str | tuple[str, ...]) -> list[int]:
    kinds = (kind,) if isinstance(kind, str) else kind
    return [k for k, it in enumerate(items) if it.kind in kinds]


def copy_item(it: Item) -> Item:
    return Item(it.kind, it.depth, list(it.toks), it.kw, dict(it.extra))


def replace_token(items: list[Item], kind: str | tuple[str, ...], rng, new: str, first: int = 1) -> bool:
    """Replace one token (from index ``first``) of a random item of ``kind``; False if none."""
    idx = [k for k in where(items, kind) if len(items[k].toks) > first]
    if not idx:
        return False
    it = items[pick(rng, idx)]
    t = int(rng.integers(first, len(it.toks)))
    if new == "":
        del it.toks[t]
    else:
        it.toks[t] = new
    return True


BAD_TOKENS = ["1,5", "0x10", "1_000", "--1", "1e", ".", "1.2.3", "e5", "+-1", "١٢", "１", "1e+", "NaN0"]
NON_FINITE = ["nan", "inf", "-inf", "NaN", "1e309", "-1e400", "Infinity"]
HUGE_OK = ["1e300", "-1e300", "5e-324", "1e-310", "1e20", "-2.5e15"]


def apply_rules(
    rng: np.random.Generator, rules: dict[str, Callable], *args, only: str | None = None
) -> tuple[str, str]:
    """Break the file ``args`` describe with one rule of ``rules`` (four times in five) or two
    to three: ``(rule, expect)``, the names joined by ``+``. A rule returns what the reader
    must do, or None when it does not apply (the file has no such item): it is dropped, and
    no rule left is ``("valid", "ok")``. Several rules may undo one another (a row dropped,
    another duplicated): their ``expect`` is ``"any"``; a second rule may also find the items
    in a state it was not written for (an exception): it is dropped too. ``only`` applies
    that one rule."""
    names, expects = [], []
    for k in range(1 if only or chance(rng, 0.8) else int(rng.integers(2, 4))):
        name = only or pick(rng, list(rules))
        try:
            expect = rules[name](rng, *args)
        except (IndexError, ValueError, TypeError, AttributeError):
            if k == 0:
                raise
            continue
        if expect is not None:
            names.append(name)
            expects.append(expect)
    if not names:
        return "valid", "ok"
    return "+".join(names), expects[0] if len(names) == 1 else "any"
