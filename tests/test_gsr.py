"""Generalized singularity-robust steering (Wie 2005) and the steering hot path (SPEC §5.2)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol.control import ConstantAttitude
from liecontrol.control.base import AttitudeController
from spacecraft import RigidBody, SgcmgActuator, SgcmgPyramid, Spacecraft, simulate
from spacecraft.steering import (
    _SMALL_BATCH,
    PINV_EPS,
    GeneralizedSingularityRobust,
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularityRobust,
    _saturate_unchecked,
    saturate_gimbal_rates,
)

P = SgcmgPyramid()
GSR = GeneralizedSingularityRobust()
INTERNAL = np.deg2rad([-90.0, 0.0, 90.0, 0.0])  # internal singularity, singular direction x
SINGULAR = np.deg2rad([[90.0, 90.0, 90.0, 90.0], [-90.0, 0.0, 90.0, 0.0], [0.0, 90.0, 0.0, -90.0]])
ALL_LAWS = [PseudoInverse(), PseudoInverseNullMotion(cluster=P), SingularityRobust(), GSR]
ALL_IDS = ["pinv", "pinv_null", "sr", "gsr"]


def paper_gsr(A: np.ndarray, h: np.ndarray, t: float, law: GeneralizedSingularityRobust):
    """Wie (2005) written out with numpy's SVD/solve, one spacecraft at a time (independent
    route): Â = A/s, λ = λ₀ exp(−μ det(ÂÂᵀ)), δ̇ = Âᵀ(ÂÂᵀ + λE)⁻¹ ḣ / s (+ the ε floor)."""
    e1, e2, e3 = (law.epsilon0 * np.sin(law.omega_eps * t + p) for p in law.phases)
    E = np.array([[1.0, e3, e2], [e3, 1.0, e1], [e2, e1, 1.0]])
    out = []
    for a, hh in zip(A, h, strict=True):
        s = np.sqrt((a**2).sum() / a.shape[1])
        ah = a / s
        lam = law.lambda0 * np.exp(-law.mu * np.linalg.det(ah @ ah.T))
        floor = PINV_EPS * np.trace(ah @ ah.T) / 3.0
        out.append(ah.T @ np.linalg.solve(ah @ ah.T + lam * E + floor * np.eye(3), hh) / s)
    return np.array(out)


@pytest.mark.parametrize("n", [1, 7, _SMALL_BATCH + 40])
def test_gsr_matches_paper_formula(n):
    """Float route (n = 1), LAPACK route (small batch), Cramer route (large batch)."""
    rng = np.random.default_rng(0)
    d = np.concatenate([rng.uniform(-4, 4, (n, 4)), SINGULAR])[:n]
    A = P.jacobian(d)
    h = rng.normal(scale=20.0, size=(n, 3))
    for t in (0.0, 0.7, 3.3):
        law = GeneralizedSingularityRobust(epsilon0=0.2, lambda0=0.05)
        ref = paper_gsr(A, h, t, law)
        got = law(A, h, d, t, P)
        scale = 1.0 + np.abs(ref).max(axis=-1, keepdims=True)
        np.testing.assert_allclose(got / scale, ref / scale, atol=1e-9)


def test_dither_matrix_is_the_papers():
    law = GeneralizedSingularityRobust(epsilon0=0.3, omega_eps=2.0, phases=(0.1, 0.2, 0.3))
    t = 1.7
    e = 0.3 * np.sin(2.0 * t + np.array([0.1, 0.2, 0.3]))
    np.testing.assert_allclose(
        law.dither_matrix(t),
        [[1.0, e[2], e[1]], [e[2], 1.0, e[0]], [e[1], e[0], 1.0]],
        rtol=1e-15,
    )
    assert np.linalg.eigvalsh(law.dither_matrix(t)).min() >= 1 - 2 * 0.3 - 1e-15


def test_gsr_without_dither_is_sr_and_nearly_exact_away_from_singularities():
    rng = np.random.default_rng(1)
    d = rng.uniform(-4, 4, (300, 4))
    A = P.jacobian(d)
    h = rng.normal(size=(300, 3))
    plain = GeneralizedSingularityRobust(epsilon0=0.0)(A, h, d, 2.0, P)
    np.testing.assert_allclose(plain, SingularityRobust()(A, h), rtol=1e-12, atol=1e-15)
    good = P.singularity_measure(d) > 1.0
    dd = GSR(A[good], h[good], d[good], 5.0, P)
    np.testing.assert_allclose((A[good] @ dd[..., None])[..., 0], h[good], atol=1e-4)


#: ḣ components for the linearity property: 0, or 1e-200 ≤ |h_i| ≤ 1e3. Doubling is exact in
#: floating point only while no intermediate underflows: every intermediate of the steering law
#: is h_i times a product of a few matrix entries (≳ 1e-50 even at a singularity), so below
#: ~1e-258 it would be subnormal, and then `GSR(2h) == 2 GSR(h)` is off by an ulp
#: (hypothesis found h = (0, 0, 2.2e-309)). The floor leaves > 50 decades of margin.
_H_COMPONENT = st.one_of(
    st.just(0.0),
    st.floats(1e-200, 1e3, allow_subnormal=False),
    st.floats(-1e3, -1e-200, allow_subnormal=False),
)


@settings(max_examples=40, deadline=None)
@given(
    d=st.tuples(*[st.floats(-7, 7)] * 4).map(np.array),
    h=st.tuples(*[_H_COMPONENT] * 3).map(np.array),
    t=st.floats(0.0, 1e4),
)
def test_gsr_finite_and_linear(d, h, t):
    A = P.jacobian(d)
    dd = GSR(A, h, d, t, P)
    assert np.all(np.isfinite(dd))
    np.testing.assert_array_equal(GSR(A, 2.0 * h, d, t, P), 2.0 * dd)


def test_gsr_finite_at_exact_singularities_and_moves_off_them():
    """ḣ along the singular direction: SR gives δ̇ = 0, GSR a non-zero, finite δ̇."""
    rng = np.random.default_rng(2)
    d = np.repeat(SINGULAR, 100, axis=0)  # batch large enough for the Cramer route too
    A = P.jacobian(d)
    u = np.linalg.svd(A)[0][..., :, -1]
    assert np.all(P.singularity_measure(d) < 1e-6)
    for h in (10.0 * u, rng.normal(scale=10.0, size=d.shape[:1] + (3,))):
        for t in (0.0, 0.4, 2.9):
            dd = GSR(A, h, d, t, P)
            assert np.all(np.isfinite(dd))
            np.testing.assert_allclose(GSR(A[:1], h[:1], d[:1], t, P), dd[:1], atol=1e-2 / P.h0)
    sr = SingularityRobust()(A[100:101], 10.0 * u[100:101])
    gsr = GSR(A[100:101], 10.0 * u[100:101], d[100:101], 0.3, P)
    assert np.abs(sr).max() < 1e-6 * np.abs(gsr).max()
    assert np.abs(gsr).max() > 1e-4
    assert np.all(np.isfinite(GSR(np.zeros((3, 4)), np.ones(3), np.zeros(4), 1.0, P)))


class _ConstantTorque(AttitudeController):
    def __init__(self, u: np.ndarray) -> None:
        self.u = np.asarray(u, dtype=np.float64)

    def reset(self, t0: float, batch_size: int) -> None:
        self.B = batch_size

    def command(self, t, state, reference):
        return np.tile(self.u, (self.B, 1))


def test_gsr_passes_internal_singularity_where_pseudo_inverse_is_stuck():
    """Same case for both laws: the cluster starts at the internal singularity
    δ = (−90°, 0, 90°, 0) (h = 2 cos β h₀ x̂, singular direction x) and the bus asks for the
    momentum rate ḣ = 0.5 h₀/s along +x (constant torque u = −ḣ, ω × h ≈ 0 on a heavy bus).
    The pseudo-inverse's rates lie in the null space of the request: it pins the gimbal-rate
    limit and delivers no momentum; the GSR dither moves the gimbals off the singularity and
    the momentum goes through it (Wie 2005, Fig. 3 case)."""
    J = np.diag([2e4, 2.2e4, 1.8e4])
    rate = 0.5 * P.h0
    out = {}
    for name, law in (("pinv", PseudoInverse()), ("gsr", GSR)):
        plant = Spacecraft(RigidBody(J), SgcmgActuator(P, law, delta0=INTERNAL))
        s0 = plant.initial_state(np.eye(3))
        res = simulate(
            plant, _ConstantTorque([-rate, 0.0, 0.0]), ConstantAttitude(np.eye(3)), s0, 5.0, 0.05
        )
        H = np.einsum("kbij,kbj->kbi", res.R, res.omega @ J + res.actuator["h"])[:, 0]
        assert np.abs(H - H[0]).max() < 1e-8 * P.h0  # the momentum exchange stays exact
        out[name] = res
    dh = {k: (r.actuator["h"][-1, 0, 0] - r.actuator["h"][0, 0, 0]) / P.h0 for k, r in out.items()}
    assert out["pinv"].actuator["singularity"][0, 0] < 1e-12
    # pseudo-inverse: rate limit hit, momentum stuck at the singular value
    assert out["pinv"].actuator["saturated"][1:].mean() > 0.9
    assert abs(dh["pinv"]) < 0.01
    # GSR: leaves the singularity and delivers most of the 2.5 h₀ asked for
    assert out["gsr"].actuator["singularity"][:, 0].max() > 1.0
    assert dh["gsr"] > 1.0


# ---------------------------------------------------------------------------- hot path
@pytest.mark.parametrize("law", ALL_LAWS, ids=ALL_IDS)
def test_unchecked_steer_equals_validated_call(law):
    rng = np.random.default_rng(3)
    for n in (1, 5, _SMALL_BATCH + 3):
        d = rng.uniform(-4, 4, (n, 4))
        A = P.jacobian(d)
        h = rng.normal(size=(n, 3))
        np.testing.assert_array_equal(law.steer(A, h, d, 1.3, P), law(A, h, d, 1.3, P))


@pytest.mark.parametrize("law", ALL_LAWS, ids=ALL_IDS)
def test_single_spacecraft_kernel_route_matches_batched_route(law):
    """One spacecraft, a batch of two and an unbatched Jacobian give the same rates (the
    compiled kernel's result against an explicit solve: tests/test_kernels.py)."""
    rng = np.random.default_rng(4)
    d = np.concatenate([rng.uniform(-4, 4, (30, 4)), np.deg2rad([[-80.0, 5.0, 85.0, -3.0]])])
    A = P.jacobian(d)
    h = rng.normal(scale=5.0, size=(d.shape[0], 3))
    for i in range(d.shape[0]):
        pair = law(A[[i, i]], h[[i, i]], d[[i, i]], 0.9, P)[0]
        one = law(A[i : i + 1], h[i : i + 1], d[i : i + 1], 0.9, P)[0]
        bare = law(A[i], h[i], d[i], 0.9, P)
        scale = 1.0 + np.abs(pair).max()
        np.testing.assert_allclose(one / scale, pair / scale, atol=1e-12)
        np.testing.assert_array_equal(bare, one)


def test_saturation_of_one_row_matches_the_batch():
    rng = np.random.default_rng(5)
    dd = rng.normal(scale=2.0, size=(50, 4))
    both, flags = _saturate_unchecked(dd, 1.0)
    for i in range(50):
        one, f1 = _saturate_unchecked(dd[i : i + 1], 1.0)
        np.testing.assert_array_equal(one, both[i : i + 1])
        assert f1.shape == (1,) and f1[0] == flags[i]
    public, pflags = saturate_gimbal_rates(dd, 1.0)
    np.testing.assert_array_equal(public, both)
    np.testing.assert_array_equal(pflags, flags)
    zero, fz = _saturate_unchecked(np.zeros((1, 4)), 1.0)
    assert not fz[0] and np.all(zero == 0.0)


def test_actuator_calls_unchecked_steer_with_time():
    """The plant passes t to the law: the GSR rates differ with t at a singularity."""
    act = SgcmgActuator(P, GSR, delta0=INTERNAL)
    x = act.initial_state(1)
    u = np.array([[-10.0, 0.0, 0.0]])
    a = act.command(u, np.zeros((1, 3)), x, 0.0).delta_dot
    b = act.command(u, np.zeros((1, 3)), x, 1.0).delta_dot
    assert np.abs(a - b).max() > 1e-6
    A = P.jacobian(x)
    np.testing.assert_allclose(a, GSR(A, -u, x, 0.0, P), rtol=1e-12, atol=1e-15)


def test_actuator_rejects_law_with_other_cluster():
    with pytest.raises(ValueError, match="^steering:"):
        SgcmgActuator(P, PseudoInverseNullMotion(cluster=SgcmgPyramid(h0=10.0)))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"lambda0": -1.0}, "lambda0"),
        ({"mu": np.nan}, "mu"),
        ({"epsilon0": 0.5}, "epsilon0"),
        ({"epsilon0": -0.1}, "epsilon0"),
        ({"omega_eps": np.inf}, "omega_eps"),
        ({"phases": (0.0, 1.0)}, "phases"),
        ({"phases": "abc"}, "phases"),
        ({"phases": (0.0, np.nan, 1.0)}, "phases"),
    ],
)
def test_gsr_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        GeneralizedSingularityRobust(**kwargs)


def test_gsr_bad_inputs_and_no_mutation():
    A = P.jacobian(np.zeros(4))
    with pytest.raises(ValueError, match="^A:"):
        GSR(np.zeros((4, 3)), np.ones(3))
    with pytest.raises(ValueError, match="^hdot_cmd:"):
        GSR(A, [np.nan, 0.0, 0.0])
    d = np.random.default_rng(6).uniform(-3, 3, (9, 4))
    A = P.jacobian(d)
    h = np.ones((9, 3))
    copies = [x.copy() for x in (A, h, d)]
    GSR(A, h, d, 1.0, P)
    GSR(A[:1], h[:1], d[:1], 1.0, P)
    for x, c in zip((A, h, d), copies, strict=True):
        np.testing.assert_array_equal(x, c)
