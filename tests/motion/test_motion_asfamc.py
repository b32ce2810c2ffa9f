"""ASF/AMC: CMU files against their own text and an independent Acclaim implementation."""

from __future__ import annotations

import re

import numpy as np
import pytest
from motion_testlib import ASF_AMC
from scipy.spatial.transform import Rotation

from elastic_motion.motion import find_asf, forward_kinematics, read_asf, read_asf_amc, read_motion


class NaiveAcclaim:
    """ASF + AMC per the Acclaim model, one frame at a time, with scipy rotations:
    ``W_b = W_p C_p^-1 C_b M_b``, bone end = start + ``W_b C_b^-1 d_b l_b``."""

    def __init__(self, asf_path, amc_path):
        text = asf_path.read_text()
        self.bones = {}
        for block in re.findall(r"begin(.*?)end", text.split(":bonedata")[1].split(":hierarchy")[0], re.S):
            fields = {ln.split()[0]: ln.split()[1:] for ln in block.strip().splitlines() if ln.split()}
            self.bones[fields["name"][0]] = {
                # unit direction (the files round it to 6 digits; the library normalises too)
                "dir": np.array(fields["direction"], dtype=float)
                / np.linalg.norm(np.array(fields["direction"], dtype=float)),
                "len": float(fields["length"][0]),
                "C": Rotation.from_euler(
                    fields["axis"][3].lower(), np.array(fields["axis"][:3], dtype=float), degrees=True
                ),
                "dof": "".join(d[1] for d in fields.get("dof", [])),
            }
        self.children = {}
        hier = text.split(":hierarchy")[1]
        for ln in hier.splitlines():
            toks = ln.split()
            if toks and toks[0] not in ("begin", "end"):
                self.children[toks[0]] = toks[1:]
        self.frames = []
        for block in re.split(r"^\d+\s*$", amc_path.read_text(), flags=re.M)[1:]:
            self.frames.append(
                {ln.split()[0]: np.array(ln.split()[1:], dtype=float) for ln in block.strip().splitlines()}
            )

    def pose(self, f):
        """(bone start positions, bone end positions) dicts for frame ``f``."""
        fr = self.frames[f]
        starts, ends = {"root": fr["root"][:3]}, {}
        w_root = Rotation.from_euler("xyz", fr["root"][3:], degrees=True)

        def walk(name, start, w_parent, c_parent):
            b = self.bones[name]
            m = Rotation.from_euler(b["dof"], fr[name], degrees=True) if b["dof"] else Rotation.identity()
            w = w_parent * c_parent.inv() * b["C"] * m
            starts[name] = start
            ends[name] = start + (w * b["C"].inv()).apply(b["dir"] * b["len"])
            for kid in self.children.get(name, []):
                walk(kid, ends[name], w, b["C"])

        for kid in self.children["root"]:
            walk(kid, starts["root"], w_root, Rotation.identity())
        return starts, ends


@pytest.mark.parametrize(("asf", "amc"), ASF_AMC)
def test_frames_joints_fps_and_units_match_the_files(mocap_dir, asf, amc):
    d = mocap_dir / "cmu" / "asfamc"
    m = read_asf_amc(d / asf, d / amc)
    text = (d / amc).read_text()
    numbers = [int(x) for x in re.findall(r"^(\d+)\s*$", text, flags=re.M)]
    assert m.n_frames == len(numbers) == numbers[-1]  # every frame block, the last one too
    assert m.n_joints == 31 == 1 + len(re.findall(r"^\s*begin", (d / asf).read_text(), flags=re.M)) - 1
    assert m.fps == 120.0
    assert m.metres_per_unit == pytest.approx(0.0254 / 0.45)
    assert m.source == (str(d / asf), str(d / amc))
    assert read_asf_amc(d / asf, d / amc, fps=60).fps == 60.0


@pytest.mark.parametrize(
    ("asf", "amc", "frames"),
    [("02.asf", "02_01.amc", [0, 150, 342]), ("backflip.asf", "backflip.amc", [0, 170, 246])],
)
def test_fk_agrees_with_independent_acclaim_implementation(mocap_dir, asf, amc, frames):
    d = mocap_dir / "cmu" / "asfamc"
    m = read_asf_amc(d / asf, d / amc)
    ref = NaiveAcclaim(d / asf, d / amc)
    pos = forward_kinematics(m, end_sites=True)
    sk = m.skeleton
    for f in frames:
        starts, ends = ref.pose(f)
        for k, name in enumerate(sk.names):
            np.testing.assert_allclose(pos[f, k], starts[name], atol=1e-9, err_msg=name)
        for e, parent in enumerate(sk.end_site_parents):
            np.testing.assert_allclose(pos[f, sk.n_joints + e], ends[sk.names[parent]], atol=1e-9)


