"""Fuzz the motion readers (issue 14): a fixed seed, a few hundred mutated files, < 60 s.

Contract: a reader returns a finite Motion or raises ``ParseError`` -- never another
exception, a NaN rotation, a hang on a FIFO, or an allocation sized by a declared count --
and a file that reads is written back with ``write_bvh`` and reads back as the same motion
(issue 32, ``contract.py``). The grammar-based generator beside this one is
``test_fuzz_grammar.py``; the long run (100,000 cases of both, time and memory per case) is
``benchmarks/fuzz_readers.py``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import contract
from mutations import STRATEGIES, load_seeds, mutate, read_case, run_case, special_cases

from elastic_motion.errors import ParseError

MOCAP = Path(__file__).resolve().parents[3] / "shared" / "mocap"
N_CASES = 800
SEED = 20261201


@pytest.fixture(scope="module")
def seeds():
    import os

    mocap = Path(os.environ.get("ELASTIC_MOTION_MOCAP", MOCAP))
    return load_seeds(mocap if mocap.is_dir() else None)


def test_seeds_read_cleanly(seeds, tmp_path: Path) -> None:
    """The unmutated seeds are valid: mutations, not the seeds, make the failures."""
    for s in seeds:
        assert run_case(tmp_path, s, s.data, "seed").status == "ok", s.name


def test_mutated_files_raise_only_parse_errors(seeds, tmp_path: Path) -> None:
    """... and the files that still read write back (contract.py)."""
    rng = np.random.default_rng(SEED)
    escaped, slow, statuses = [], [], {s: 0 for s in contract.STATUSES}
    t_all = time.perf_counter()
    with contract.scratch_dir() as folder:
        for k in range(N_CASES):
            seed = seeds[k % len(seeds)]
            data, used = mutate(seed.data, rng)
            t0 = time.perf_counter()
            out = contract.run_checked(folder, seed.name, data, seed.asf, f"c{k}")
            dt = time.perf_counter() - t0
            if dt > 2.0:
                slow.append((k, seed.name, used, round(dt, 2)))
            if out.status in ("escaped", "writeback_failed"):
                escaped.append((k, seed.name, used, out.status, out.detail))
            statuses[out.status] += 1
    assert not escaped, escaped[:5]
    assert not slow, slow[:5]
    assert statuses["parse_error"] > N_CASES // 4  # the mutations do break files
    assert statuses["ok"] > 0  # and some still read, and write back
    assert time.perf_counter() - t_all < 60


@pytest.mark.parametrize("strategy", sorted(STRATEGIES))
def test_each_strategy_alone(strategy: str, seeds, tmp_path: Path) -> None:
    """Every strategy on every seed, a few times: named failures point at the strategy."""
    rng = np.random.default_rng(SEED + len(strategy))
    for s in seeds:
        for r in range(2):
            out = run_case(tmp_path, s, STRATEGIES[strategy](s.data, rng), f"{strategy}{r}")
            assert out.status != "escaped", (strategy, s.name, out.detail)


def test_special_files_are_refused_without_blocking(tmp_path: Path) -> None:
    """FIFOs, folders, dangling links and link loops: a ParseError at once (no open() that blocks)."""
    asf = tmp_path / "skeleton.asf"
    asf.write_text("")
    for p in special_cases(tmp_path):
        t0 = time.perf_counter()
        with pytest.raises(ParseError) as info:
            read_case(p, asf=None) if p.suffix != ".amc" else read_case(p, asf=p)
        assert time.perf_counter() - t0 < 2.0
        assert str(p.name) in str(info.value)
