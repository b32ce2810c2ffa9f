"""Tests of the constrained projection (closing.kkt): the result is a KKT point of
min ||q - q_orig||^2 subject to closure, no nearby closed curve is nearer the original, it is
at least as near as the Gauss-Newton and R^d Newton projections, and ClosingResult.srv is the
solver's SRV function."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.closing import (
    ClosingOptions,
    ExtraConstraints,
    close_curve,
    closing_gap,
    kkt_residual,
    project_closed,
    project_closed_rd,
)
from elastic_motion.closing.kkt import _eu_samples, _ExtraLinear, _kkt, _newton_step, _solve
from elastic_motion.closing.problem import ClosingProblem
from elastic_motion.curves import SRVFunction, inverse_srv_transform, srv_transform
from elastic_motion.groups import SO3, Euclidean, PowerGroup, ProductGroup


def smooth_curve(group, n, seed=0, scale=1.0):
    """A smooth open curve: SRV = a few random cosines, integrated from a random start."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n + 1)
    mid = 0.5 * (t[:-1] + t[1:])
    q = sum(
        np.outer(np.cos((k + 1) * np.pi * mid + rng.uniform(0, 6)), rng.normal(size=group.dim))
        for k in range(3)
    )
    start = group.exp(rng.normal(size=group.dim) * 0.5)
    return inverse_srv_transform(SRVFunction(scale * q, t, start, group))


def l2(a, b, dt):
    d = np.asarray(a) - np.asarray(b)
    return float(np.sqrt(np.einsum("i,ij,ij->", dt, d, d)))


def lie_group():
    return ProductGroup([Euclidean(3, weight=[0.5, 2.0, 1.0]), PowerGroup(SO3(), 3, [1.0, 2.0, 0.5])])


CASES = {
    # group, closing mask (None: everything), c1
    "lie": (lie_group, None, False),
    "lie-swing-mask": (lie_group, np.array([0, 1, 0, 1, 0, 1, 1, 1, 1, 0, 0, 0], dtype=bool), False),
    "lie-c1": (lie_group, None, True),
    "rd": (lambda: Euclidean(4, weight=[1.0, 2.0, 0.5, 1.0]), None, False),
}


def closed_perturbation(res, orig_srv, mask, c1, rng, scale):
    """A random closed curve near the result: perturb its SRV, close again by Gauss-Newton."""
    q = np.array(res.srv.q)
    dq = rng.normal(size=q.shape) * scale
    pert = SRVFunction(q + dq, orig_srv.t, orig_srv.start, orig_srv.group)
    other = close_curve(pert, factors=mask, c1=c1, tol=1e-12, max_iter=50, keep_free=False)
    assert other.converged
    return other.srv


@pytest.mark.parametrize("case", list(CASES))
def test_projection_is_a_kkt_point_and_no_nearby_closed_curve_is_nearer(case):
    make, mask, c1 = CASES[case]
    curve = smooth_curve(make(), 60, seed=3, scale=1.2)
    srv0 = srv_transform(curve)
    res = project_closed(curve, factors=mask, c1=c1, keep_free=False)
    assert res.converged, res.message
    assert res.gap < 1e-9 and (not c1 or res.velocity_gap < 1e-9)
    assert res.kkt_residual < 1e-8
    # the KKT residual measured independently of the solver's bookkeeping
    k, gap = kkt_residual(res.srv, srv0, factors=mask, c1=c1)
    assert k < 1e-8 and gap < 1e-9
    assert res.change == pytest.approx(l2(res.srv.q, srv0.q, srv0.dt), rel=1e-12)
    # random closed curves near the result are never nearer the original
    rng = np.random.default_rng(7)
    for scale in (1e-1, 3e-2, 1e-2):
        for _ in range(4):
            other = closed_perturbation(res, srv0, mask, c1, rng, scale)
            assert l2(other.q, srv0.q, srv0.dt) >= res.change * (1 - 1e-12)
    # and the Gauss-Newton flow's closed curve is farther (it is nearest only to first order)
    gn = close_curve(curve, factors=mask, c1=c1, tol=1e-12, keep_free=False)
    assert gn.change > res.change
    assert kkt_residual(gn.srv, srv0, factors=mask, c1=c1)[0] > 1e-4


