"""SGCMG steering laws and gimbal-rate saturation (SPEC §5.2)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spacecraft.sgcmg import SgcmgPyramid
from spacecraft.steering import (
    _SMALL_BATCH,
    PINV_EPS,
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularityRobust,
    jacobian_singularity_measure,
    pseudo_inverse,
    saturate_gimbal_rates,
    singularity_robust_inverse,
)

P = SgcmgPyramid()
BIG = _SMALL_BATCH + 44  # batches this large take the closed-form (Cramer) route
LAWS = [PseudoInverse(), PseudoInverseNullMotion(cluster=P), SingularityRobust()]
LAW_IDS = ["pinv", "pinv_null", "sr"]
SINGULAR = np.deg2rad(
    [
        [90.0, 90.0, 90.0, 90.0],  # saturation singularity (envelope, +z)
        [-90.0, -90.0, -90.0, -90.0],
        [-90.0, 0.0, 90.0, 0.0],  # internal singularity, singular direction x
        [0.0, 90.0, 0.0, -90.0],  # internal singularity, singular direction y
        [90.0, 0.0, -90.0, 0.0],
    ]
)
angles = st.floats(-2 * np.pi, 2 * np.pi, allow_nan=False, allow_infinity=False)
delta_st = st.tuples(angles, angles, angles, angles).map(np.array)
hdot_st = st.tuples(*[st.floats(-50.0, 50.0, allow_nan=False)] * 3).map(np.array)


def random_regular(rng: np.random.Generator, n: int, m_min: float = 0.3) -> np.ndarray:
    d = rng.uniform(-np.pi, np.pi, (4 * n, 4))
    return d[P.singularity_measure(d) > m_min][:n]


def realised(A: np.ndarray, dd: np.ndarray) -> np.ndarray:
    return (A @ dd[..., None])[..., 0]


# ---------------------------------------------------------------------------- pure inverses
def test_pseudo_inverse_matches_numpy_pinv_away_from_singularity():
    d = random_regular(np.random.default_rng(0), BIG)
    A = P.jacobian(d)
    assert A.shape[0] == BIG
    for sub in (A[:5], A):  # LAPACK path (small batch) and closed-form path (large batch)
        ref = np.linalg.pinv(sub)
        np.testing.assert_allclose(pseudo_inverse(sub), ref, atol=1e-9 * np.abs(ref).max())


def svd_regularised_inverse(A: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Aᵀ(AAᵀ + λI)⁻¹ = V diag(σ/(σ² + λ)) Uᵀ (independent route through the SVD)."""
    U, sv, Vt = np.linalg.svd(A, full_matrices=False)
    gain = sv / (sv**2 + np.asarray(lam)[..., None])
    return np.swapaxes(Vt, -1, -2) @ (gain[..., None] * np.swapaxes(U, -1, -2))


