"""Malformed files: a ParseError naming file, line and expectation; fuzzed real files.

The fuzz tests mutate small copies of the real files (byte and line edits, truncation)
and require that only ``ParseError`` escapes the readers -- never ``IndexError``,
``KeyError``, ``UnicodeDecodeError``...; a successful read must give a consistent Motion.
"""

from __future__ import annotations

import json
import pickle
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from elastic_motion.errors import ParseError
from elastic_motion.motion import read_asf, read_asf_amc, read_bvh, read_deepmimic, read_urdf_skeleton

# ------------------------------------------------------------------------------------------
# Small valid copies of the real files
# ------------------------------------------------------------------------------------------


def small_cmu_bvh(mocap, n=4) -> str:
    """131_01.bvh (CRLF, '.0083333') cut to its first n frames."""
    text = (mocap / "cmu" / "bvh" / "131_01.bvh").read_bytes().decode()
    head, data = text.split("Frame Time:", 1)
    lines = data.split("\n")
    head = head.replace("Frames: 994", f"Frames: {n}")
    return head + "Frame Time:" + "\n".join(lines[: n + 1]) + "\n"


def small_bandai_bvh(mocap, n=2) -> str:
    """A Bandai file (six channels on every joint, tabs in the header) cut to n frames."""
    text = (mocap / "bandai" / "dataset-1_dash_normal_001.bvh").read_text()
    head, data = text.split("Frame Time:", 1)
    lines = data.split("\n")
    return re.sub(r"Frames:\s*\d+", f"Frames:\t{n}", head) + "Frame Time:" + "\n".join(lines[: n + 1]) + "\n"


def small_amc(mocap, n=3) -> str:
    text = (mocap / "cmu" / "asfamc" / "02_01.amc").read_text()
    cut = re.search(rf"^{n + 1}\s*$", text, flags=re.M).start()
    return text[:cut]


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text) if isinstance(text, str) else p.write_bytes(text)
    return p


# ------------------------------------------------------------------------------------------
# BVH
# ------------------------------------------------------------------------------------------
def test_parse_error_format_and_pickling():
    e = ParseError("walk.bvh", 190, "expected 96 values, found 95")
    assert str(e) == "walk.bvh:190: expected 96 values, found 95"
    assert isinstance(e, ValueError)
    e2 = pickle.loads(pickle.dumps(e))
    assert (e2.path, e2.line, e2.message) == ("walk.bvh", 190, "expected 96 values, found 95")
    assert str(ParseError("x.amc", None, "boom")) == "x.amc: boom"


def test_bvh_wrong_number_of_values_names_the_line(mocap_dir, tmp_path):
    text = small_cmu_bvh(mocap_dir)
    lines = text.split("\n")
    k = next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time")) + 2  # 2nd frame
    lines[k] = lines[k].rsplit(" ", 1)[0]
    p = write(tmp_path, "short.bvh", "\n".join(lines))
    with pytest.raises(ParseError) as info:
        read_bvh(p)
    assert info.value.line == k + 1
    assert str(info.value) == f"{p}:{k + 1}: expected 96 values (one per channel) in frame 1, found 95"


def test_bvh_non_numeric_and_non_finite_values(mocap_dir, tmp_path):
    text = small_cmu_bvh(mocap_dir)
    lines = text.split("\n")
    k = next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time")) + 3
    toks = lines[k].split()
    for bad, match in (("1.2.3", "expected a number"), ("abc", "expected a number"), ("nan", "finite")):
        toks2 = toks.copy()
        toks2[10] = bad
        lines2 = lines.copy()
        lines2[k] = " ".join(toks2)
        p = write(tmp_path, "bad.bvh", "\n".join(lines2))
        with pytest.raises(ParseError, match=match) as info:
            read_bvh(p)
        assert info.value.line == k + 1
        assert str(p) in str(info.value)