def test_kkt_residual_is_not_small_away_from_the_optimum():
    # guards the residual itself: a closed curve that is not the nearest has a large one
    curve = smooth_curve(lie_group(), 40, seed=1, scale=1.0)
    srv0 = srv_transform(curve)
    res = project_closed(curve)
    rng = np.random.default_rng(0)
    other = closed_perturbation(res, srv0, None, False, rng, 0.05)
    assert kkt_residual(other, srv0)[0] > 1e-3


def test_rd_projection_is_nearer_than_paper_001_newton_projection():
    curve = smooth_curve(Euclidean(2), 80, seed=5, scale=2.0)
    srv0 = srv_transform(curve)
    newton = project_closed_rd(curve, tol=1e-12)
    kkt = project_closed(curve)
    assert kkt.converged and newton.converged
    assert kkt.change < newton.change
    assert np.abs(kkt.curve.values[-1] - kkt.curve.values[0]).max() < 1e-9
    # paper 001, Thm. 2: at the optimum q - q_orig lies in the span of U_k(q) = (q_k q + |q|^2 e_k)/|q|
    q = np.array(kkt.srv.q)
    qn = np.linalg.norm(q, axis=1)
    basis = [(q[:, [k]] * q + np.outer(qn**2, np.eye(2)[k])) / qn[:, None] for k in range(2)]
    a = np.stack([b.ravel() * np.repeat(np.sqrt(srv0.dt), 2) for b in basis], axis=1)
    e = (q - srv0.q).ravel() * np.repeat(np.sqrt(srv0.dt), 2)
    coef, *_ = np.linalg.lstsq(a, e, rcond=None)
    assert np.linalg.norm(e - a @ coef) < 1e-8 * np.linalg.norm(e)


def test_closed_curve_is_returned_unchanged():
    curve = smooth_curve(lie_group(), 30, seed=2)
    closed = project_closed(curve, keep_free=False).curve
    again = project_closed(closed)
    assert again.iterations == 0 and again.change == 0.0 and again.kkt_residual == 0.0


def test_closing_result_srv_is_the_solvers():
    # a closed copy whose steps end past pi: the SRVT of the returned curve would read them the
    # short way round; the result's srv is the solver's own, so every number measured through it
    # equals the solver's
    g = PowerGroup(SO3(), 2)
    n = 20
    rng = np.random.default_rng(4)
    q = rng.normal(size=(n, 6)) * 0.3
    q[:, 0] += 9.0  # |u_i| = |q_i|^2 / n: about 4.1 rad per step, past pi and below 2 pi
    srv0 = SRVFunction(q, np.linspace(0, 1, n + 1), g.identity(), g)
    for solve in (
        lambda c: close_curve(c, keep_free=False, tol=1e-10),
        lambda c: project_closed(c, keep_free=False),
    ):
        res = solve(srv0)
        assert res.converged
        assert res.change == pytest.approx(l2(res.srv.q, srv0.q, srv0.dt), rel=1e-12)
        assert closing_gap(res.srv).gap == pytest.approx(res.gap, abs=1e-9)
        reread = srv_transform(res.curve)
        assert l2(reread.q, srv0.q, srv0.dt) > 2 * res.change  # what the old srv measured
        np.testing.assert_allclose(inverse_srv_transform(res.srv).values, res.curve.values, atol=1e-9)


