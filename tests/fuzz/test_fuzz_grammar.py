"""Grammar-based fuzzing of the readers (issue 32): generated BVH, ASF/AMC and DeepMimic files on
a fixed seed, about 20 s in all.

Every case (``grammar/``: valid by construction, or grammar rules broken) keeps the contract
of ``contract.py``: the reader returns a finite Motion or raises ``ParseError`` (never
another exception, a case over 2 s of CPU or 300 MB); a valid file is accepted and a file
the grammar makes invalid refused; and every accepted file is written back with
``write_bvh`` and read back as the same motion (frames, fps, joints, the channel layout of a
BVH source, End Sites, joint positions to 1e-9 of the skeleton's size). The long run, with
the mutation generator beside it, is ``benchmarks/fuzz_readers.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import contract
import grammar

from elastic_motion.errors import ParseError
from elastic_motion.motion import read_amc, read_asf

SEED = 20261232
N_CASES = {"bvh": 600, "asfamc": 500, "deepmimic": 400}
CPU_BUDGET_S = 2.0
MEMORY_BUDGET_MB = 300.0


@pytest.fixture(scope="module")
def scratch():
    with contract.scratch_dir() as d:
        yield d


def run_grammar(fmt: str, n: int, seed: int, folder: Path) -> tuple[contract.Tally, set[str]]:
    """``n`` cases of ``fmt`` (half valid, half perturbed): their tally and the rules drawn."""
    rng = np.random.default_rng([seed, list(grammar.GENERATORS).index(fmt)])
    rss = contract.can_measure_rss()
    tally, rules = contract.Tally(), set()
    for k in range(n):
        case = grammar.GENERATORS[fmt](rng, perturb=0.5)
        rules.update(case.rule.split("+"))
        out, m = contract.measured(rss, contract.run_checked, folder, case.name, case.data, case.asf, f"g{k}")
        info = {"case": k, "rule": case.rule, "detail": out.detail, "warning": out.warning, **m}
        tally.add(contract.verdict(out, case.expect), info)
    return tally, rules


@pytest.mark.parametrize("fmt", sorted(N_CASES))
def test_generated_files_keep_the_contract(fmt: str, scratch: Path) -> None:
    for s in range(3):  # warm up: numba caches, imports
        case = grammar.GENERATORS[fmt](np.random.default_rng(s), perturb=0.0)
        contract.run_checked(scratch, case.name, case.data, case.asf, "warm")
    tally, rules = run_grammar(fmt, N_CASES[fmt], SEED, scratch)
    assert not tally.failures(), tally.failures()
    assert tally.slowest["cpu_seconds"] < CPU_BUDGET_S, tally.slowest
    assert tally.largest["peak_mb"] < MEMORY_BUDGET_MB, tally.largest
    # the generator reaches both sides, and most rules (each one alone: the next test)
    assert tally.counts["ok"] > N_CASES[fmt] // 4, tally.counts
    assert tally.counts["parse_error"] > N_CASES[fmt] // 5, tally.counts
    missing = set(grammar.RULES[fmt]) - rules
    assert len(missing) < len(grammar.RULES[fmt]) // 5, missing


@pytest.mark.parametrize("fmt", sorted(N_CASES))
def test_each_rule_alone(fmt: str, scratch: Path) -> None:
    """Every rule of the grammar, alone, on a few files: the reader does what the rule says
    (``expect``) and keeps the contract; a failure names the rule."""
    rng = np.random.default_rng([SEED, 11])
    for rule in grammar.RULES[fmt]:
        applied = 0
        for k in range(12):
            case = grammar.GENERATORS[fmt](rng, rule=rule)
            if case.rule == "valid":  # not applicable to this file
                continue
            applied += 1
            out = contract.run_checked(scratch, case.name, case.data, case.asf, f"r{k}")
            v = contract.verdict(out, case.expect)
            assert v not in contract.FAILURES, (rule, k, v, out.detail)
            if applied == 3:
                break
        assert applied, f"rule {rule!r} never applied"


@pytest.mark.parametrize("fmt", sorted(N_CASES))
def test_valid_files_are_valid(fmt: str, scratch: Path) -> None:
    """Unperturbed cases are accepted: the grammar, not luck, makes the valid files."""
    rng = np.random.default_rng([SEED, 7])
    for k in range(30):
        case = grammar.GENERATORS[fmt](rng, perturb=0.0)
        assert (case.rule, case.expect) == ("valid", "ok")
        out = contract.run_checked(scratch, case.name, case.data, case.asf, f"v{k}")
        assert out.accepted, (k, out.detail, case.data[:2000])


def test_same_seed_same_cases() -> None:
    for fmt, gen in grammar.GENERATORS.items():
        a = [gen(np.random.default_rng(5)).data for _ in range(3)]
        b = [gen(np.random.default_rng(5)).data for _ in range(3)]
        assert a == b, fmt


# ------------------------------------------------------------------------------------------
# Cases the generator found, fixed
# ------------------------------------------------------------------------------------------
ASF = """:version 1.10
:name VICON
:units
  mass 1.0
  length {length}
  angle deg
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name femur
     direction 0 -1 0
     length 7.5
     axis 0 0 20 XYZ
     dof rx ry rz
  end
:hierarchy
  begin
    root femur
  end
"""
AMC = ":FULLY-SPECIFIED\n:DEGREES\n1\nroot 1 2 3 10 20 30\nfemur 5 -10 45\n"
AMC += "2\nroot 1 2 4 10 20 31\nfemur 6 -10 44\n"


def test_asf_length_unit_too_small_is_a_parse_error(tmp_path: Path) -> None:
    """``length 1e-320`` makes 1/L inch overflow: a ParseError on its line (was a plain
    ValueError from the Motion, 3 of 6,000 generated pairs)."""
    asf = tmp_path / "s.asf"
    asf.write_text(ASF.format(length="1e-320"))
    with pytest.raises(ParseError, match=r"s\.asf:5: expected a length unit of at least 1\.41e-310"):
        read_asf(asf)
    out = contract.run_checked(tmp_path, "m.amc", AMC.encode(), asf.read_bytes(), "t")
    assert out.status == "parse_error", out.detail


@pytest.mark.parametrize("length", ["1e-300", "1.5e-310", "1e308", "0.45"])
def test_asf_extreme_length_units_read(tmp_path: Path, length: str) -> None:
    asf = tmp_path / "s.asf"
    asf.write_text(ASF.format(length=length))
    amc = tmp_path / "m.amc"
    amc.write_text(AMC)
    m = read_amc(read_asf(asf), amc)
    assert 0 < m.metres_per_unit < float("inf")
    assert contract.run_checked(tmp_path, "m.amc", AMC.encode(), asf.read_bytes(), "t").status == "ok"


TWO_CHANNELS = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Arm
  {
    OFFSET 10 0 0
    CHANNELS 2 Xrotation Zrotation
    End Site
    {
      OFFSET 0 -20 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 0 30 120
0 91 0 0 0 0 -40 -135
"""


def test_two_rotation_channels_past_90_degrees_write_back(tmp_path: Path) -> None:
    out = contract.run_checked(tmp_path, "two.bvh", TWO_CHANNELS.encode(), None, "t")
    assert out.status == "ok", out.detail


def test_asf_bone_named_brace_writes_back(tmp_path: Path) -> None:
    asf = ASF.format(length="0.45").replace("femur", "{")
    out = contract.run_checked(tmp_path, "m.amc", AMC.replace("femur", "{").encode(), asf.encode(), "t")
    assert out.status == "ok", out.detail
