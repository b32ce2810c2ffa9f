"""Mutation fuzzing of the motion readers: seeds, mutation strategies, one case.

Shared by the pytest module (``test_fuzz_readers.py``: a fixed seed, a few hundred cases)
and the long-run script (``benchmarks/fuzz_readers.py``: 100,000 cases, with time and memory
per case). A case is a seed file (a short real clip, or a synthetic one when the real data is
absent), one or more mutations of its bytes, and a reader; the contract under test is that a
reader returns a Motion whose arrays are finite, or raises the project's ``ParseError`` --
nothing else (no ``MemoryError``, ``OverflowError``, ``IndexError``, hang).

Strategies (:data:`STRATEGIES`): byte flips, truncation, deleted and duplicated lines,
numbers replaced by nan / inf / 1e308 / huge integers / tiny or negative values, changed
channel counts, removed braces or brackets, deep nesting, huge declared frame counts and
frame times, non-UTF-8 bytes, an empty file, repeated blocks; plus the special files (a
FIFO, a folder, a dangling symbolic link, a symbolic-link loop) in :func:`special_cases`.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from elastic_motion.errors import ParseError

_NUM = re.compile(rb"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?")
_BAD_NUMBERS = [
    b"nan",
    b"NaN",
    b"inf",
    b"-inf",
    b"Infinity",
    b"1e308",
    b"-1.797e308",
    b"1e309",
    b"4e-324",
    b"1e-307",
    b"0",
    b"-0.0",
    b"-1",
    b"1000000000000000000000000000000",
    b"1" * 400,
    b"9" * 5000,
    b"1e20",
    b"0x10",
    b"1_000",
    b"",
]


# ------------------------------------------------------------------------------------------
# Seeds
# ------------------------------------------------------------------------------------------


def _trim_bvh(text: str, frames: int) -> str:
    head, _, rest = text.partition("MOTION")
    lines = [ln for ln in rest.splitlines() if ln.strip()]
    ft = next(ln for ln in lines if ln.strip().lower().startswith("frame time"))
    data = lines[2 : 2 + frames]
    return head + "MOTION\nFrames: " + str(len(data)) + "\n" + ft.strip() + "\n" + "\n".join(data) + "\n"


def _trim_amc(text: str, frames: int) -> str:
    out, count = [], 0
    for ln in text.splitlines():
        if ln.strip().isdigit():
            count += 1
            if count > frames:
                break
        out.append(ln)
    return "\n".join(out) + "\n"


def synthetic_bvh() -> str:
    """A small 3-joint BVH (no real data needed)."""
    frames = "\n".join(
        " ".join(f"{v:.4f}" for v in [0, 90 + k, 0, 5 * k, 0, 0, -5 * k, 2, 1, 3 * k, 0, 1]) for k in range(6)
    )
    return (
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation "
        "Xrotation Yrotation\n  JOINT LeftLeg\n  {\n    OFFSET 10 -5 0\n    CHANNELS 3 Zrotation Xrotation "
        "Yrotation\n    JOINT LeftFoot\n    {\n      OFFSET 0 -40 0\n      CHANNELS 3 Zrotation Xrotation "
        "Yrotation\n      End Site\n      {\n        OFFSET 0 -5 10\n      }\n    }\n  }\n}\n"
        f"MOTION\nFrames: 6\nFrame Time: 0.0333333\n{frames}\n"
    )


def synthetic_deepmimic() -> str:
    """A small DeepMimic clip (5 frames of the built-in humanoid)."""
    from elastic_motion.motion.deepmimic import DEEPMIMIC_JOINTS

    joints = [v for _, _, rev in DEEPMIMIC_JOINTS[1:] for v in ([0.3] if rev else [0.9, 0.1, 0.2, 0.3])]
    frames = [[0.0333, 0.1 * k, 0.9, 0.0, 1.0, 0.0, 0.0, 0.0, *joints] for k in range(5)]
    return json.dumps({"Loop": "wrap", "Frames": frames}, indent=1)


def synthetic_gltf() -> list[Seed]:
    """The synthetic BVH written as ``.gltf`` (JSON, buffer inline) and ``.glb`` (binary), or
    nothing without the ``gltf`` extra."""
    import importlib.util
    import tempfile

    if importlib.util.find_spec("pygltflib") is None:
        return []
    from elastic_motion.motion import read_bvh, write_motion

    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "synthetic.bvh"
        src.write_text(synthetic_bvh())
        motion = read_bvh(src)
        out = []
        for ext in (".gltf", ".glb"):
            write_motion(motion, Path(d) / f"synthetic{ext}")
            out.append(Seed(f"synthetic{ext}", (Path(d) / f"synthetic{ext}").read_bytes()))
    return out


@dataclass(frozen=True)
class Seed:
    """A seed file: its name (the extension selects the reader) and its bytes."""

    name: str
    data: bytes
    asf: bytes | None = None  # the skeleton an AMC seed is read with


def load_seeds(mocap: Path | None, frames: int = 12) -> list[Seed]:
    """Short real clips from ``mocap`` (BVH, DeepMimic, ASF, AMC); synthetic ones when absent."""
    seeds = [
        Seed("synthetic.bvh", synthetic_bvh().encode()),
        Seed("synthetic_dm.txt", synthetic_deepmimic().encode()),
        *synthetic_gltf(),
    ]
    if mocap is None or not Path(mocap).is_dir():
        return seeds
    m = Path(mocap)
    for rel in ("cmu/bvh/131_01.bvh", "cmu/bvh/07_01.bvh", "bandai/" if (m / "bandai").is_dir() else None):
        if rel is None:
            continue
        p = m / rel
        if p.is_dir():
            bvhs = sorted(p.glob("*.bvh"))
            if not bvhs:
                continue
            p = bvhs[0]
        if p.is_file():
            seeds.append(Seed(p.name, _trim_bvh(p.read_text(), frames).encode()))
    for rel in ("deepmimic/humanoid3d_walk.txt", "deepmimic/humanoid3d_roll.txt"):
        p = m / rel
        if p.is_file():
            d = json.loads(p.read_text())
            d["Frames"] = d["Frames"][: frames + 2]
            seeds.append(Seed(p.name, json.dumps(d, indent=1).encode()))
    asf = m / "cmu/asfamc/02.asf"
    amc = m / "cmu/asfamc/02_01.amc"
    if asf.is_file() and amc.is_file():
        seeds.append(Seed("02.asf", asf.read_bytes()))
        seeds.append(Seed("02_01.amc", _trim_amc(amc.read_text(), frames).encode(), asf=asf.read_bytes()))
    return seeds


# ------------------------------------------------------------------------------------------
# Mutations: bytes -> bytes, driven by a numpy Generator
# ------------------------------------------------------------------------------------------


def _lines(data: bytes) -> list[bytes]:
    return data.split(b"\n")


def byte_flips(data: bytes, rng: np.random.Generator) -> bytes:
    if not data:
        return data
    b = bytearray(data)
    for _ in range(int(rng.integers(1, 9))):
        i = int(rng.integers(len(b)))
        b[i] ^= int(rng.integers(1, 256))
    return bytes(b)


def truncate(data: bytes, rng: np.random.Generator) -> bytes:
    return data[: int(rng.integers(0, len(data) + 1))]


def delete_lines(data: bytes, rng: np.random.Generator) -> bytes:
    lines = _lines(data)
    for _ in range(int(rng.integers(1, 4))):
        if lines:
            del lines[int(rng.integers(len(lines)))]
    return b"\n".join(lines)


def duplicate_lines(data: bytes, rng: np.random.Generator) -> bytes:
    lines = _lines(data)
    for _ in range(int(rng.integers(1, 4))):
        i = int(rng.integers(len(lines)))
        lines.insert(i, lines[i])
    return b"\n".join(lines)


def bad_numbers(data: bytes, rng: np.random.Generator) -> bytes:
    spans = [m.span() for m in _NUM.finditer(data)]
    if not spans:
        return data
    b = data
    for _ in range(int(rng.integers(1, 4))):
        spans = [m.span() for m in _NUM.finditer(b)]
        if not spans:
            break
        i, j = spans[int(rng.integers(len(spans)))]
        b = b[:i] + _BAD_NUMBERS[int(rng.integers(len(_BAD_NUMBERS)))] + b[j:]
    return b


def channel_counts(data: bytes, rng: np.random.Generator) -> bytes:
    choices = [b"0", b"1", b"2", b"5", b"7", b"9", b"-3", b"99999999999", b"x"]
    return re.sub(
        rb"CHANNELS\s+\d+",
        lambda m: (
            b"CHANNELS " + choices[int(rng.integers(len(choices)))] if rng.random() < 0.5 else m.group(0)
        ),
        data,
    )


def remove_braces(data: bytes, rng: np.random.Generator) -> bytes:
    idx = [i for i, c in enumerate(data) if c in b"{}[]"]
    if not idx:
        return data
    b = bytearray(data)
    for i in sorted({idx[int(rng.integers(len(idx)))] for _ in range(int(rng.integers(1, 4)))}, reverse=True):
        del b[i]
    return bytes(b)


def deep_nesting(data: bytes, rng: np.random.Generator) -> bytes:
    depth = int(rng.choice([100, 1000, 20000]))
    if data.lstrip().startswith(b"{"):
        return b'{"Frames": ' + b"[" * depth + b"0" + b"]" * depth + b"}"
    if b"ROOT" in data:
        nest = b"".join(
            b"JOINT j%d\n{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" % k
            for k in range(depth)
        )
        i = data.find(b"{", data.find(b"ROOT")) + 1
        return data[:i] + b"\n" + nest + b"}\n" * depth + data[i:]
    return b"(" * depth + data + b")" * depth


def huge_frames(data: bytes, rng: np.random.Generator) -> bytes:
    counts = [
        b"1000000000000000",
        b"1e20",
        b"99999999999999999999999999999",
        b"-5",
        b"0",
        b"1000001",
        b"9" * 4000,
    ]
    c = counts[int(rng.integers(len(counts)))]
    if b"Frames:" in data:
        return re.sub(rb"Frames:\s*\S+", b"Frames: " + c, data, count=1)
    if data.lstrip().startswith(b"{"):  # DeepMimic: a frame duration instead
        return re.sub(
            rb"\[\s*([-+0-9.eE]+)",
            b"[" + _BAD_NUMBERS[int(rng.integers(12))],
            data,
            count=int(rng.integers(1, 3)),
        )
    return data + b"\n" + c + b"\n"


def frame_times(data: bytes, rng: np.random.Generator) -> bytes:
    times = [b"1e-9", b"1e-307", b"1e9", b"0", b"-0.01", b"nan", b"inf", b"1e308", b"5e-324", b"10000"]
    t = times[int(rng.integers(len(times)))]
    if b"Frame Time:" in data:
        return re.sub(rb"Frame Time:\s*\S+", b"Frame Time: " + t, data, count=1)
    if data.lstrip().startswith(b"{"):
        lines = _lines(data)
        cand = [k for k, ln in enumerate(lines) if ln.lstrip().startswith(b"[") and _NUM.search(ln)]
        if cand:
            k = cand[int(rng.integers(len(cand)))]
            lines[k] = _NUM.sub(t, lines[k], count=1)
        return b"\n".join(lines)
    return data


def non_utf8(data: bytes, rng: np.random.Generator) -> bytes:
    junk = [b"\xff\xfe", b"\xc3\x28", b"\x80", b"\xed\xa0\x80", b"\x00", b"\xef\xbb\xbf", b"\xe2\x80\xa8"]
    b = data
    for _ in range(int(rng.integers(1, 5))):
        i = int(rng.integers(len(b) + 1))
        b = b[:i] + junk[int(rng.integers(len(junk)))] + b[i:]
    return b


def empty(data: bytes, rng: np.random.Generator) -> bytes:
    return [b"", b"\n", b" \t\r\n", b"\x00" * 10, b"{}", b"[]", b"null", b"HIERARCHY"][int(rng.integers(8))]


def repeat_block(data: bytes, rng: np.random.Generator) -> bytes:
    if not data:
        return data
    i = int(rng.integers(len(data)))
    j = min(len(data), i + int(rng.integers(1, 2000)))
    return data[:j] + data[i:j] * int(rng.integers(2, 50)) + data[j:]


#: Every mutation strategy, by name.
STRATEGIES: dict[str, Callable[[bytes, np.random.Generator], bytes]] = {
    "byte_flips": byte_flips,
    "truncate": truncate,
    "delete_lines": delete_lines,
    "duplicate_lines": duplicate_lines,
    "bad_numbers": bad_numbers,
    "channel_counts": channel_counts,
    "remove_braces": remove_braces,
    "deep_nesting": deep_nesting,
    "huge_frames": huge_frames,
    "frame_times": frame_times,
    "non_utf8": non_utf8,
    "empty": empty,
    "repeat_block": repeat_block,
}


def mutate(data: bytes, rng: np.random.Generator) -> tuple[bytes, list[str]]:
    """Apply 1 to 3 random strategies; return the bytes and the strategies' names."""
    names = list(STRATEGIES)
    used = [names[int(rng.integers(len(names)))] for _ in range(int(rng.choice([1, 1, 1, 2, 3])))]
    for n in used:
        data = STRATEGIES[n](data, rng)
    return data, used