def test_bad_options():
    curve = smooth_curve(lie_group(), 10)
    with pytest.raises(ValueError, match="kkt_tol"):
        project_closed(curve, kkt_tol=-1)
    with pytest.raises(ValueError, match="max_iter"):
        project_closed(curve, max_iter=1.5)
    with pytest.raises(ValueError, match="at least 3 samples"):
        project_closed(SRVFunction(np.ones((1, 12)), [0.0, 1.0], lie_group().identity(), lie_group()))


class PinConstraints(ExtraConstraints):
    """Test constraints: a direction carried by copy ``b`` at sample ``f`` and one Euclidean
    coordinate at another sample take given values."""

    def __init__(self, f, b, a, target_dir, f_eu, c, target_eu):
        self.f, self.b, self.a = f, b, np.asarray(a, float)
        self.target_dir, self.f_eu, self.c, self.target_eu = target_dir, f_eu, c, target_eu

    def evaluate(self, rot, eu):
        v = rot[self.f, self.b] @ self.a
        g = np.concatenate([v[:2] - self.target_dir, [eu[self.f_eu, self.c] - self.target_eu]])
        frames = np.array([[self.f], [self.f], [self.f_eu]])
        d_rot = np.zeros((3, 1, rot.shape[1], 3))
        # delta (R a) = omega x (R a) = -hat(R a) omega
        hv = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        d_rot[:2, 0, self.b] = -hv[:2]
        d_eu = np.zeros((3, 1, eu.shape[1]))
        d_eu[2, 0, self.c] = 1.0
        return g, frames, d_rot, d_eu


class DenseLinear:
    """Reference: closing rows plus extra rows as a dense Jacobian ``(R, n, dim)``, assembled
    row by row through the ``exp`` steps (the implementation ``_ExtraLinear`` replaced)."""

    def __init__(self, prob, s, extra, eu_orig):
        self.prob, self.s = prob, s
        n, m, ne, dim = prob.n, prob.m, prob.ne, prob.layout.dim
        lay, sp = prob.layout, prob.spec
        bs, be = prob.blocks(s)
        full = prob.residual(s)
        sel = prob.sel
        k = be.shape[-1]
        # closing rows: row (g, internal coordinate) of the full residual; w.r.t. M_i dq_i
        jf = np.zeros((k * dim, n, dim))
        for g in range(k):
            if ne:
                idx = g * dim + np.arange(ne)
                jf[idx, :, np.arange(ne)] = be[:, :, g].T
            for b in range(m):
                r0 = g * dim + ne + 3 * b
                jf[r0 : r0 + 3, :, ne + 3 * b : ne + 3 * b + 3] = np.transpose(
                    bs[:, b, 3 * g : 3 * g + 3, :], (1, 0, 2)
                )
        jf = jf[sel]
        # extra rows through the exp steps: the natural steps u_i = h_i x_i / s
        eu = np.where(sp.eu_closed, _eu_samples(prob, s), eu_orig)
        g_x, frames, d_rot, d_eu = extra.evaluate(s.rot, eu)
        r = g_x.shape[0]
        je = np.zeros((r, n, dim))
        # a sample f depends on the cells i < f: "before[r, s, i]" = i < frames[r, s]
        before = (np.arange(n)[None, None, :] < frames[:, :, None]).astype(np.float64)  # (R, S, n)
        # delta eu_f = sum_{i<f} delta u_i (closed coordinates only)
        tail_eu = np.einsum("rsi,rse->rie", before, d_eu)
        je[:, :, :ne] = np.where(sp.eu_closed, tail_eu, 0.0) / lay.s_eu
        if m:
            # delta R_f R_f^T = sum_{i<f} R_f R_{i+1}^T dexp_{u_i} delta u_i
            fr = np.maximum(frames, 0)
            d_back = np.einsum("rsbj,rsbjk->rsbk", d_rot, s.rot[fr])  # (dg/domega_f) R_f
            tail = np.einsum("rsi,rsbk->ribk", before, d_back)  # (R, n, m, 3): sum over f > i
            dmat = SO3().dexp_matrix(s.u_so3)  # (n, m, 3, 3)
            a = np.einsum("fbji,fbjk->fbik", s.rot[1:], dmat)  # R_{i+1}^T dexp_{u_i}
            ju = np.einsum("ribj,ibjk->ribk", tail, a)
            je[:, :, ne:] = (ju / lay.s_so3[:, None]).reshape(r, n, 3 * m)
        je *= prob.h[None, :, None]
        jm = np.concatenate([jf, je], axis=0)
        # J_i = (rows w.r.t. M_i dq_i) M_i, M_i symmetric
        qn = np.where(s.qn > 0, s.qn, 1.0)
        coef = np.einsum("rij,ij->ri", jm, s.q) / qn
        self.jac = jm * s.qn[None, :, None] + coef[:, :, None] * s.q[None] * (s.qn > 0)[None, :, None]
        self.h = prob.h
        self.fsel = np.concatenate([full[sel], g_x])
        self.n_extra = r
        self._gmat: np.ndarray | None = None

    @property
    def gmat(self) -> np.ndarray:
        """``J J^*`` (assembled on first use: the Hessian products need only ``J^*``)."""
        if self._gmat is None:
            flat = self.jac.reshape(self.jac.shape[0], -1)
            w = np.repeat(1.0 / self.h, self.jac.shape[2])
            self._gmat = (flat * w) @ flat.T
        return self._gmat

    def forward(self, d: np.ndarray) -> np.ndarray:
        return np.einsum("ria,ia->r", self.jac, d)

    def adjoint(self, lam: np.ndarray) -> np.ndarray:
        return np.einsum("r,ria->ia", lam, self.jac) / self.h[:, None]