def test_bvh_truncated_files(mocap_dir, tmp_path):
    text = small_cmu_bvh(mocap_dir)
    # cut inside the last frame line: the frame has too few values
    p = write(tmp_path, "t1.bvh", text[: len(text) - 200])
    with pytest.raises(ParseError, match=r"expected 96 values .* found"):
        read_bvh(p)
    # cut after a complete frame: one frame missing
    cut = text.rstrip("\r\n").rsplit("\n", 1)[0]
    p = write(tmp_path, "t2.bvh", cut)
    with pytest.raises(
        ParseError, match=r"expected 4 frames \(the Frames: header\), found 3 \(truncated file\?\)"
    ):
        read_bvh(p)
    # cut in the hierarchy
    p = write(tmp_path, "t3.bvh", text[:900])
    with pytest.raises(ParseError, match="found the end of the file"):
        read_bvh(p)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: re.sub(r"Frames: \d+", "Frames: 0", t), "expected at least one frame"),
        (lambda t: re.sub(r"Frames: \d+", "Frames: 5", t), "expected 5 frames"),
        (lambda t: re.sub(r"Frames: \d+", "Frames: four", t), "expected the number of frames"),
        (lambda t: t.replace("Frame Time: .0083333", "Frame Time: 0"), "positive frame time"),
        (lambda t: t.replace("Zrotation", "Wrotation", 1), "expected a channel name"),
        (lambda t: t.replace("CHANNELS 3", "CHANNELS 7", 1), r"number of channels \(0 to 6\)"),
        (lambda t: t.replace("JOINT LeftKnee", "JOINT LeftHip", 1), "used twice"),
        (lambda t: t.replace("OFFSET 0 0 0", "OFFSET 0 x 0", 1), "expected an OFFSET value"),
        (lambda t: t.replace("MOTION", "MOTIONS"), "expected MOTION"),
        (lambda t: t.replace("HIERARCHY", "HIERARCH"), "expected HIERARCHY"),
        (lambda t: t.replace("End Site", "End Sight", 1), "expected 'Site'"),
    ],
)
def test_bvh_header_errors(mocap_dir, tmp_path, edit, match):
    p = write(tmp_path, "e.bvh", edit(small_cmu_bvh(mocap_dir)))
    with pytest.raises(ParseError, match=match) as info:
        read_bvh(p)
    assert info.value.line is not None and info.value.path == str(p)


def test_unreadable_path_is_a_parse_error(tmp_path):
    with pytest.raises(ParseError, match="cannot read"):
        read_bvh(tmp_path / "nope.bvh")
    with pytest.raises(ParseError, match="directory"):
        read_bvh(tmp_path)


# ------------------------------------------------------------------------------------------
# ASF / AMC
# ------------------------------------------------------------------------------------------
def _amc_case(mocap, tmp_path, amc_text):
    asf = mocap / "cmu" / "asfamc" / "02.asf"
    p = write(tmp_path, "x.amc", amc_text)
    return asf, p


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: t.replace("lfemur", "lfemurX", 1), r"unknown bone 'lfemurX'"),
        (
            lambda t: t.replace("rtibia 11.5302", "rtibia 11.5302 1.0", 1),
            r"expected 1 values for bone 'rtibia' \(dof rx\)",
        ),
        (lambda t: t.replace("head 2.97226", "head abc", 1), "expected a value for bone 'head'"),
        (
            lambda t: re.sub(r"^ltoes .*\n", "", t, count=1, flags=re.M),
            "frame 1 has no line for bone 'ltoes'",
        ),
        (lambda t: re.sub(r"^2$", "3", t, flags=re.M), "expected frame number 2, found 3"),
        (lambda t: t.replace("lradius 20.3824", "lradius 20.3824\nlradius 1", 1), "appears twice"),
        (lambda t: re.sub(r"^1$", "", t, flags=re.M), "expected a frame number before"),
        (lambda t: t[: t.index("\n1\n") + 1], "expected at least one frame"),
    ],
)
def test_amc_errors(mocap_dir, tmp_path, edit, match):
    asf, p = _amc_case(mocap_dir, tmp_path, edit(small_amc(mocap_dir)))
    with pytest.raises(ParseError, match=match) as info:
        read_asf_amc(asf, p)
    assert info.value.path == str(p)
    assert info.value.line is not None