def test_pseudo_inverse_is_least_squares_at_singularity():
    A = P.jacobian(SINGULAR)
    # ≈ the minimum-norm least-squares inverse; the floating-point residue σ ~ 1e-14 h₀ of the
    # zero singular value is amplified by σ/ε̄ (ε̄ = PINV_EPS tr(AAᵀ)/3), a 1e-4 relative noise
    ref = np.linalg.pinv(A, rcond=1e-8)
    np.testing.assert_allclose(pseudo_inverse(A), ref, atol=1e-4 / P.h0)
    big = np.repeat(A, BIG // 5 + 1, 0)
    np.testing.assert_allclose(pseudo_inverse(big)[:: BIG // 5 + 1], ref, atol=1e-4 / P.h0)
    assert np.all(pseudo_inverse(np.zeros((3, 4))) == 0.0)


def test_sr_inverse_matches_svd_formula():
    """Aᵀ(AAᵀ + λI)⁻¹ = V diag(σ/(σ² + λ)) Uᵀ (independent route through the SVD)."""
    rng = np.random.default_rng(1)
    A = P.jacobian(np.concatenate([rng.uniform(-4, 4, (40, 4)), SINGULAR]))
    lam = rng.uniform(1e-3, 0.05, A.shape[0]) * P.h0**2
    eps_bar = PINV_EPS * np.trace(A @ np.swapaxes(A, -1, -2), axis1=-2, axis2=-1) / 3
    ref = svd_regularised_inverse(A, lam + eps_bar)
    np.testing.assert_allclose(singularity_robust_inverse(A, lam), ref, atol=1e-12 / P.h0)
    for i in (0, 41):
        np.testing.assert_allclose(singularity_robust_inverse(A[i], lam[i]), ref[i], atol=1e-14)


def test_jacobian_measure_equals_cluster_measure():
    d = np.random.default_rng(2).uniform(-4, 4, (30, 4))
    np.testing.assert_allclose(
        jacobian_singularity_measure(P.jacobian(d)), P.singularity_measure(d), atol=1e-13
    )


# ---------------------------------------------------------------------------- realising ḣ
@pytest.mark.parametrize("law", LAWS[:2], ids=LAW_IDS[:2])
def test_pinv_laws_realise_command_away_from_singularity(law):
    rng = np.random.default_rng(3)
    d = random_regular(rng, BIG)
    A = P.jacobian(d)
    h = rng.normal(size=(d.shape[0], 3))
    for k in (slice(0, 1), slice(0, 8), slice(None)):
        dd = law(A[k], h[k], d[k], 0.0, P)
        np.testing.assert_allclose(realised(A[k], dd), h[k], rtol=0, atol=1e-10)


@settings(max_examples=50, deadline=None)
@given(delta_st, hdot_st)
def test_pinv_realises_command_property(d, h):
    if P.singularity_measure(d) < 0.3:
        return
    A = P.jacobian(d)
    dd = PseudoInverse()(A, h)
    np.testing.assert_allclose(A @ dd, h, atol=1e-10 * (1 + np.linalg.norm(h)))
    # linear in ḣ and minimum-norm: orthogonal to the null space of A
    np.testing.assert_allclose(PseudoInverse()(A, 2.0 * h), 2.0 * dd, rtol=1e-13, atol=1e-300)
    null = np.linalg.svd(A)[2][-1]
    assert abs(null @ dd) <= 1e-10 * (1 + np.linalg.norm(dd))


def test_sr_error_shrinks_with_lambda():
    rng = np.random.default_rng(4)
    d = np.deg2rad([-80.0, 5.0, 85.0, -3.0])  # near the internal singularity
    A = P.jacobian(d)
    h = np.array([3.0, 1.0, -2.0])
    errs = [
        np.linalg.norm(A @ SingularityRobust(lambda0=lam0)(A, h) - h)
        for lam0 in (1e-1, 1e-2, 1e-3, 1e-4, 0.0)
    ]
    assert all(e1 > e2 for e1, e2 in zip(errs, errs[1:], strict=False))
    assert errs[-1] < 1e-8
    # λ₀ = 0 is the pseudo-inverse; far from singularities the default SR is almost exact
    np.testing.assert_allclose(SingularityRobust(lambda0=0.0)(A, h), PseudoInverse()(A, h))
    dr = random_regular(rng, 50, m_min=1.0)
    Ar = P.jacobian(dr)
    hr = rng.normal(size=(dr.shape[0], 3))
    np.testing.assert_allclose(realised(Ar, SingularityRobust()(Ar, hr)), hr, atol=1e-4)


def test_sr_rates_bounded_near_singularity():
    """|δ̇| ≤ |ḣ| / (2 h₀ √λ) for the SR inverse; the pseudo-inverse rates blow up instead."""
    h = np.array([1.0, 0.0, 0.0])
    law = SingularityRobust()
    for eps in (1e-2, 1e-4, 1e-6, 0.0):
        d = np.deg2rad([-90.0, 0.0, 90.0, 0.0]) + eps * np.array([1.0, 0.3, -0.7, 0.2])
        A = P.jacobian(d)
        m = P.singularity_measure(d)
        lam = law.lambda0 * np.exp(-law.mu * m**2)
        assert np.linalg.norm(law(A, h)) <= np.linalg.norm(h) / (2 * P.h0 * np.sqrt(lam)) * 1.001


# ---------------------------------------------------------------------------- singular inputs
def constructed_singular(rng: np.random.Generator, n: int) -> np.ndarray:
    g = P.gimbal_axes()
    h_zero = P.unit_momenta(np.zeros(4))
    a_zero = P.jacobian(np.zeros(4)) / P.h0
    out = []
    for _ in range(n):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        proj = (u[:, None] - g * (g.T @ u)[None, :]) * rng.choice([-1.0, 1.0], size=4)
        out.append(np.arctan2((proj * a_zero).sum(0), (proj * h_zero).sum(0)))
    return np.array(out)


@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_all_laws_finite_at_exact_singularities(law):
    rng = np.random.default_rng(5)
    d = np.concatenate([SINGULAR, constructed_singular(rng, 40)])
    d = np.tile(d, (BIG // d.shape[0] + 1, 1))
    assert np.all(P.singularity_measure(d) < 1e-6)
    A = P.jacobian(d)
    h = rng.normal(scale=10.0, size=(d.shape[0], 3))
    # the singular direction itself, the worst case
    u = np.linalg.svd(A)[0][..., :, -1]
    for hh in (h, 10.0 * u):
        batched = law(A, hh, d, 0.0, P)
        assert np.all(np.isfinite(batched))
        for i in (0, 2, 7):
            single = law(A[i], hh[i], d[i], 0.0, P)
            assert np.all(np.isfinite(single))
            # Exactly at a singularity the regularised inverse amplifies the rounding residue
            # of the zero singular value (≈1e-14 h₀) by 1/ε̄; the batched (Cramer + LU) and
            # single (LU) routes round differently, so agreement is at that noise level only.
            noise = 1e-2 * np.linalg.norm(hh[i]) / P.h0
            np.testing.assert_allclose(single, batched[i], atol=noise)
    z = law(np.zeros((3, 4)), np.ones(3), np.zeros(4), 0.0, P)
    assert np.all(np.isfinite(z))


@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_batched_equals_per_element(law):
    rng = np.random.default_rng(6)
    d = np.concatenate([rng.uniform(-4, 4, (BIG, 4)), SINGULAR])
    A = P.jacobian(d)
    h = rng.normal(scale=3.0, size=(d.shape[0], 3))
    batched = law(A, h, d, 0.0, P)
    assert batched.shape == (d.shape[0], 4)
    single = np.array([law(A[i], h[i], d[i], 0.0, P) for i in range(d.shape[0])])
    scale = 1.0 + np.abs(single).max(axis=-1, keepdims=True)
    np.testing.assert_allclose(batched / scale, single / scale, atol=1e-9)
    # extra leading dims
    for n in (60, BIG):
        nd = law(
            A[:n].reshape(n // 20, 20, 3, 4),
            h[:n].reshape(n // 20, 20, 3),
            d[:n].reshape(n // 20, 20, 4),
        )
        ref = law(A[:n], h[:n], d[:n])
        np.testing.assert_allclose(nd.reshape(n, 4), ref, rtol=1e-12, atol=1e-14)


# ---------------------------------------------------------------------------- null motion
def test_null_motion_in_null_space_and_climbs_measure():
    rng = np.random.default_rng(7)
    d = np.concatenate([rng.uniform(-4, 4, (BIG, 4)), SINGULAR])
    A = P.jacobian(d)
    zero = np.zeros((d.shape[0], 3))
    k = 0.5
    null = PseudoInverseNullMotion(k=k, cluster=P)(A, zero, d)
    np.testing.assert_allclose(realised(A, null), 0.0, atol=1e-7)
    _, grad = P.singularity_measure_and_gradient(d)
    rate = (grad * null).sum(-1)  # dm/dt along the null motion = k |(I − A⁺A)∇m|²
    assert np.all(rate >= -1e-12)
    np.testing.assert_allclose(rate, (null * null).sum(-1) / k, rtol=1e-6, atol=1e-12)
    # the null term is what is added on top of the pseudo-inverse
    h = rng.normal(size=(d.shape[0], 3))
    total = PseudoInverseNullMotion(k=k, cluster=P)(A, h, d)
    pinv = PseudoInverse()(A, h)
    np.testing.assert_allclose(total[:BIG] - pinv[:BIG], null[:BIG], atol=1e-9)
    # at exact singularities the two agree up to the regularised inverse's rounding noise
    np.testing.assert_allclose(total[BIG:] - pinv[BIG:], null[BIG:], atol=1e-2 / P.h0)


def test_seed000_null_motion_direction():
    """At (45°, −45°, 45°, −45°) ∇m is itself a null vector, so the null motion is k ∇m."""
    d = np.deg2rad([45.0, -45.0, 45.0, -45.0])
    law = PseudoInverseNullMotion(k=0.01)
    dd = law(P.jacobian(d), np.zeros(3), d, cluster=P)
    np.testing.assert_allclose(dd, 0.01 * P.singularity_measure_gradient(d), atol=1e-14)
    assert np.abs(dd).max() < 0.02  # the paper's gimbal-rate scale


def test_pure_null_motion_raises_measure_and_keeps_momentum():
    """RK4 integration of δ̇ = k (I − A⁺A)∇m: m increases monotonically, h(δ) stays put."""
    law = PseudoInverseNullMotion(k=1.0, cluster=P)
    rng = np.random.default_rng(8)
    near = np.deg2rad([[-90.0, 0.0, 90.0, 0.0], [90.0, 90.0, 90.0, 90.0]]) + 0.01
    d = np.concatenate([near, rng.uniform(-3, 3, (5, 4))])

    def f(x):
        return law(P.jacobian(x), np.zeros((x.shape[0], 3)), x)

    h0 = P.momentum(d)
    m_hist = [P.singularity_measure(d)]
    dt = 0.02
    for _ in range(50):
        k1 = f(d)
        k2 = f(d + 0.5 * dt * k1)
        k3 = f(d + 0.5 * dt * k2)
        k4 = f(d + dt * k3)
        d = d + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        m_hist.append(P.singularity_measure(d))
    m_hist = np.array(m_hist)
    assert np.all(np.diff(m_hist, axis=0) >= -1e-9)
    assert m_hist[-1, 0] > 1.5 * m_hist[0, 0]  # escapes the internal (hyperbolic) singularity
    # near the envelope (elliptic) there is no null motion to use: m stays put
    assert m_hist[-1, 1] == pytest.approx(m_hist[0, 1], rel=1e-6)
    assert np.all(m_hist[-1, 2:] > m_hist[0, 2:] + 1e-4)
    np.testing.assert_allclose(P.momentum(d), h0, atol=1e-6 * P.h0)


def test_null_motion_cluster_handling():
    d = np.deg2rad([10.0, 20.0, 30.0, 40.0])
    A = P.jacobian(d)
    h = np.ones(3)
    a = PseudoInverseNullMotion(cluster=P)(A, h, d)
    b = PseudoInverseNullMotion()(A, h, d, cluster=P)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="^cluster:"):
        PseudoInverseNullMotion()(A, h, d)
    with pytest.raises(ValueError, match="^cluster:"):
        PseudoInverseNullMotion(cluster=P)(A, h, d, cluster=SgcmgPyramid(h0=1.0))
    with pytest.raises(ValueError, match="^delta:"):
        PseudoInverseNullMotion(cluster=P)(A, h)
    with pytest.raises(ValueError, match="^delta:"):
        PseudoInverseNullMotion(cluster=P)(np.stack([A, A]), np.stack([h, h]), d)


# ---------------------------------------------------------------------------- saturation
def test_saturation_keeps_direction_and_flags():
    rng = np.random.default_rng(9)
    dd = rng.normal(scale=2.0, size=(200, 4))
    out, flag = saturate_gimbal_rates(dd, 1.0)
    peak = np.abs(dd).max(-1)
    np.testing.assert_array_equal(flag, peak > 1.0)
    assert np.all(np.abs(out).max(-1) <= 1.0 + 1e-15)
    np.testing.assert_allclose(np.abs(out[flag]).max(-1), 1.0, rtol=1e-15)
    np.testing.assert_array_equal(out[~flag], dd[~flag])
    # same direction: out = c dd with 0 < c ≤ 1
    c = (out * dd).sum(-1) / (dd * dd).sum(-1)
    assert np.all((c > 0) & (c <= 1.0))
    np.testing.assert_allclose(out, c[:, None] * dd, rtol=1e-14, atol=1e-300)
    # idempotent, per-spacecraft limits, leading dims
    again, flag2 = saturate_gimbal_rates(out, 1.0)
    np.testing.assert_array_equal(again, out)
    assert not flag2.any()
    lim = rng.uniform(0.5, 3.0, 200)
    out3, flag3 = saturate_gimbal_rates(dd, lim)
    np.testing.assert_array_equal(flag3, peak > lim)
    out4, flag4 = saturate_gimbal_rates(dd.reshape(10, 20, 4), 1.0)
    np.testing.assert_array_equal(out4.reshape(200, 4), out)
    assert flag4.shape == (10, 20)
    single, f1 = saturate_gimbal_rates(np.array([0.0, 3.0, -1.5, 0.3]), 0.5)
    np.testing.assert_allclose(single, [0.0, 0.5, -0.25, 0.05])
    assert f1.shape == () and bool(f1)


def test_saturation_bad_input():
    with pytest.raises(ValueError, match="^limit:"):
        saturate_gimbal_rates(np.ones(4), 0.0)
    with pytest.raises(ValueError, match="^delta_dot:"):
        saturate_gimbal_rates([np.nan, 0.0, 0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="^delta_dot:"):
        saturate_gimbal_rates(1.0, 1.0)


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_laws_bad_input(law):
    d = np.zeros(4)
    A = P.jacobian(d)
    with pytest.raises(ValueError, match="^A:"):
        law(np.zeros((4, 3)), np.ones(3), d)
    with pytest.raises(ValueError, match="^A:"):
        law(np.full((3, 4), np.nan), np.ones(3), d)
    with pytest.raises(ValueError, match="^hdot_cmd:"):
        law(A, np.ones(4), d)
    with pytest.raises(ValueError, match="^hdot_cmd:"):
        law(A, [np.inf, 0.0, 0.0], d)
    with pytest.raises(ValueError, match="^hdot_cmd:"):
        law(np.stack([A] * 3), np.ones((2, 3)), np.zeros((3, 4)))


def test_law_parameters_validated():
    with pytest.raises(ValueError, match="^eps:"):
        PseudoInverse(eps=0.0)
    with pytest.raises(ValueError, match="^k:"):
        PseudoInverseNullMotion(k=-1.0)
    with pytest.raises(ValueError, match="^cluster:"):
        PseudoInverseNullMotion(cluster="pyramid")
    with pytest.raises(ValueError, match="^lambda0:"):
        SingularityRobust(lambda0=-0.1)
    with pytest.raises(ValueError, match="^mu:"):
        SingularityRobust(mu=np.nan)
    with pytest.raises(ValueError, match="^lam:"):
        singularity_robust_inverse(np.eye(3, 4), -1.0)
    with pytest.raises(ValueError, match="^A:"):
        pseudo_inverse(np.ones(3))


@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_inputs_not_mutated(law):
    rng = np.random.default_rng(10)
    d = rng.uniform(-3, 3, (40, 4))
    A = P.jacobian(d)
    h = rng.normal(size=(40, 3))
    copies = [x.copy() for x in (d, A, h)]
    law(A, h, d, 0.0, P)
    law(A[:1], h[:1], d[:1], 0.0, P)
    for x, c in zip((d, A, h), copies, strict=True):
        np.testing.assert_array_equal(x, c)