def test_extra_constraint_jacobian_matches_central_differences():
    g = lie_group()
    curve = smooth_curve(g, 12, seed=9, scale=1.0)
    mask = np.array([0, 1, 0, 1, 0, 1, 1, 1, 1, 0, 0, 0], dtype=bool)  # x, z free: kept as original
    extra = PinConstraints(7, 1, [0.3, -0.2, 0.9], [0.1, 0.2], 9, 1, 0.5)
    for c1 in (False, True):
        prob = ClosingProblem.from_curve(curve, ClosingOptions(factors=mask, c1=c1, cut_locus_tol=1e-9))
        q = prob.to_internal(prob.srv.q)
        s = prob.evaluate(q)
        eu0 = _eu_samples(prob, s)
        lin = DenseLinear(prob, s, extra, eu0)

        def rows(qq, prob=prob, eu0=eu0):
            st = prob.evaluate(qq)
            eu = np.where(prob.spec.eu_closed, _eu_samples(prob, st), eu0)
            return np.concatenate([prob.residual(st)[prob.sel], extra.evaluate(st.rot, eu)[0]])

        eps = 1e-6
        fd = np.zeros_like(lin.jac)
        for i in range(q.shape[0]):
            for k in range(q.shape[1]):
                dq = np.zeros_like(q)
                dq[i, k] = eps
                fd[:, i, k] = (rows(q + dq) - rows(q - dq)) / (2 * eps)
        np.testing.assert_allclose(lin.jac, fd, atol=1e-7 * np.abs(fd).max())
        assert lin.n_extra == 3