@pytest.mark.mocap
def test_asf_huge_direction_is_a_direction(mocap_dir, tmp_path):
    """A direction of 1e200 (a fuzzed file) is scaled before its norm: the bone points the same
    way as with unit values, with no overflow warning (the norm overflowed to inf)."""
    import warnings

    text = (mocap_dir / "cmu" / "asfamc" / "02.asf").read_text()
    huge = text.replace("direction 0.34202 -0.939693 0 ", "direction 0.34202e200 -0.939693e200 0 ", 1)
    assert huge != text
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sk = read_asf(write(tmp_path, "huge.asf", huge))
    plain = read_asf(write(tmp_path, "plain.asf", text)).skeleton.offsets
    np.testing.assert_allclose(sk.skeleton.offsets, plain, atol=1e-12)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: t.replace(":root", ":rooot"), "expected a ':root' section"),
        (lambda t: t.replace("lfemur ltibia", "lfemur ltibiaa"), "unknown bone 'ltibiaa' in :hierarchy"),
        (lambda t: t.replace("rtibia rfoot", "rtibia rfoot lfoot"), "more than one parent"),
        (lambda t: t.replace("length 7.59371", "length seven"), "expected the bone length"),
        (
            lambda t: t.replace("dof rx\n    limits (-10.0 170.0)", "dof rx ry\n    limits (-10.0 170.0)", 1),
            "expected 2 limits",
        ),
        (lambda t: t.replace("axis 0 0 20  XYZ", "axis 0 0 20 XYQ", 1), "axis a1 a2 a3 ORDER"),
        (lambda t: t.replace("dof rx ry rz", "dof rx ry tz", 1), "translation and length dofs"),
        (lambda t: t.replace("order TX TY TZ RX RY RZ", "order TX TY TZ RX RY RQ"), "in 'order'"),
        (lambda t: t.replace("     name lfemur", "     nam lfemur", 1), "has no 'name'"),
    ],
)
def test_asf_errors(mocap_dir, tmp_path, edit, match):
    text = (mocap_dir / "cmu" / "asfamc" / "02.asf").read_text()
    new = edit(text)
    assert new != text
    p = write(tmp_path, "x.asf", new)
    with pytest.raises(ParseError, match=match):
        read_asf(p)


# ------------------------------------------------------------------------------------------
# DeepMimic
# ------------------------------------------------------------------------------------------
def test_deepmimic_errors(mocap_dir, tmp_path):
    src = (mocap_dir / "deepmimic" / "humanoid3d_walk.txt").read_text()
    data = json.loads(src)
    p = write(tmp_path, "bad.txt", src.replace('"Frames":', '"Frames"', 1))
    with pytest.raises(ParseError, match="expected JSON") as info:
        read_deepmimic(p)
    assert info.value.line == 4  # where the ':' was expected
    lines = src.split("\n")
    k = next(i for i, ln in enumerate(lines) if re.match(r"\[\s*[-\d]", ln)) + 2  # third frame's line
    lines[k] = lines[k].replace("[", "[1.0, ", 1)
    with pytest.raises(ParseError, match="expected 44 numbers in frame 2") as info:
        read_deepmimic(write(tmp_path, "bad.txt", "\n".join(lines)))
    assert info.value.line == k + 1
    bad = dict(data, Frames=[[*fr[:5], "x", *fr[6:]] for fr in data["Frames"]])
    with pytest.raises(ParseError, match="finite number at position 5 of frame 0"):
        read_deepmimic(write(tmp_path, "bad.txt", json.dumps(bad)))
    bad = dict(data, Frames=[[*fr[:4], 0, 0, 0, 0, *fr[8:]] for fr in data["Frames"]])
    with pytest.raises(ParseError, match="non-zero quaternion for 'root'"):
        read_deepmimic(write(tmp_path, "bad.txt", json.dumps(bad)))
    with pytest.raises(ParseError, match="'Frames' list"):
        read_deepmimic(write(tmp_path, "bad.txt", json.dumps({"Loop": "wrap"})))
    with pytest.raises(ParseError, match="non-empty list"):
        read_deepmimic(write(tmp_path, "bad.txt", json.dumps({"Frames": []})))
    bad = dict(data, Frames=[[10**400, *fr[1:]] for fr in data["Frames"]])
    with pytest.raises(ParseError, match="finite number at position 0"):
        read_deepmimic(write(tmp_path, "bad.txt", json.dumps(bad)))


