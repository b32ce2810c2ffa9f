"""The DeepMimic reader checks a clip's structure while it reads (issue 32).

A file of millions of empty frames used to become a Python list of millions of lists (870 MB
for 30 MB) before its error on frame 0; now the first bad frame stops the reading, with
memory of the order of the file's text. Every error names the file and a line, and what
was expected and what came.
"""

from __future__ import annotations

import json
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from elastic_motion.errors import ParseError
from elastic_motion.motion import read_deepmimic
from elastic_motion.motion.deepmimic import DEEPMIMIC_JOINTS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fuzz"))

from mutations import load_seeds, mutate


def _frames(n: int = 5) -> list[list[float]]:
    joints = [v for _, _, rev in DEEPMIMIC_JOINTS[1:] for v in ([0.3] if rev else [0.9, 0.1, 0.2, 0.3])]
    return [[0.0333, 0.1 * k, 0.9, 0.0, 1.0, 0.0, 0.0, 0.0, *joints] for k in range(n)]


def _write(tmp_path: Path, text: str, name: str = "clip.txt") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_millions_of_empty_frames_fail_at_frame_0_with_memory_of_the_text(tmp_path):
    n = 750_000  # 3 MB of "[], "
    p = _write(tmp_path, '{"Loop": "wrap", "Frames": [' + ", ".join(["[]"] * n) + "]}")
    size = p.stat().st_size
    tracemalloc.start()
    try:
        with pytest.raises(ParseError, match=r"expected 44 numbers in frame 0 .* found 0 values") as info:
            read_deepmimic(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert info.value.line == 1
    assert peak < 3 * size  # the file's bytes and text; was 100 x (a list per frame, an array for all)


def test_a_valid_clip_reads_the_same_in_any_layout(tmp_path):
    """Keys in any order, settings of any JSON (strings with brackets, nested objects),
    any spacing: the frames read are those of ``json.loads``."""
    frames = _frames(6)
    ref = read_deepmimic(_write(tmp_path, json.dumps({"Loop": "wrap", "Frames": frames}), "ref.txt"))
    variants = [
        json.dumps({"Frames": frames, "Loop": "none"}, indent=4),
        json.dumps(
            {
                "Note": 'a [tricky] {string}, "quoted"',
                "RightJoints": [3, 4, {"a": [[], {}]}],
                "Frames": frames,
            }
        ),
        "\ufeff" + json.dumps({"Loop": "wrap", "Frames": frames}, separators=(",", ":")),
        json.dumps({"Frames": [[1.0] * 44], "Loop": "wrap", "Frames ": 1}).replace(
            json.dumps([[1.0] * 44]), json.dumps(frames)
        ),
    ]
    for k, text in enumerate(variants):
        m = read_deepmimic(_write(tmp_path, text, f"v{k}.txt"))
        np.testing.assert_array_equal(m.rotations, ref.rotations)
        np.testing.assert_array_equal(m.root_translation, ref.root_translation)
        assert m.fps == ref.fps


def test_each_kind_of_bad_frame_is_named_with_its_line(tmp_path):
    frames = _frames(4)
    good = json.dumps(frames[0])

    def clip(third: str) -> str:
        body = ",\n".join([good, good, third, good])
        return '{\n"Loop": "wrap",\n"Frames": [\n' + body + "\n]\n}\n"

    cases = [
        (good.replace("0.0333", "[1, [2]]", 1), r"finite number at position 0 of frame 2, found a list"),
        (good.replace("[", '["x", ', 1)[:-1] + "]", r"expected 44 numbers in frame 2 .* found 45 values"),
        (good.replace("0.0333", '"x"', 1), r"finite number at position 0 of frame 2, found a string"),
        (good.replace("0.0333", "true", 1), r"finite number at position 0 of frame 2, found true"),
        (good.replace("0.0333", "NaN", 1), r"finite number at position 0 of frame 2, found NaN"),
        (good.replace("0.0333", "1e999", 1), r"finite number at position 0 of frame 2, found 1e999"),
        (good.replace("0.0333", "0x10", 1), r"JSON \(',' or '\]' after value 0 of frame 2\), found 'x10"),
        ('{"dt": 1}', r"expected 44 numbers in frame 2 .* found an object"),
        ("7", r"expected 44 numbers in frame 2 .* found a number"),
        (good + " " + good, r"JSON \(',' or '\]' after frame 2\), found '\["),
    ]
    for third, message in cases:
        with pytest.raises(ParseError, match=message) as info:
            read_deepmimic(_write(tmp_path, clip(third)))
        assert info.value.line == 6, (third[:30], str(info.value))


@pytest.mark.parametrize(
    ("text", "line", "message"),
    [
        ("", 1, r"a JSON object with a 'Frames' list .* found the end of the file"),
        ("[1, 2]", 1, r"a JSON object with a 'Frames' list .* found '\[1, 2\]'"),
        ('{\n"Loop": "wrap"\n}', 1, r"'Frames' list \(a DeepMimic clip\), found none"),
        ('{\n"Frames": {}\n}', 2, r"'Frames' to be a non-empty list of frames, found '\{"),
        ('{\n"Frames":\n[\n]\n}', 3, r"non-empty list of frames, found \[\]"),
        ('{\n"Loop": "wrap"\n"Frames": []}', 3, r"JSON \(',' or '\}' after the value of 'Loop'\)"),
        (
            '{\n"Loop": ' + "[" * 5000 + "]" * 5000 + ', "Frames": []}',
            2,
            r"nested at most 1000 deep in the value of 'Loop'",
        ),
        ('{\n"Loop": [1, 2,, 3]}', 2, r"JSON \(a value in the value of 'Loop'\), found ', 3\]\}'"),
        ('{\n"Loop": "wrap\n"}', 2, r"JSON \(Invalid control character"),
        ('{\n"Frames": [[]]} x', 2, r"expected 44 numbers in frame 0"),
        ('{"Loop": 1}\n\nx', 3, r"nothing after the clip's last '\}'\), found 'x'"),
    ],
)
def test_structural_errors_name_a_line(tmp_path, text, line, message):
    with pytest.raises(ParseError, match=message) as info:
        read_deepmimic(_write(tmp_path, text))
    assert info.value.line == line


def test_mutated_clips_raise_only_errors_that_name_a_line(tmp_path):
    """The mutation fuzzer's DeepMimic cases (tests/fuzz/mutations.py, fixed seed): every
    ParseError names a line (before: 223 of 2,649 in 3,000 cases had none)."""
    seeds = [s for s in load_seeds(None) if s.name.endswith(".txt")]
    rng = np.random.default_rng(20261201)
    without_line, errors = [], 0
    for k in range(400):
        data, used = mutate(seeds[k % len(seeds)].data, rng)
        p = tmp_path / "case.txt"
        p.write_bytes(data)
        try:
            read_deepmimic(p)
        except ParseError as exc:
            errors += 1
            if exc.line is None:
                without_line.append((k, used, exc.message[:80]))
    assert errors > 200
    assert not without_line, without_line[:5]