# ------------------------------------------------------------------------------------------
# Running a case
# ------------------------------------------------------------------------------------------


def read_case(path: Path, asf: Path | None = None):
    """Read ``path`` with the reader its extension selects (an AMC with the ASF ``asf``)."""
    from elastic_motion.motion import read_amc, read_asf, read_bvh, read_deepmimic, read_motion

    ext = path.suffix.lower()
    if ext == ".bvh":
        return read_bvh(path)
    if ext in (".gltf", ".glb"):
        return read_motion(path)
    if ext == ".asf":
        return read_asf(path)
    if ext == ".amc":
        return read_amc(read_asf(asf), path)
    return read_deepmimic(path)


def check_result(result) -> None:
    """A Motion read from a hostile file must still be finite (no NaN rotation, ever)."""
    from elastic_motion.motion import Motion

    if isinstance(result, Motion):
        for name in ("rotations", "root_translation"):
            arr = np.asarray(getattr(result, name))
            if not np.isfinite(arr).all():
                raise AssertionError(f"non-finite {name} accepted")
        if not (np.isfinite(result.fps) and result.fps > 0):
            raise AssertionError(f"fps {result.fps!r} accepted")


@dataclass(frozen=True)
class Outcome:
    """What one case did: ``"ok"``, ``"parse_error"`` or ``"escaped"`` (the contract broken)."""

    status: str
    detail: str


