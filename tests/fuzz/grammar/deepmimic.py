"""DeepMimic clips from the grammar: JSON members, frames of 44 numbers, durations; their rules."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .core import JSON_STYLES, Case, apply_rules, chance, number_writer, pick


def _dm_joints() -> list[bool]:
    from elastic_motion.motion.deepmimic import DEEPMIMIC_JOINTS

    return [rev for _, _, rev in DEEPMIMIC_JOINTS[1:]]


@dataclass
class _Dm:
    """A DeepMimic clip as JSON tokens: ``members`` ``(key, value)`` in file order, where the
    value ``None`` stands for ``frames`` (rows of number tokens, or any JSON text)."""

    members: list[tuple[str, str | None]]
    frames: list[list[str] | str]
    durations: list[float]


def _dm_model(rng: np.random.Generator) -> _Dm:
    f = int(rng.choice([1, 2, 3, 5, 10, 10, 30]))
    dt = 1.0 / float(rng.choice([30.0, 60.0, 29.97, 120.0, 24.0, 20.0]))
    durations = [dt] * f
    if f > 2 and chance(rng, 0.2):  # unequal durations: the reader resamples
        durations = list(dt * rng.uniform(0.5, 1.5, f))
    if f > 1 and chance(rng, 0.3):
        durations[-1] = 0.0
    num = number_writer(rng, JSON_STYLES)
    exact = number_writer(rng, tuple(s for s in JSON_STYLES if s != "int"))  # durations, quaternions
    revolute = _dm_joints()
    frames: list[list[str] | str] = []
    for k in range(f):
        quats = rng.normal(size=(1 + revolute.count(False), 4))
        quats *= (
            rng.choice([1.0, 1.0, 0.5, 3.0], size=(len(quats), 1)) / np.linalg.norm(quats, axis=1)[:, None]
        )
        angles = iter(rng.uniform(-2.5, 2.5, len(revolute)))
        q = iter([[exact(v) for v in row] for row in quats])
        row = [exact(durations[k]), *map(num, rng.normal(0.0, 0.3, 3) + (0.0, 0.9, 0.0)), *next(q)]
        for rev in revolute:
            row += [num(next(angles))] if rev else next(q)
        frames.append(row)
    members: list[tuple[str, str | None]] = [
        ("Loop", pick(rng, ['"wrap"', '"none"', '"WRAP"'])),
        ("Frames", None),
    ]
    if chance(rng, 0.2):
        members.append(("Extra", pick(rng, ['{"a": [1, 2.5e3]}', '"text"', "null", "[]"])))
    if chance(rng, 0.3):
        members = [members[int(k)] for k in rng.permutation(len(members))]
    return _Dm(members, frames, durations)


def _dm_render(rng: np.random.Generator, dm: _Dm) -> str:
    """JSON text: compact, one frame per line (as DeepMimic writes), or one value per line."""
    form = pick(rng, ["compact", "lines", "lines", "values"])
    comma = pick(rng, [",", ", ", " , "]) if form != "values" else ","
    nl = pick(rng, ["\n", "\n", "\r\n"])

    def frame(fr: list[str] | str) -> str:
        if isinstance(fr, str):
            return fr
        if form == "values":
            return "[" + nl + ("," + nl).join("\t\t" + v for v in fr) + nl + "\t]"
        return "[" + comma.join(fr) + "]"

    sep = "," if form == "compact" else "," + nl
    body = "[" + ("" if form == "compact" else nl) + sep.join(frame(fr) for fr in dm.frames)
    body += ("" if form == "compact" else nl) + "]"
    parts = [f'"{key}": {body if value is None else value}' for key, value in dm.members]
    inner = sep.join(parts)
    return "{" + inner + "}" if form == "compact" else "{" + nl + inner + nl + "}" + nl


def _dm_width(rng, dm):
    fr = pick(rng, dm.frames)
    if chance(rng, 0.5):
        fr.pop(int(rng.integers(len(fr))))
    else:
        fr.insert(int(rng.integers(len(fr) + 1)), "0.5")
    return "error"


def _dm_frame_type(rng, dm):
    dm.frames[int(rng.integers(len(dm.frames)))] = pick(rng, ["{}", '"x"', "5", "null", "[]", "true"])
    return "error"


def _dm_value(new: list[str], expect: str, first: int = 0):
    def rule(rng, dm):
        fr = pick(rng, dm.frames)
        fr[int(rng.integers(first, len(fr)))] = pick(rng, new)
        return expect

    return rule


def _dm_duration(rng, dm):
    k = int(rng.integers(len(dm.frames)))
    choice = pick(rng, ["negative", "zero", "all_zero", "tiny", "fast", "slow", "long"])
    if choice == "negative":
        dm.frames[k][0] = "-0.0333"
        return "error"
    if choice == "zero":
        dm.frames[0][0] = "0"  # a zero step (or a one-frame clip of no duration)
        return "error"
    if choice == "all_zero":
        for fr in dm.frames:
            fr[0] = "0.0"
        return "error"
    if choice in ("fast", "slow"):
        for fr in dm.frames:
            fr[0] = "1e-5" if choice == "fast" else "100"
        return "error"
    dm.frames[k][0] = "1e-320" if choice == "tiny" else "100"
    return "any"


def _dm_zero_quaternion(rng, dm):
    fr = pick(rng, dm.frames)
    fr[4:8] = ["0", "0.0", "-0", "0e5"]
    return "error"


def _dm_frames_member(rng, dm):
    if chance(rng, 0.5):
        dm.members = [(k, v) for k, v in dm.members if k != "Frames"]
    else:
        dm.members = [
            (k, v if k != "Frames" else pick(rng, ["[]", "{}", '"x"', "null", "5", "[[]]"]))
            for k, v in dm.members
        ]
    return "error"


def _dm_dup_frame(rng, dm):
    k = int(rng.integers(len(dm.frames)))
    dm.frames.insert(k, list(dm.frames[k]))
    zero_inside = float(dm.frames[k][0]) == 0.0
    return "error" if zero_inside else "any"


def _dm_drop_frame(rng, dm):
    if len(dm.frames) == 1:
        dm.frames.clear()
        return "error"
    del dm.frames[int(rng.integers(len(dm.frames)))]
    return "any"


DM_RULES: dict[str, Callable] = {
    "count:frame_width": _dm_width,
    "type:frame": _dm_frame_type,
    "type:value": _dm_value(['"0.1"', "true", "false", "null", "[]", "{}"], "error"),
    "range:value": _dm_value(["NaN", "Infinity", "-Infinity", "1e400", "1" + "0" * 400, "9" * 5000], "error"),
    "range:big_value": _dm_value(
        ["1e300", "-1e300", "5e-324", "123456789012345678901234567890"], "any", first=1
    ),
    "range:duration": _dm_duration,
    "range:quaternion": _dm_zero_quaternion,
    "drop:frames": _dm_frames_member,
    "dup:frame": _dm_dup_frame,
    "drop:frame": _dm_drop_frame,
    "drop:loop": lambda rng, dm: (setattr(dm, "members", [m for m in dm.members if m[0] != "Loop"]), "ok")[1],
    "dup:frames": lambda rng, dm: (dm.members.append(("Frames", None)), "ok")[1],
}

#: Rules applied to the rendered text: (text, rng) -> (text, expect).
DM_TEXT_RULES: dict[str, Callable[[str, np.random.Generator], tuple[str, str]]] = {
    "drop:closing": lambda text, rng: (text.rstrip()[: -int(rng.integers(1, 3))], "error"),
    "dup:trailing": lambda text, rng: (text + pick(rng, ["x", "}", ",", "[]"]), "error"),
    "dup:whitespace": lambda text, rng: (" \t\n" + text + "\n\n  ", "ok"),
    "type:top_level": lambda text, rng: ("[" + text + "]", "error"),
    "limit:nesting": lambda text, rng: ('{"Frames": ' + "[" * 5000 + "]" * 5000 + "}", "error"),
}


def deepmimic_case(rng: np.random.Generator, *, perturb: float = 0.5, rule: str | None = None) -> Case:
    """A DeepMimic clip: valid, or (with probability ``perturb``) rules broken (one on the
    text, or :func:`.core.apply_rules` on the clip); ``rule``: that rule, always."""
    dm = _dm_model(rng)
    only, (rule, expect) = rule, ("valid", "ok")
    text_rule = None
    if only is None and chance(rng, perturb):  # "": rules on the clip, drawn by apply_rules
        n_text = len(DM_TEXT_RULES)
        only = pick(rng, list(DM_TEXT_RULES)) if chance(rng, n_text / (n_text + len(DM_RULES))) else ""
    if only in DM_TEXT_RULES:
        rule, text_rule = only, DM_TEXT_RULES[only]
    elif only is not None:
        rule, expect = apply_rules(rng, DM_RULES, dm, only=only or None)
    text = _dm_render(rng, dm)
    if text_rule is not None:
        text, expect = text_rule(text, rng)
    return Case("grammar_dm.txt", text.encode("utf-8"), None, "deepmimic", rule, expect)