def test_urdf_errors(mocap_dir, tmp_path):
    text = (mocap_dir / "deepmimic" / "humanoid.urdf").read_bytes().decode()
    with pytest.raises(ParseError, match="right_knee"):
        read_urdf_skeleton(write(tmp_path, "h.urdf", text.replace('name="right_knee"', 'name="rknee"')))
    with pytest.raises(ParseError, match="well-formed"):
        read_urdf_skeleton(write(tmp_path, "h.urdf", text[:3000]))


# ------------------------------------------------------------------------------------------
# Fuzzing
# ------------------------------------------------------------------------------------------
_INSERTS = [b"0", b"9", b"-", b".", b" ", b"\t", b"\n", b"\r", b"{", b"}", b"e", b"x", b"\x00", b"\xff",
            b"nan", b"1e999", b"JOINT", b"End Site", b"CHANNELS 3", b"[", b"]", b",", b'"', b"(", b")",
            b"root", b"begin", b"end", b":", "\u00b2".encode(), "\u0661".encode()]  # fmt: skip


@st.composite
def mutations(draw, data: bytes):
    """Apply 1 to 4 random edits to ``data``: byte edits, line edits or truncation."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "insert", "replace", "truncate", "dup_line", "drop_line"]))
        n = len(out)
        if n == 0:
            break
        i = draw(st.integers(0, n - 1))
        if kind == "delete":
            del out[i : i + draw(st.integers(1, 8))]
        elif kind == "insert":
            out[i:i] = draw(st.sampled_from(_INSERTS))
        elif kind == "replace":
            out[i : i + 1] = draw(st.sampled_from(_INSERTS))
        elif kind == "truncate":
            del out[i:]
        else:
            lines = bytes(out).split(b"\n")
            k = draw(st.integers(0, len(lines) - 1))
            if kind == "dup_line":
                lines.insert(k, lines[k])
            else:
                del lines[k]
            out = bytearray(b"\n".join(lines))
    return bytes(out)


FUZZ = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


def _check_reader(read, path, blob):
    path.write_bytes(blob)
    try:
        m = read(path)
    except ParseError as exc:
        assert exc.path
        return
    # Success: the result must be internally consistent.
    assert m.rotations.shape == (m.n_frames, m.n_joints, 3, 3)
    assert np.isfinite(m.rotations).all() and np.isfinite(m.root_translation).all()


@pytest.fixture(scope="module")
def fuzz_sources(mocap_dir):
    return {
        "cmu": small_cmu_bvh(mocap_dir, 3).encode(),
        "bandai": small_bandai_bvh(mocap_dir).encode(),
        "asf": (mocap_dir / "cmu" / "asfamc" / "02.asf").read_bytes(),
        "amc": small_amc(mocap_dir, 2).encode(),
        "deepmimic": (mocap_dir / "deepmimic" / "humanoid3d_backflip.txt").read_bytes(),
    }


@given(data=st.data())
@FUZZ
def test_fuzz_bvh(fuzz_sources, tmp_path, data):
    src = fuzz_sources[data.draw(st.sampled_from(["cmu", "bandai"]))]
    _check_reader(read_bvh, tmp_path / "f.bvh", data.draw(mutations(src)))


@given(data=st.data())
@FUZZ
def test_fuzz_asf_amc(fuzz_sources, tmp_path, data):
    mutate_asf = data.draw(st.booleans())
    asf = data.draw(mutations(fuzz_sources["asf"])) if mutate_asf else fuzz_sources["asf"]
    amc = fuzz_sources["amc"] if mutate_asf else data.draw(mutations(fuzz_sources["amc"]))
    (tmp_path / "f.asf").write_bytes(asf)
    _check_reader(lambda p: read_asf_amc(tmp_path / "f.asf", p), tmp_path / "f.amc", amc)


@given(data=st.data())
@FUZZ
def test_fuzz_deepmimic(fuzz_sources, tmp_path, data):
    _check_reader(read_deepmimic, tmp_path / "f.txt", data.draw(mutations(fuzz_sources["deepmimic"])))