def run_case(folder: Path, seed: Seed, data: bytes, tag: str) -> Outcome:
    """Write ``data`` as ``seed.name`` in ``folder`` and read it; classify the result."""
    path = folder / f"{tag}_{seed.name}"
    path.write_bytes(data)
    asf = None
    if seed.asf is not None:
        asf = folder / f"{tag}_skeleton.asf"
        asf.write_bytes(seed.asf)
    try:
        check_result(read_case(path, asf))
        return Outcome("ok", "")
    except ParseError as exc:
        return Outcome("parse_error", str(exc)[:200])
    except BaseException as exc:  # the contract: nothing else escapes a reader
        if isinstance(exc, KeyboardInterrupt):
            raise
        return Outcome("escaped", f"{type(exc).__name__}: {str(exc)[:300]}")
    finally:
        for p in (path, asf):
            if p is not None:
                try:
                    os.unlink(p)
                except OSError:
                    pass


def special_cases(folder: Path) -> list[Path]:
    """A FIFO, a folder, a dangling symbolic link and a symbolic-link loop, each named ``*.bvh``."""
    out = []
    fifo = folder / "fifo.bvh"
    if hasattr(os, "mkfifo"):
        os.mkfifo(fifo)
        out.append(fifo)
    d = folder / "folder.bvh"
    d.mkdir()
    out.append(d)
    dangling = folder / "dangling.bvh"
    dangling.symlink_to(folder / "missing.bvh")
    out.append(dangling)
    a, b = folder / "loop_a.bvh", folder / "loop_b.bvh"
    a.symlink_to(b)
    b.symlink_to(a)
    out.append(a)
    for ext in (".txt", ".amc", ".asf"):
        f = folder / f"fifo{ext}"
        if hasattr(os, "mkfifo"):
            os.mkfifo(f)
            out.append(f)
    return out