@pytest.mark.parametrize(("asf", "amc"), ASF_AMC)
def test_bone_lengths_are_constant_and_equal_to_the_asf(mocap_dir, asf, amc):
    d = mocap_dir / "cmu" / "asfamc"
    m = read_asf_amc(d / asf, d / amc)
    sk = m.skeleton
    pos = forward_kinematics(m, end_sites=True)
    lengths = dict(re.findall(r"name (\w+)\s+direction [^\n]*\n\s*length (\S+)", (d / asf).read_text()))
    parents = np.concatenate([sk.parents[1:], sk.end_site_parents])
    child = np.concatenate([np.arange(1, sk.n_joints), sk.n_joints + np.arange(sk.end_site_parents.size)])
    seg = np.linalg.norm(pos[:, child] - pos[:, parents], axis=-1)  # (F, segments)
    assert np.ptp(seg, axis=0).max() < 1e-9
    # a segment from joint p to its child is bone p of the ASF (bones start at joints)
    for s, p in enumerate(parents):
        name = sk.names[p]
        if name != "root":
            assert seg[0, s] == pytest.approx(float(lengths[name]), abs=1e-9)


def test_last_frame_is_read(mocap_dir):
    d = mocap_dir / "cmu" / "asfamc"
    m = read_asf_amc(d / "02.asf", d / "02_01.amc")
    np.testing.assert_allclose(m.root_translation[-1], [11.0237, 17.502, 29.4538])
    # ltoes has dof rx and axis (-90, 0, 20) XYZ: R = C Rx(-24.1466) C^-1 in the last frame
    c = Rotation.from_euler("xyz", [-90, 7.62852e-016, 20], degrees=True).as_matrix()
    expected = c @ Rotation.from_euler("x", -24.1466, degrees=True).as_matrix() @ c.T
    np.testing.assert_allclose(m.rotations[-1, m.skeleton.index("ltoes")], expected, atol=1e-12)


def test_asf_details(mocap_dir):
    asf = read_asf(mocap_dir / "cmu" / "asfamc" / "02.asf")
    sk = asf.skeleton
    assert sk.names[:6] == ("root", "lhipjoint", "lfemur", "ltibia", "lfoot", "ltoes")
    assert asf.dof[0] == ("TX", "TY", "TZ", "RX", "RY", "RZ")
    assert asf.dof[sk.index("lfemur")] == ("rx", "ry", "rz") and asf.dof[sk.index("lhipjoint")] == ()
    assert asf.limits[sk.index("lfemur")] == [(-160.0, 20.0), (-70.0, 70.0), (-60.0, 70.0)]
    assert asf.angle_unit == "deg"
    # lfemur starts where lhipjoint ends: offset = direction * length of lhipjoint
    np.testing.assert_allclose(
        sk.offsets[sk.index("lfemur")], 2.52691 * np.array([0.655637, -0.713449, 0.247245]), rtol=1e-5
    )
    assert sk.end_site_parents.size == 7  # ltoes, rtoes, head, l/r fingers, l/r thumbs


def test_read_motion_finds_the_asf(mocap_dir, tmp_path):
    d = mocap_dir / "cmu" / "asfamc"
    assert find_asf(d / "02_01.amc").name == "02.asf"
    assert find_asf(d / "charleston2.amc").name == "charleston.asf"
    assert read_motion(d / "backflip.amc").n_frames == 247
    (tmp_path / "a.asf").write_text("x")
    (tmp_path / "b.asf").write_text("x")
    (tmp_path / "walk.amc").write_text("x")
    with pytest.raises(ValueError, match=r"walk\.amc': expected one \.asf skeleton file beside it.*asf=PATH"):
        find_asf(tmp_path / "walk.amc")
    with pytest.raises(
        ValueError, match=r"expected a motion file; got an ASF skeleton without motion: give an \.amc"
    ):
        read_motion(d / "02.asf")
    assert read_motion(d / "02.asf", amc=d / "02_01.amc").n_frames == 343
