"""Tests for liecontrol.lie.se3 (SPEC §2): against scipy.linalg.expm of the 4×4 (and 6×6)
generators, finite differences and the group axioms, on random inputs (hypothesis) and on fixed
grids near rotation angles 0 and π."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.linalg import expm

from liecontrol.lie import se3, so3

PI = np.pi
HYP = settings(max_examples=100, deadline=None)
HYP_SLOW = settings(max_examples=40, deadline=None)

_rng = np.random.default_rng(314)
_AXES = np.vstack([np.eye(3), np.ones(3) / np.sqrt(3.0), _rng.normal(size=(4, 3))])
_AXES /= np.linalg.norm(_AXES, axis=1, keepdims=True)
_V = _rng.normal(size=(len(_AXES), 3)) * 2.0
ANGLES = np.concatenate(
    [
        [0.0],
        10.0 ** np.arange(-12.0, -3.5, 1.0),
        [0.1, 0.5, 0.999, 1.0, 1.001, 2.0, 3.0],
        PI - np.array([1e-3, 1e-6, 1e-9, 1e-12]),
    ]
)
XI_GRID = np.concatenate(
    [np.hstack([a * _AXES, _V]) for a in ANGLES] + [np.hstack([np.zeros((3, 3)), _V[:3]])]
)

unit = arrays(np.float64, 3, elements=st.floats(-1.0, 1.0)).filter(
    lambda a: np.linalg.norm(a) > 1e-3
)
angles = st.floats(0.0, PI - 1e-9)
vec = arrays(np.float64, 3, elements=st.floats(-5.0, 5.0))


def _twist(axis, theta, v):
    return np.concatenate([axis / np.linalg.norm(axis) * theta, v])


def _rel(a, b):
    nb = np.linalg.norm(b, axis=-1)
    return np.linalg.norm(a - b, axis=-1) / np.where(nb > 0, nb, 1.0)


# ---------------------------------------------------------------- hat / vee / exp / log
@HYP
@given(vec, vec)
def test_hat_vee(w, v):
    xi = np.concatenate([w, v])
    X = se3.hat(xi)
    np.testing.assert_array_equal(X[:3, :3], so3.hat(w))
    np.testing.assert_array_equal(X[:3, 3], v)
    np.testing.assert_array_equal(X[3], 0.0)
    np.testing.assert_array_equal(se3.vee(X), xi)
    # action of the generator on a homogeneous point: ω × x + v
    x = np.array([0.4, -1.0, 2.0, 1.0])
    np.testing.assert_allclose((X @ x)[:3], np.cross(w, x[:3]) + v, atol=1e-12)


def test_exp_matches_expm_on_grid():
    g = se3.exp(XI_GRID)
    ref = np.array([expm(se3.hat(xi)) for xi in XI_GRID])
    np.testing.assert_allclose(g, ref, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(g[:, 3, :], np.tile([0.0, 0.0, 0.0, 1.0], (len(g), 1)))


@HYP_SLOW
@given(unit, st.floats(0.0, 3 * PI), vec)
def test_exp_matches_expm_random(axis, theta, v):
    xi = _twist(axis, theta, v)
    np.testing.assert_allclose(se3.exp(xi), expm(se3.hat(xi)), rtol=0, atol=1e-12)


def test_log_exp_round_trip_on_grid():
    xi = XI_GRID
    assert _rel(se3.log(se3.exp(xi)), xi).max() <= 1e-12


@HYP
@given(unit, angles, vec)
def test_log_exp_round_trip_random(axis, theta, v):
    xi = _twist(axis, theta, v)
    assert _rel(se3.log(se3.exp(xi)), xi) <= 1e-12


def test_exp_log_round_trip_including_half_turns():
    rng = np.random.default_rng(1)
    n = _AXES[:, :, None]
    half = 2.0 * n * np.swapaxes(n, -1, -2) - np.eye(3)
    R = np.concatenate([half, np.diag([1.0, -1.0, -1.0])[None], so3.random(rng, 500)])
    g = se3.from_rt(R, rng.normal(size=(len(R), 3)) * 3.0)
    xi = se3.log(g)
    assert np.all(np.isfinite(xi))
    assert np.linalg.norm(xi[:, :3], axis=1).max() <= PI + 1e-15
    assert np.abs(se3.exp(xi) - g).max() <= 1e-12


# ---------------------------------------------------------------- group axioms
@HYP
@given(unit, angles, vec, unit, angles, vec, vec)
def test_group_axioms_and_action(a1, t1, v1, a2, t2, v2, x):
    g1 = se3.exp(_twist(a1, t1, v1))
    g2 = se3.exp(_twist(a2, t2, v2))
    g3 = se3.from_rt(so3.exp(v1 / 7.0), v2)
    np.testing.assert_allclose(
        se3.compose(se3.compose(g1, g2), g3), se3.compose(g1, se3.compose(g2, g3)), atol=1e-12
    )
    np.testing.assert_allclose(se3.compose(g1, se3.inverse(g1)), np.eye(4), atol=1e-13)
    np.testing.assert_allclose(se3.inverse(g1), np.linalg.inv(g1), atol=1e-12)
    np.testing.assert_array_equal(se3.compose(se3.identity(), g1), g1)
    np.testing.assert_allclose(se3.act(g1, se3.act(g2, x)), se3.act(g1 @ g2, x), atol=1e-12)
    np.testing.assert_allclose(se3.act(g1, x), (g1 @ np.append(x, 1.0))[:3], atol=1e-13)
    np.testing.assert_array_equal(se3.rotation(g1), g1[:3, :3])
    np.testing.assert_array_equal(se3.translation(g1), g1[:3, 3])
    np.testing.assert_array_equal(se3.from_rt(se3.rotation(g1), se3.translation(g1)), g1)


# ---------------------------------------------------------------- Jacobians
def _fd(xi: np.ndarray, side: str, h: float = 1e-6) -> np.ndarray:
    gi = se3.inverse(se3.exp(xi))
    E = h * np.eye(6)
    if side == "right":
        plus, minus = se3.log(gi @ se3.exp(xi + E)), se3.log(gi @ se3.exp(xi - E))
    else:
        plus, minus = se3.log(se3.exp(xi + E) @ gi), se3.log(se3.exp(xi - E) @ gi)
    return ((plus - minus) / (2 * h)).T


JAC_XI = XI_GRID[:: max(1, len(XI_GRID) // 25)]


@pytest.mark.parametrize("xi", JAC_XI, ids=lambda x: f"|w|={np.linalg.norm(x[:3]):.3g}")
def test_jacobians_against_finite_differences(xi):
    tol = 5e-8 * max(1.0, np.linalg.norm(xi))
    Jl, Jr = se3.left_jacobian(xi), se3.right_jacobian(xi)
    np.testing.assert_allclose(Jr, _fd(xi, "right"), atol=tol)
    np.testing.assert_allclose(Jl, _fd(xi, "left"), atol=tol)
    I6 = np.eye(6)
    np.testing.assert_allclose(Jl @ se3.left_jacobian_inv(xi), I6, atol=1e-11)
    np.testing.assert_allclose(Jr @ se3.right_jacobian_inv(xi), I6, atol=1e-11)
    # J_l(ξ) = Ad_{exp ξ} J_r(ξ), J_r(ξ) = J_l(−ξ), and the ω-blocks are the SO(3) Jacobians
    np.testing.assert_allclose(Jl, se3.adjoint(se3.exp(xi)) @ Jr, atol=1e-12)
    np.testing.assert_array_equal(Jr, se3.left_jacobian(-xi))
    np.testing.assert_allclose(Jl[:3, :3], so3.left_jacobian(xi[:3]), atol=0)
    np.testing.assert_array_equal(Jl[:3, 3:], 0.0)


@HYP
@given(unit, st.floats(0.0, 3.0), vec)
def test_jacobian_inverses_random(axis, theta, v):
    xi = _twist(axis, theta, v)
    np.testing.assert_allclose(
        se3.left_jacobian(xi) @ se3.left_jacobian_inv(xi), np.eye(6), atol=1e-11
    )
    np.testing.assert_allclose(
        se3.right_jacobian_inv(xi) @ se3.right_jacobian(xi), np.eye(6), atol=1e-11
    )


def test_q_block_continuous_at_series_switch():
    axis, v = _AXES[-1], _V[-1]
    lo = se3.left_jacobian(np.concatenate([axis * (1 - 1e-13), v]))
    hi = se3.left_jacobian(np.concatenate([axis * (1 + 1e-13), v]))
    assert np.abs(lo - hi).max() < 1e-12


# ---------------------------------------------------------------- adjoints
@HYP_SLOW
@given(unit, angles, vec, vec, vec)
def test_adjoint_identities(axis, theta, p, w, v):
    g = se3.from_rt(so3.exp(axis / np.linalg.norm(axis) * theta), p)
    xi = np.concatenate([w, v]) / 3.0
    eta = np.concatenate([v, w])
    Ad = se3.adjoint(g)
    np.testing.assert_allclose(se3.exp(Ad @ xi), g @ se3.exp(xi) @ se3.inverse(g), atol=1e-11)
    np.testing.assert_allclose(se3.hat(Ad @ xi), g @ se3.hat(xi) @ se3.inverse(g), atol=1e-12)
    # Ad is a homomorphism, Ad_{exp ξ} = expm(ad_ξ), ad is the bracket
    h = se3.exp(eta / 4.0)
    np.testing.assert_allclose(se3.adjoint(g @ h), Ad @ se3.adjoint(h), atol=1e-12)
    np.testing.assert_allclose(se3.adjoint(se3.exp(xi)), expm(se3.ad(xi)), atol=1e-10)
    bracket = se3.vee(se3.hat(xi) @ se3.hat(eta) - se3.hat(eta) @ se3.hat(xi))
    np.testing.assert_allclose(se3.ad(xi) @ eta, bracket, atol=1e-12)
    np.testing.assert_allclose(se3.adjoint(se3.inverse(g)), np.linalg.inv(Ad), atol=1e-11)
    # coadjoint: pairing invariance and transport of a wrench (m, f) applied at g's origin
    mu = np.concatenate([v, w])
    np.testing.assert_allclose((se3.coadjoint(g) @ mu) @ (Ad @ xi), mu @ xi, atol=1e-10)
    m, f = mu[:3], mu[3:]
    R = g[:3, :3]
    np.testing.assert_allclose(
        se3.coadjoint(g) @ mu, np.concatenate([R @ m + np.cross(p, R @ f), R @ f]), atol=1e-12
    )


# ---------------------------------------------------------------- distance / interpolation
@HYP
@given(unit, angles, vec, unit, angles, vec)
def test_distance_and_interpolation(a0, t0, p0, a1, t1, p1):
    g0 = se3.exp(_twist(a0, t0, p0))
    g1 = se3.exp(_twist(a1, t1, p1))
    d = se3.distance(g0, g1, length_scale=2.0)
    theta = so3.distance(g0[:3, :3], g1[:3, :3])
    dp = np.linalg.norm(g1[:3, 3] - g0[:3, 3])
    assert d == pytest.approx(np.hypot(theta, dp / 2.0), abs=1e-12)
    h = se3.from_rt(so3.exp(p1 / 9.0), p0)
    assert se3.distance(h @ g0, h @ g1, 2.0) == pytest.approx(d, abs=1e-11)  # left-invariant
    assert se3.distance(g0, g0) == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(se3.interpolate(g0, g1, 0.0), g0, atol=1e-13)
    np.testing.assert_allclose(se3.interpolate(g0, g1, 1.0), g1, atol=1e-10)
    gm = se3.interpolate(g0, g1, 0.5)
    # the midpoint of the screw geodesic: g0⁻¹ gm = exp(½ log(g0⁻¹ g1)), its square is g0⁻¹ g1
    step = se3.inverse(g0) @ gm
    np.testing.assert_allclose(step @ step, se3.inverse(g0) @ g1, atol=1e-10)


# ---------------------------------------------------------------- batching
@pytest.mark.parametrize("shape", [(), (5,), (2, 3)], ids=str)
def test_batched_calls_equal_one_by_one(shape):
    rng = np.random.default_rng(4)
    xi = rng.normal(size=shape + (6,)) * 1.5
    g = se3.random(rng, shape, translation_scale=3.0)
    g2 = se3.random(rng, shape)
    x = rng.normal(size=shape + (3,))
    s = rng.uniform(size=shape)
    funcs = {
        "hat": lambda i: se3.hat(xi[i]),
        "exp": lambda i: se3.exp(xi[i]),
        "log": lambda i: se3.log(g[i]),
        "jl": lambda i: se3.left_jacobian(xi[i]),
        "jr": lambda i: se3.right_jacobian(xi[i]),
        "jli": lambda i: se3.left_jacobian_inv(xi[i]),
        "jri": lambda i: se3.right_jacobian_inv(xi[i]),
        "Ad": lambda i: se3.adjoint(g[i]),
        "ad": lambda i: se3.ad(xi[i]),
        "coAd": lambda i: se3.coadjoint(g[i]),
        "compose": lambda i: se3.compose(g[i], g2[i]),
        "inverse": lambda i: se3.inverse(g[i]),
        "act": lambda i: se3.act(g[i], x[i]),
        "distance": lambda i: se3.distance(g[i], g2[i]),
        "interpolate": lambda i: se3.interpolate(g[i], g2[i], s[i]),
    }
    everything = (slice(None),) * len(shape) if shape else ()
    for key, f in funcs.items():
        batched = f(everything) if shape else f(...)
        assert batched.shape[: len(shape)] == shape, key
        for idx in np.ndindex(*shape):
            np.testing.assert_allclose(batched[idx], f(idx), rtol=0, atol=1e-14, err_msg=key)


def test_random_and_inputs_not_mutated():
    rng = np.random.default_rng(5)
    g = se3.random(rng, 1000, translation_scale=2.0)
    se3.validate(g)
    np.testing.assert_allclose(g[:, :3, 3].std(axis=0), 2.0, rtol=0.1)
    g0 = g.copy()
    se3.log(g), se3.inverse(g), se3.adjoint(g), se3.interpolate(g, g[::-1], 0.3)
    np.testing.assert_array_equal(g, g0)
    np.testing.assert_array_equal(
        se3.random(np.random.default_rng(3), 2), se3.random(np.random.default_rng(3), 2)
    )


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("func", "args", "name"),
    [
        (se3.exp, ([0.0, 0.0, np.nan, 1.0, 2.0, 3.0],), "xi"),
        (se3.exp, ([0.0, 0.0, 1.0],), "xi"),
        (se3.log, (np.eye(3),), "g"),
        (se3.log, (np.full((4, 4), np.inf),), "g"),
        (se3.left_jacobian, (np.ones(5),), "xi"),
        (se3.from_rt, (np.eye(3), [1.0, np.nan, 0.0]), "p"),
        (se3.from_rt, (np.eye(4), [1.0, 0.0, 0.0]), "R"),
        (se3.act, (np.eye(4), [1.0, 0.0]), "x"),
        (se3.distance, (np.eye(4), np.eye(4), 0.0), "length_scale"),
        (se3.random, (np.random.default_rng(0), 3, -1.0), "translation_scale"),
    ],
)
def test_bad_input_raises_naming_the_argument(func, args, name):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        func(*args)


def test_validate():
    g = se3.random(np.random.default_rng(9), 3)
    np.testing.assert_array_equal(se3.validate(g), g)
    bad = g.copy()
    bad[1, 0, 1] += 1e-5
    with pytest.raises(ValueError, match=r"^g: not orthonormal"):
        se3.validate(bad)
    bad = g.copy()
    bad[0, 3, 0] = 0.1
    with pytest.raises(ValueError, match=r"^g_d: last row"):
        se3.validate(bad, name="g_d")
    bad = g.copy()
    bad[2, 1, 3] = np.nan
    with pytest.raises(ValueError, match=r"^g: contains"):
        se3.validate(bad)