def test_projection_with_extra_constraints_is_a_kkt_point():
    g = lie_group()
    curve = smooth_curve(g, 40, seed=2, scale=1.0)
    srv0 = srv_transform(curve)
    mask = np.array([0, 1, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    v0 = curve.values
    extra = PinConstraints(25, 2, [1.0, 0.0, 0.0], [0.8, 0.1], 30, 1, float(v0[30, 1]) + 0.05)
    res = project_closed(curve, factors=mask, extra=extra, keep_free=True)
    assert res.converged, res.message
    assert res.kkt_residual < 1e-8 and res.gap < 1e-9
    rot = g.split_points(res.curve.values)[1]
    np.testing.assert_allclose((rot[25, 2] @ [1.0, 0, 0])[:2], [0.8, 0.1], atol=1e-9)
    assert res.curve.values[30, 1] == pytest.approx(float(v0[30, 1]) + 0.05, abs=1e-9)
    assert res.multipliers.shape == (int(mask.sum()) + 3,)  # closing rows, then the extra rows
    # nearby curves that meet all the constraints are never nearer the original
    rng = np.random.default_rng(3)
    plain = project_closed(curve, factors=mask)
    assert res.change > plain.change  # the extra constraints cost something
    for _ in range(4):
        q = np.array(res.srv.q) + rng.normal(size=res.srv.q.shape) * 1e-2
        other = project_closed(
            SRVFunction(q, srv0.t, srv0.start, srv0.group), factors=mask, extra=extra, kkt_tol=1.0
        )
        assert other.gap < 1e-9
        assert l2(other.srv.q, srv0.q, srv0.dt) >= res.change * (1 - 1e-9)


class RelativeConstraints(ExtraConstraints):
    """Test rows on two samples each (the second slot an anchor, as the loop's seam contacts),
    plus a row on the fixed first sample and one with an unused slot."""

    def __init__(self, pairs, b, c):
        self.pairs, self.b, self.c = pairs, b, c

    def evaluate(self, rot, eu):
        rows, frames, d_rot, d_eu = [], [], [], []
        m, e = rot.shape[1], eu.shape[1]
        a = np.array([0.2, 0.7, -0.4])
        for f, g in self.pairs:
            # (R_f a - R_g a)[0] and eu_f[c] - eu_g[c]
            dr = np.zeros((2, m, 3))
            for slot, (fr, sign) in enumerate(((f, 1.0), (g, -1.0))):
                v = rot[fr, self.b] @ a
                dr[slot, self.b] = sign * np.cross(v, [1.0, 0.0, 0.0])  # e0 . (w x v) = w . (v x e0)
            rows.append((rot[f, self.b] @ a - rot[g, self.b] @ a)[0])
            frames.append([f, g])
            d_rot.append(dr)
            d_eu.append(np.zeros((2, e)))
            de = np.zeros((2, e))
            de[0, self.c], de[1, self.c] = 1.0, -1.0
            rows.append(eu[f, self.c] - eu[g, self.c])
            frames.append([f, g])
            d_rot.append(np.zeros((2, m, 3)))
            d_eu.append(de)
        de = np.zeros((2, e))
        de[0, self.c] = 1.0
        rows.append(eu[0, self.c])  # the first sample never moves: a zero row of J
        frames.append([0, -1])
        d_rot.append(np.zeros((2, m, 3)))
        d_eu.append(de)
        return np.array(rows), np.array(frames), np.array(d_rot), np.array(d_eu)


class Stacked(ExtraConstraints):
    def __init__(self, *parts):
        self.parts = parts

    def evaluate(self, rot, eu):
        out = [p.evaluate(rot, eu) for p in self.parts]
        w = max(o[1].shape[1] for o in out)
        pad = [
            (
                o[0],
                np.pad(o[1], ((0, 0), (0, w - o[1].shape[1])), constant_values=-1),
                np.pad(o[2], ((0, 0), (0, w - o[2].shape[1]), (0, 0), (0, 0))),
                np.pad(o[3], ((0, 0), (0, w - o[3].shape[1]), (0, 0))),
            )
            for o in out
        ]
        return tuple(np.concatenate([p[k] for p in pad]) for k in range(4))


def linearisations_of_two_kinds_of_rows(c1, one_slot):
    """A curve with pinned rows (and rows on two samples unless ``one_slot``) linearised at
    its start: ``(q, DenseLinear, _ExtraLinear)``."""
    g = lie_group()
    curve = smooth_curve(g, 30, seed=4, scale=1.5)
    mask = np.array([0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    extra = Stacked(
        PinConstraints(7, 1, [0.3, -0.2, 0.9], [0.1, 0.2], 9, 1, 0.5),
        *(() if one_slot else (RelativeConstraints([(5, 30), (12, 20), (29, 3)], 2, 2),)),
        PinConstraints(30, 0, [1.0, 0.0, 0.0], [0.4, 0.0], 17, 2, 0.1),
    )
    prob = ClosingProblem.from_curve(curve, ClosingOptions(factors=mask, c1=c1, cut_locus_tol=1e-9))
    q = prob.to_internal(prob.srv.q)
    s = prob.evaluate(q)
    eu0 = _eu_samples(prob, s) + 0.3
    return q, DenseLinear(prob, s, extra, eu0), _ExtraLinear(prob, s, extra, eu0)


@pytest.mark.parametrize("one_slot", [False, True])
@pytest.mark.parametrize("c1", [False, True])
def test_structured_extra_rows_equal_the_dense_jacobian(c1, one_slot):
    """J d, J^* lambda and J J^* of the prefix-sum implementation against the dense Jacobian
    (rows on two samples and unused slots; and rows on one sample each, the short path)."""
    q, dense, fast = linearisations_of_two_kinds_of_rows(c1, one_slot)
    assert fast._one_atom_per_row == one_slot
    np.testing.assert_allclose(fast.fsel, dense.fsel, atol=1e-13)
    rng = np.random.default_rng(0)
    d = rng.normal(size=q.shape)
    lam = rng.normal(size=dense.fsel.shape)
    np.testing.assert_allclose(fast.forward(d), dense.forward(d), rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(fast.adjoint(lam), dense.adjoint(lam), rtol=1e-11, atol=1e-11)
    scale = np.abs(dense.gmat).max()
    np.testing.assert_allclose(fast.gmat, dense.gmat, rtol=1e-10, atol=1e-12 * scale)


def test_inconsistent_extra_rows_give_up_early_when_asked():
    """A row asking a closed coordinate of the last sample to differ from the first sample's:
    no closed curve meets it; with stall_iterations the solver says so after a few iterations."""
    g = lie_group()
    curve = smooth_curve(g, 30, seed=5, scale=1.0)
    mask = np.array([0, 1, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    n = curve.values.shape[0] - 1
    extra = PinConstraints(20, 1, [1.0, 0.0, 0.0], [0.6, 0.2], n, 1, float(curve.values[0, 1]) + 0.3)
    quick = project_closed(curve, factors=mask, extra=extra, max_iter=60, stall_iterations=6)
    assert not quick.converged and quick.iterations < 30, quick.message
    slow = project_closed(curve, factors=mask, extra=extra, max_iter=quick.iterations + 5)
    assert not slow.converged
    assert "inconsistent" in quick.message and "inconsistent" not in slow.message


def test_newton_step_meets_the_linearised_rows_and_minimises_the_quadratic_model():
    """The SQP step ``d = dn + t`` against an independent model: ``J d = -F`` (the normal
    part) and, on the null space of ``J``, ``P (e + W d)`` down by 1e-3 from ``P (e + W dn)``,
    ``W v = v - D(J^* lam)[v]`` by central differences at another ``eps`` (a wrong sign or
    factor of the Hessian term fails it)."""
    g = lie_group()
    curve = smooth_curve(g, 30, seed=4, scale=1.5)
    mask = np.array([0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    extra = Stacked(
        PinConstraints(7, 1, [0.3, -0.2, 0.9], [0.1, 0.2], 9, 1, 0.5),
        RelativeConstraints([(5, 30), (12, 20), (29, 3)], 2, 2),
    )
    prob = ClosingProblem.from_curve(curve, ClosingOptions(factors=mask, cut_locus_tol=1e-9))
    q0 = prob.to_internal(prob.srv.q)
    eu0 = _eu_samples(prob, prob.evaluate(q0))

    def linearise(state):
        return _ExtraLinear(prob, state, extra, eu0)

    def norm(v):
        return float(np.sqrt(np.sum(prob.h[:, None] * v**2)))

    rng = np.random.default_rng(3)
    q = q0 + 0.05 * rng.normal(size=q0.shape)  # away from the original: e != 0
    lin = linearise(prob.evaluate(q))
    e = q - q0
    lam = _kkt(lin, e, prob.h)[1]
    d = _newton_step(prob, lin, e, lam, linearise, max_cg=40)
    f = lin.fsel
    live = np.diag(lin.gmat) > 0  # a row with no derivative (on the fixed first sample) cannot move
    assert live.sum() >= f.size - 2
    np.testing.assert_allclose(lin.forward(d)[live], -f[live], atol=1e-8 * np.linalg.norm(f))

    def w_ref(v):
        eps = 3e-6 / norm(v)
        plus = linearise(prob.evaluate(q + eps * v)).adjoint(lam)
        minus = linearise(prob.evaluate(q - eps * v)).adjoint(lam)
        return v - (plus - minus) / (2.0 * eps)

    def proj(v):
        return v - lin.adjoint(_solve(lin, lin.forward(v)))

    dn = -lin.adjoint(_solve(lin, f))
    before = norm(proj(e + w_ref(dn)))
    after = norm(proj(e + w_ref(d)))
    assert before > 1e-3
    assert after <= 2e-3 * before, (after, before)


@pytest.mark.parametrize("one_slot", [False, True])
@pytest.mark.parametrize("c1", [False, True])
def test_structured_gram_solves_as_the_dense_gram(c1, one_slot):
    """``(J J^* + mu I)^{-1}`` through the sparse time-ordered system (closing.structured)
    against the dense Gram matrix of the reference Jacobian: the same shift ``mu`` (the exact
    trace), the same multipliers and the same step ``J^* lambda``."""
    _, dense, fast = linearisations_of_two_kinds_of_rows(c1, one_slot)
    gmat = dense.gmat
    # drop the zero row (a row on the fixed first sample) from the comparison of lambda: its
    # multiplier is r / mu, exact in both but a 1e12 scale
    live = np.abs(gmat).sum(axis=1) > 0
    mu = 1e-12 * np.trace(gmat) / gmat.shape[0]
    sg = fast.structured()
    assert sg.mu == pytest.approx(mu, rel=1e-10)  # the exact trace, without the Gram matrix
    rng = np.random.default_rng(1)
    lam0 = rng.normal(size=gmat.shape[0]) * live
    rhs = gmat @ lam0 + mu * lam0
    want = np.linalg.solve(gmat + mu * np.eye(gmat.shape[0]), rhs)
    got = sg.solve(rhs)
    # lambda itself is defined to the conditioning of G (1e12: dependent rows); what the
    # projection uses, the residual and the step J^* lambda, agree
    assert np.linalg.norm(gmat @ got + mu * got - rhs) <= 1e-9 * np.linalg.norm(rhs)
    step, want_step = dense.adjoint(got), dense.adjoint(want)
    np.testing.assert_allclose(step, want_step, atol=1e-9 * np.abs(want_step).max())
    # several right-hand sides at once (the Schur complement's), as one by one
    many = sg.solve(np.stack([rhs, 2.0 * rhs], axis=1))
    for col, factor in ((0, 1.0), (1, 2.0)):
        np.testing.assert_allclose(dense.adjoint(many[:, col]), factor * step, atol=1e-9 * np.abs(step).max())


class ManyPins(ExtraConstraints):
    """Rows on many samples: Euclidean coordinate ``c`` and the direction of copy ``b`` at each
    sample of ``frames`` take given values (consistent with closure: a loop's contacts)."""

    def __init__(self, frames, b, a, dirs, c, eus):
        self.parts = Stacked(
            *(PinConstraints(f, b, a, d, f, c, e) for f, d, e in zip(frames, dirs, eus, strict=True))
        )

    def evaluate(self, rot, eu):
        return self.parts.evaluate(rot, eu)


def test_projection_with_many_extra_rows_is_the_same_structured_or_dense(monkeypatch):
    """The closing with 3 rows on each of 23 samples, solved through the structure
    (``structured_pays`` forced) and through the dense Gram matrix: the same closed curve to
    1e-8, both KKT points."""
    from elastic_motion.closing import kkt

    g = lie_group()
    curve = smooth_curve(g, 60, seed=6, scale=1.0)
    mask = np.array([0, 1, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    frames = list(range(5, 50, 2))
    rot = g.split_points(curve.values)[1]
    a = np.array([1.0, 0.0, 0.0])
    dirs = [(rot[f, 2] @ a)[:2] + 0.003 for f in frames]
    eus = [float(curve.values[f, 1]) + 0.005 for f in frames]
    extra = ManyPins(frames, 2, a, dirs, 1, eus)
    used = []
    results = {}
    for forced in (True, False):
        monkeypatch.setattr(kkt._ExtraLinear, "structured_pays", lambda self, f=forced: used.append(f) or f)
        results[forced] = res = project_closed(curve, factors=mask, extra=extra)
        assert res.converged and res.kkt_residual < 1e-8 and res.gap < 1e-9, res.message
    assert True in used and False in used
    np.testing.assert_allclose(results[True].curve.values, results[False].curve.values, atol=1e-8)
    np.testing.assert_allclose(results[True].srv.q, results[False].srv.q, atol=1e-8)


def test_structured_solve_is_chosen_for_many_rows_on_few_coordinates():
    from elastic_motion.closing.structured import structured_pays

    assert structured_pays(452, 28, 3462)  # CMU 55_01 whole with its contacts
    assert not structured_pays(144, 55, 927)  # 49_08: the dense Gram matrix is cheaper
    assert not structured_pays(30, 12, 9)


def test_warm_start_from_the_projection_with_fewer_rows_reaches_the_same_point():
    """``start`` (issue 33: each round of a loop's joint limits starts from the last loop):
    the projection with extra rows a little beyond the loop without them (as a limit crossed
    by degrees), started from that loop, is the KKT point the original's start reaches, in
    fewer iterations; started from that point it stops at once and returns it (not the
    input); a start on another grid is an error naming it."""
    g = lie_group()
    curve = smooth_curve(g, 40, seed=2, scale=0.5)  # one nearest point (1.0: two KKT points)
    mask = np.array([0, 1, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1], dtype=bool)
    plain = project_closed(curve, factors=mask)
    near = (g.split_points(plain.curve.values)[1][25, 2] @ [1.0, 0.0, 0.0])[:2] + [1e-3, -1e-3]
    extra = PinConstraints(25, 2, [1.0, 0.0, 0.0], near, 30, 1, float(plain.curve.values[30, 1]) + 1e-3)
    cold = project_closed(curve, factors=mask, extra=extra)
    warm = project_closed(curve, factors=mask, extra=extra, start=plain.srv)
    assert cold.converged and warm.converged, warm.message
    assert warm.iterations < cold.iterations
    np.testing.assert_allclose(warm.curve.values, cold.curve.values, atol=1e-8)
    assert warm.change == pytest.approx(cold.change, rel=1e-7)  # measured from the original
    assert warm.objective_history[0] == pytest.approx(0.5 * plain.change**2, rel=1e-9)
    again = project_closed(curve, factors=mask, extra=extra, start=cold.srv)
    assert again.converged and again.iterations == 0
    np.testing.assert_array_equal(again.srv.q, cold.srv.q)
    np.testing.assert_allclose(again.curve.values, cold.curve.values, atol=1e-12)
    with pytest.raises(ValueError, match=r"^start: expected the SRV function of the curve's grid"):
        project_closed(curve, start=srv_transform(smooth_curve(g, 30)))
