"""Tests for liecontrol.charts: conversions against scipy, kinematics against finite differences
of an exact trajectory, singularities, bad input, batch shapes and hypothesis round trips."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation as Rot

from liecontrol.charts import ChartSingularityError, euler, mrp, quaternion, rotvec
from liecontrol.exceptions import ChartSingularityError as ExcChartSingularityError
from liecontrol.lie import so3

SEED = 20261121


def _rng(k: int = 0) -> np.random.Generator:
    return np.random.default_rng(SEED + k)


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def _half_turns(n: int, rng: np.random.Generator) -> np.ndarray:
    axis = rng.normal(size=(n, 3))
    axis[:3] = np.eye(3)  # coordinate axes: the exact-zero-entry cases
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    return so3.exp(np.pi * axis)


# --------------------------------------------------------------------------- exact trajectory
# R(t) = exp(t a) exp(t b) has body rate ω(t) = exp(−t b) a + b exactly:
# RᵀṘ = exp(−tb) a^ exp(tb) + b^ = (exp(−tb) a)^ + b^.
A_VEC = np.array([0.7, -0.4, 0.9])
B_VEC = np.array([-0.3, 0.8, 0.5])


def traj_R(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=float)[..., None]
    return so3.exp(t * A_VEC) @ so3.exp(t * B_VEC)


def traj_omega(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=float)[..., None]
    return np.einsum("...ij,j->...i", so3.exp(-t * B_VEC), A_VEC) + B_VEC


T_GRID = np.linspace(0.05, 2.5, 40)
DT = 1e-5


def central_diff(chart, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(chart(R(t)), (chart(R(t+δ)) − chart(R(t−δ)))/2δ)."""
    c0 = chart(traj_R(t))
    return c0, (chart(traj_R(t + DT)) - chart(traj_R(t - DT))) / (2.0 * DT)


def test_trajectory_matches_integration_of_body_rate():
    """The closed-form trajectory used below solves Ṙ = R ω^: integrate with so3.exp steps of
    the known ω(t) (midpoint rule, 2nd order) and compare; halving h quarters the error."""
    errs = []
    for n in (400, 800):
        h = 2.0 / n
        R = np.eye(3)
        for k in range(n):
            R = R @ so3.exp(h * traj_omega((k + 0.5) * h))
        errs.append(np.abs(R - traj_R(2.0)).max())
    assert errs[1] < 2e-5
    assert 3.5 < errs[0] / errs[1] < 4.5


# --------------------------------------------------------------------------- quaternion


@pytest.mark.parametrize("scalar_first", [True, False])
def test_quaternion_matrix_roundtrip_vs_scipy(scalar_first):
    rng = _rng(1)
    R = np.concatenate(
        (
            Rot.random(200, random_state=3).as_matrix(),
            _half_turns(20, rng),
            so3.exp((np.pi - 1e-9) * np.array([[0.0, 0.6, 0.8]])),
            so3.exp(np.array([[1e-13, 0.0, 0.0], [0.0, 0.0, 0.0]])),
        )
    )
    q = quaternion.from_matrix(R, scalar_first=scalar_first)
    ref = Rot.from_matrix(R).as_quat(canonical=True, scalar_first=scalar_first)
    np.testing.assert_allclose(q, ref, atol=2e-15)
    np.testing.assert_allclose(quaternion.to_matrix(q, scalar_first=scalar_first), R, atol=2e-15)
    np.testing.assert_allclose(
        quaternion.to_matrix(ref, scalar_first=scalar_first),
        Rot.from_quat(ref, scalar_first=scalar_first).as_matrix(),
        atol=2e-15,
    )


def test_quaternion_half_turn_exact():
    q = quaternion.from_matrix(np.diag([1.0, -1.0, -1.0]))
    np.testing.assert_array_equal(q, [0.0, 1.0, 0.0, 0.0])
    q = quaternion.from_matrix(np.diag([-1.0, -1.0, 1.0]), scalar_first=False)
    np.testing.assert_array_equal(q, [0.0, 0.0, 1.0, 0.0])


def test_quaternion_storage_orders_agree():
    q = Rot.random(10, random_state=4).as_quat(scalar_first=True)
    qs = np.roll(q, -1, axis=-1)
    p = Rot.random(10, random_state=5).as_quat(scalar_first=True)
    ps = np.roll(p, -1, axis=-1)
    np.testing.assert_allclose(
        np.roll(quaternion.multiply(p, q), -1, axis=-1),
        quaternion.multiply(ps, qs, scalar_first=False),
        atol=1e-15,
    )
    np.testing.assert_allclose(
        quaternion.to_matrix(q), quaternion.to_matrix(qs, scalar_first=False), atol=1e-15
    )
    np.testing.assert_allclose(
        quaternion.kinematics_matrix(q)[..., [1, 2, 3, 0], :],
        quaternion.kinematics_matrix(qs, scalar_first=False),
        atol=1e-15,
    )


def test_quaternion_multiply_is_matrix_product_and_scipy_composition():
    r1, r2 = Rot.random(20, random_state=6), Rot.random(20, random_state=7)
    q1, q2 = r1.as_quat(scalar_first=True), r2.as_quat(scalar_first=True)
    q12 = quaternion.multiply(q1, q2)
    np.testing.assert_allclose(
        quaternion.to_matrix(q12), r1.as_matrix() @ r2.as_matrix(), atol=2e-15
    )
    np.testing.assert_allclose(q12, (r1 * r2).as_quat(scalar_first=True), atol=2e-15)
    # Hamilton basis: i ⊗ j = k
    np.testing.assert_array_equal(
        quaternion.multiply([0.0, 1, 0, 0], [0.0, 0, 1, 0]), [0.0, 0, 0, 1]
    )


def test_quaternion_conjugate_inverse_normalize_nonunit():
    q = np.array([[2.0, -1.0, 0.5, 3.0], [0.0, 0.0, 0.0, -4.0]])
    qi = quaternion.inverse(q)
    np.testing.assert_allclose(quaternion.multiply(q, qi), [[1.0, 0, 0, 0]] * 2, atol=1e-15)
    np.testing.assert_allclose(quaternion.multiply(qi, q), [[1.0, 0, 0, 0]] * 2, atol=1e-15)
    np.testing.assert_array_equal(quaternion.conjugate(q)[0], [2.0, 1.0, -0.5, -3.0])
    n = quaternion.normalize(q)
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_allclose(quaternion.norm(q), np.linalg.norm(q, axis=-1))
    q_before = q.copy()
    quaternion.canonicalize(q)
    np.testing.assert_array_equal(q, q_before)  # inputs never mutated


def test_quaternion_canonicalize():
    q = np.array(
        [[-0.5, 0.5, 0.5, 0.5], [0.0, -0.6, 0.8, 0.0], [0.0, 0.0, -1.0, 0.0], [0.5, -0.5, 0.5, 0.5]]
    )
    c = quaternion.canonicalize(q)
    np.testing.assert_array_equal(
        c, [[0.5, -0.5, -0.5, -0.5], [0.0, 0.6, -0.8, 0.0], [0.0, 0.0, 1.0, 0.0], q[3]]
    )
    np.testing.assert_allclose(
        c, Rot.from_quat(q, scalar_first=True).as_quat(canonical=True, scalar_first=True)
    )
    cs = quaternion.canonicalize(np.roll(q, -1, axis=-1), scalar_first=False)
    np.testing.assert_array_equal(cs, np.roll(c, -1, axis=-1))


@pytest.mark.parametrize("scalar_first", [True, False])
def test_quaternion_rotvec_vs_scipy(scalar_first):
    rng = _rng(2)
    tv = np.concatenate(
        (
            Rot.random(100, random_state=8).as_rotvec(),
            np.pi * np.eye(3),
            [[1e-12, -2e-12, 0.0], [0.0, 0.0, 0.0], [1e-7, 0.0, 0.0]],
            rng.normal(size=(5, 3)) * 1e-4,
        )
    )
    q = quaternion.from_rotvec(tv, scalar_first=scalar_first)
    np.testing.assert_allclose(
        q, Rot.from_rotvec(tv).as_quat(scalar_first=scalar_first), rtol=1e-14, atol=2e-16
    )
    np.testing.assert_allclose(
        quaternion.to_rotvec(q, scalar_first=scalar_first), tv, rtol=1e-13, atol=1e-20
    )
    # the negated quaternion gives the same (shortest) rotation vector
    np.testing.assert_allclose(
        quaternion.to_rotvec(-q[:100], scalar_first=scalar_first), tv[:100], atol=1e-14
    )


def test_quaternion_rotate_vs_scipy():
    r = Rot.random(30, random_state=9)
    v = _rng(3).normal(size=(30, 3))
    np.testing.assert_allclose(
        quaternion.rotate(r.as_quat(), v, scalar_first=False), r.apply(v), atol=1e-14
    )


def test_quaternion_error_and_slerp():
    r, rd = Rot.random(15, random_state=10), Rot.random(15, random_state=11)
    q, qd = r.as_quat(scalar_first=True), rd.as_quat(scalar_first=True)
    np.testing.assert_allclose(
        quaternion.to_matrix(quaternion.error(q, qd)),
        np.swapaxes(rd.as_matrix(), -1, -2) @ r.as_matrix(),
        atol=2e-15,
    )
    for s in (0.0, 0.25, 0.8, 1.0):
        np.testing.assert_allclose(
            quaternion.to_matrix(quaternion.slerp(qd, q, s)),
            so3.interpolate(rd.as_matrix(), r.as_matrix(), s),
            atol=1e-14,
        )
    # identical end points and a batch of t
    t = np.linspace(0, 1, 5)
    out = quaternion.slerp(q[0], q[0], t)
    assert out.shape == (5, 4)
    np.testing.assert_allclose(out, np.broadcast_to(q[0], (5, 4)), atol=1e-15)
    # the shorter arc is taken even when q1 is given with the other sign
    np.testing.assert_allclose(
        quaternion.to_matrix(quaternion.slerp(qd, -q, 0.5)),
        so3.interpolate(rd.as_matrix(), r.as_matrix(), 0.5),
        atol=1e-14,
    )


@pytest.mark.parametrize("scalar_first", [True, False])
def test_quaternion_kinematics_vs_finite_differences(scalar_first):
    def chart(R):
        return quaternion.from_matrix(R, scalar_first=scalar_first)

    q, qdot_fd = central_diff(chart, T_GRID)
    w_idx = 0 if scalar_first else 3
    ok = np.abs(q[..., w_idx]) > 0.05  # canonical sign is continuous away from w = 0
    assert ok.sum() > 20
    omega = traj_omega(T_GRID)
    qdot = quaternion.kinematics(q, omega, scalar_first=scalar_first)
    np.testing.assert_allclose(qdot[ok], qdot_fd[ok], atol=1e-8)
    Xi = quaternion.kinematics_matrix(q, scalar_first=scalar_first)
    np.testing.assert_allclose(np.einsum("...ij,...j->...i", Xi, omega), qdot, atol=1e-15)
    # ½Ξᵀ·½Ξ = ¼|q|² I and Ξᵀ q = 0
    np.testing.assert_allclose(
        np.swapaxes(Xi, -1, -2) @ Xi,
        np.broadcast_to(np.eye(3) / 4, Xi.shape[:-2] + (3, 3)),
        atol=1e-15,
    )
    np.testing.assert_allclose(np.einsum("...ij,...i->...j", Xi, q), 0.0, atol=1e-15)


@pytest.mark.parametrize(
    ("func", "args", "name"),
    [
        (quaternion.to_matrix, ([0.0, 0.0, 0.0, 0.0],), "q"),
        (quaternion.to_matrix, ([1.0, np.nan, 0.0, 0.0],), "q"),
        (quaternion.to_matrix, ([1.0, 0.0, np.inf, 0.0],), "q"),
        (quaternion.to_matrix, ([1.0, 0.0, 0.0],), "q"),
        (quaternion.to_matrix, ([1.1, 0.0, 0.0, 0.0],), "q"),
        (quaternion.normalize, ([0.0, 0.0, 0.0, 0.0],), "q"),
        (quaternion.inverse, ([[1.0, 0, 0, 0], [0.0, 0, 0, 0]],), "q"),
        (quaternion.multiply, ([1.0, 0, 0, 0], [0.0, 0, 0, 0]), "q"),
        (quaternion.multiply, ([0.0, 0, 0, 0], [1.0, 0, 0, 0]), "p"),
        (quaternion.kinematics, ([1.0, 0, 0, 0], [1.0, 2.0]), "omega"),
        (quaternion.error, ([1.0, 0, 0, 0], [2.0, 0, 0, 0]), "q_d"),
        (quaternion.slerp, ([1.0, 0, 0, 0], [1.0, 0, 0, 0], np.nan), "t"),
        (quaternion.from_rotvec, ([1.0, 2.0, 3.0, 4.0],), "theta"),
        (quaternion.from_matrix, (np.ones((3, 3)),), "R"),
        (quaternion.from_matrix, (np.diag([1.0, 1.0, -1.0]),), "R"),
        (quaternion.rotate, ([1.0, 0, 0, 0], "abc"), "v"),
    ],
)
def test_quaternion_bad_input(func, args, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        func(*args)


# --------------------------------------------------------------------------- MRP


def test_mrp_vs_scipy():
    r = Rot.random(200, random_state=12)
    R = np.concatenate((r.as_matrix(), _half_turns(10, _rng(4))))
    p = mrp.from_matrix(R)
    assert np.all(np.linalg.norm(p, axis=-1) <= 1.0 + 1e-15)
    np.testing.assert_allclose(p[:200], r.as_mrp(), atol=2e-15)
    np.testing.assert_allclose(mrp.to_matrix(p), R, atol=2e-15)
    big = _rng(5).normal(size=(20, 3)) * 3.0  # includes |p| > 1 (the shadow side)
    np.testing.assert_allclose(mrp.to_matrix(big), Rot.from_mrp(big).as_matrix(), atol=1e-14)


def test_mrp_quaternion_maps():
    q = Rot.random(50, random_state=13).as_quat(scalar_first=True)
    p = mrp.from_quaternion(q)
    np.testing.assert_allclose(p, mrp.from_quaternion(-q), atol=1e-15)
    assert np.all(np.linalg.norm(p, axis=-1) <= 1.0 + 1e-15)
    qq = mrp.to_quaternion(p)
    np.testing.assert_allclose(qq, quaternion.canonicalize(q), atol=1e-15)
    np.testing.assert_allclose(
        mrp.to_quaternion(p, scalar_first=False), np.roll(qq, -1, axis=-1), atol=1e-15
    )
    np.testing.assert_allclose(
        mrp.from_quaternion(np.roll(q, -1, axis=-1), scalar_first=False), p, atol=1e-15
    )
    # the quaternion of the shadow is −q
    np.testing.assert_allclose(mrp.to_quaternion(mrp.shadow(p[:10])), -qq[:10], atol=1e-14)


def test_mrp_shadow_and_switch_keep_rotation():
    rng = _rng(6)
    p = rng.normal(size=(2, 7, 3)) * 1.2
    ps = mrp.shadow(p)
    np.testing.assert_allclose(mrp.to_matrix(ps), mrp.to_matrix(p), atol=1e-14)
    np.testing.assert_allclose(
        np.linalg.norm(ps, axis=-1) * np.linalg.norm(p, axis=-1), 1.0, rtol=1e-14
    )
    sw, mask = mrp.switch(p)
    assert mask.shape == (2, 7)
    np.testing.assert_array_equal(mask, np.linalg.norm(p, axis=-1) > 1.0)
    assert np.all(np.linalg.norm(sw, axis=-1) <= 1.0)
    np.testing.assert_allclose(mrp.to_matrix(sw), mrp.to_matrix(p), atol=1e-14)
    np.testing.assert_array_equal(sw[~mask], p[~mask])
    # hysteresis threshold and the zero MRP (never switched, no NaN)
    sw2, mask2 = mrp.switch(np.array([[0.0, 0.0, 0.0], [1.1, 0.0, 0.0], [0.0, 1.3, 0.0]]), 1.2)
    np.testing.assert_array_equal(mask2, [False, False, True])
    np.testing.assert_allclose(sw2, [[0.0, 0.0, 0.0], [1.1, 0.0, 0.0], [0.0, -1 / 1.3, 0.0]])


def test_mrp_kinematics_matrix_formula_and_inverse():
    p = _rng(7).normal(size=(25, 3)) * 0.8
    s2 = np.sum(p * p, axis=-1)[:, None, None]
    B = (1 - s2) * np.eye(3) + 2 * so3.hat(p) + 2 * p[:, :, None] * p[:, None, :]  # Schaub
    G = mrp.kinematics_matrix(p)
    np.testing.assert_allclose(G, B / 4.0, atol=1e-15)
    np.testing.assert_allclose(
        G @ mrp.kinematics_matrix_inv(p), np.broadcast_to(np.eye(3), G.shape), atol=1e-14
    )
    np.testing.assert_allclose(mrp.kinematics_matrix_inv(p), np.linalg.inv(G), atol=1e-12)


def test_mrp_kinematics_vs_finite_differences():
    p, pdot_fd = central_diff(mrp.from_matrix, T_GRID)
    ok = np.linalg.norm(p, axis=-1) < 0.95  # away from the |p| = 1 switch
    assert ok.sum() > 20
    pdot = mrp.kinematics(p, traj_omega(T_GRID))
    np.testing.assert_allclose(pdot[ok], pdot_fd[ok], atol=1e-8)


def test_mrp_compose_relative():
    r1, r2 = Rot.random(20, random_state=14), Rot.random(20, random_state=15)
    p1, p2 = r1.as_mrp(), r2.as_mrp()
    c = mrp.compose(p1, p2)
    np.testing.assert_allclose(mrp.to_matrix(c), r1.as_matrix() @ r2.as_matrix(), atol=1e-14)
    np.testing.assert_allclose(c, (r1 * r2).as_mrp(), atol=1e-14)
    e = mrp.relative(p1, p2)
    np.testing.assert_allclose(
        mrp.to_matrix(e), np.swapaxes(r2.as_matrix(), -1, -2) @ r1.as_matrix(), atol=1e-14
    )
    assert np.all(np.linalg.norm(e, axis=-1) <= 1.0 + 1e-15)


@pytest.mark.parametrize(
    ("func", "args", "name"),
    [
        (mrp.shadow, ([[0.1, 0.0, 0.0], [0.0, 0.0, 0.0]],), "p"),
        (mrp.switch, ([0.5, 0.0, 0.0], 0.9), "threshold"),
        (mrp.to_matrix, ([np.nan, 0.0, 0.0],), "p"),
        (mrp.to_matrix, ([0.1, 0.2],), "p"),
        (mrp.kinematics, ([0.1, 0.2, 0.3], [[1.0, 2.0]]), "omega"),
        (mrp.from_quaternion, ([0.0, 0.0, 0.0, 0.0],), "q"),
        (mrp.from_matrix, (np.eye(3) * 2,), "R"),
        (mrp.compose, ([0.1, 0.2, 0.3], [0.1, 0.2, np.inf]), "p2"),
        (mrp.relative, ([0.1, 0.2, 0.3], [0.1, 0.2]), "p_d"),
    ],
)
def test_mrp_bad_input(func, args, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        func(*args)


# --------------------------------------------------------------------------- Euler


@pytest.mark.parametrize("seq", euler.SEQUENCES)
def test_euler_roundtrip_vs_scipy(seq):
    r = Rot.random(100, random_state=16)
    R = r.as_matrix()
    a = euler.from_matrix(R, seq)
    np.testing.assert_allclose(_wrap(a - r.as_euler(seq)), 0.0, atol=1e-13)
    np.testing.assert_allclose(euler.to_matrix(a, seq), R, atol=2e-15)
    ang = _rng(8).uniform(-4.0, 4.0, size=(50, 3))
    np.testing.assert_allclose(
        euler.to_matrix(ang, seq), Rot.from_euler(seq, ang).as_matrix(), atol=2e-15
    )


@pytest.mark.parametrize("seq", euler.SEQUENCES)
def test_euler_gimbal_lock_from_matrix(seq):
    rng = _rng(9)
    ang = rng.uniform(-3.0, 3.0, size=(12, 3))
    lock_vals = (np.pi / 2, -np.pi / 2) if euler.is_tait_bryan(seq) else (0.0, np.pi)
    ang[:, 1] = np.resize(lock_vals, 12)
    R = euler.to_matrix(ang, seq)
    with pytest.warns(euler.GimbalLockWarning):
        a = euler.from_matrix(R, seq)
    assert np.all(np.isfinite(a))
    np.testing.assert_array_equal(a[:, 2], 0.0)  # documented choice: third angle 0
    np.testing.assert_allclose(euler.to_matrix(a, seq), R, atol=1e-15 * 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = Rot.from_matrix(R).as_euler(seq)
    np.testing.assert_allclose(_wrap(a - ref), 0.0, atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        euler.from_matrix(R, seq, warn=False)


@pytest.mark.parametrize("seq", ["ZYX", "xyz", "ZXZ", "yzy"])
@pytest.mark.parametrize("offset", [1e-5, 1e-8, 1e-10, 1e-12])
def test_euler_near_lock_accurate(seq, offset):
    """Near (not at) lock the residual a3 keeps R reproduced to round-off."""
    ang = _rng(10).uniform(-3.0, 3.0, size=(20, 3))
    base = np.pi / 2 if euler.is_tait_bryan(seq) else 0.0
    ang[:, 1] = base - offset if base else offset
    R = euler.to_matrix(ang, seq)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", euler.GimbalLockWarning)
        a = euler.from_matrix(R, seq)
    np.testing.assert_allclose(euler.to_matrix(a, seq), R, atol=1e-14 if offset > 1e-11 else 5e-12)


@pytest.mark.parametrize("seq", euler.SEQUENCES)
def test_euler_rates_vs_finite_differences(seq):
    a, adot_fd = central_diff(lambda R: euler.from_matrix(R, seq), T_GRID)
    ok = ~euler.near_gimbal_lock(a, seq, tol=0.15)
    ok &= np.all(np.abs(_wrap(a[..., [0, 2]])) < np.pi - 0.05, axis=-1)  # no ±π wrap in the FD
    assert ok.sum() > 15
    omega = traj_omega(T_GRID[ok])
    np.testing.assert_allclose(euler.kinematics(a[ok], omega, seq), adot_fd[ok], atol=2e-8)
    B = euler.rates_matrix(a[ok], seq)
    M = euler.rates_matrix_inv(a[ok], seq)
    np.testing.assert_allclose(B @ M, np.broadcast_to(np.eye(3), B.shape), atol=1e-13)
    np.testing.assert_allclose(np.einsum("...ij,...j->...i", M, adot_fd[ok]), omega, atol=2e-8)


def test_euler_zyx_closed_form():
    """Schaub & Junkins eq. (3.57), the 3-2-1 kinematic differential equation."""
    a = _rng(11).uniform(-1.2, 1.2, size=(10, 3))
    _, a2, a3 = a.T
    c2, s2, c3, s3 = np.cos(a2), np.sin(a2), np.cos(a3), np.sin(a3)
    z = np.zeros_like(a2)
    ref = (
        np.stack(
            (
                np.stack((z, s3, c3), -1),
                np.stack((z, c3 * c2, -s3 * c2), -1),
                np.stack((c2, s3 * s2, c3 * s2), -1),
            ),
            -2,
        )
        / c2[:, None, None]
    )
    np.testing.assert_allclose(euler.rates_matrix(a, "ZYX"), ref, atol=1e-14)


@pytest.mark.parametrize("seq", euler.SEQUENCES)
def test_euler_gimbal_lock_raises_never_nan(seq):
    lock = np.pi / 2 if euler.is_tait_bryan(seq) else np.pi
    angles = np.array([[0.3, 0.1, -0.2], [0.3, lock, -0.2]])
    assert euler.near_gimbal_lock(angles, seq).tolist() == [False, True]
    with pytest.raises(ChartSingularityError, match="^angles: gimbal lock"):
        euler.rates_matrix(angles, seq)
    with pytest.raises(ChartSingularityError):
        euler.kinematics(angles, [0.1, 0.2, 0.3], seq)
    # just outside the tolerance: finite; M is defined everywhere
    near = angles.copy()
    near[1, 1] = lock - 2e-6
    assert np.all(np.isfinite(euler.kinematics(near, [0.1, 0.2, 0.3], seq)))
    assert np.all(np.isfinite(euler.rates_matrix_inv(angles, seq)))
    with pytest.raises(ChartSingularityError):
        euler.rates_matrix(near, seq, lock_tol=1e-5)


def test_chart_singularity_error_is_value_error():
    assert ChartSingularityError is ExcChartSingularityError
    assert issubclass(ChartSingularityError, ValueError)


@pytest.mark.parametrize("seq", ["ZYx", "XXY", "XYY", "ABC", "XY", "xyzx", 123, "", None, "zÿx"])
def test_euler_bad_seq(seq):
    with pytest.raises(ValueError, match="^seq:"):
        euler.to_matrix([0.1, 0.2, 0.3], seq)
    with pytest.raises(ValueError, match="^seq:"):
        euler.from_matrix(np.eye(3), seq)
    with pytest.raises(ValueError, match="^seq:"):
        euler.rates_matrix([0.1, 0.2, 0.3], seq)


@pytest.mark.parametrize(
    ("func", "args", "name"),
    [
        (euler.to_matrix, ([0.1, 0.2], "ZYX"), "angles"),
        (euler.to_matrix, ([0.1, np.nan, 0.3], "ZYX"), "angles"),
        (euler.from_matrix, (np.zeros((3, 3)), "ZYX"), "R"),
        (euler.from_matrix, (np.eye(4), "ZYX"), "R"),
        (euler.kinematics, ([0.1, 0.2, 0.3], [np.inf, 0, 0], "ZYX"), "omega"),
        (euler.near_gimbal_lock, (np.zeros((2, 4)), "ZYX"), "angles"),
    ],
)
def test_euler_bad_input(func, args, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        func(*args)


# --------------------------------------------------------------------------- rotation vector


def test_rotvec_vs_scipy_and_wrap():
    r = Rot.random(100, random_state=17)
    R = np.concatenate((r.as_matrix(), _half_turns(5, _rng(12))))
    th = rotvec.from_matrix(R)
    np.testing.assert_allclose(th[:100], r.as_rotvec(), atol=1e-14)
    np.testing.assert_allclose(rotvec.to_matrix(th), R, atol=1e-14)
    big = _rng(13).normal(size=(30, 3)) * 4.0
    w = rotvec.wrap(big)
    assert np.all(np.linalg.norm(w, axis=-1) <= np.pi + 1e-12)
    np.testing.assert_allclose(rotvec.to_matrix(w), rotvec.to_matrix(big), atol=1e-13)
    small = big[np.linalg.norm(big, axis=-1) <= np.pi]
    np.testing.assert_array_equal(rotvec.wrap(small), small)
    np.testing.assert_array_equal(rotvec.wrap(np.zeros(3)), np.zeros(3))


def test_rotvec_kinematics_vs_finite_differences():
    th, thdot_fd = central_diff(rotvec.from_matrix, T_GRID)
    ok = np.linalg.norm(th, axis=-1) < np.pi - 0.05
    assert ok.sum() > 20
    thdot = rotvec.kinematics(th, traj_omega(T_GRID))
    np.testing.assert_allclose(thdot[ok], thdot_fd[ok], atol=1e-8)
    np.testing.assert_allclose(
        rotvec.kinematics_matrix(th) @ rotvec.kinematics_matrix_inv(th),
        np.broadcast_to(np.eye(3), th.shape + (3,)),
        atol=1e-12,
    )


def test_rotvec_kinematics_smooth_across_pi():
    """Near |θ| = π the principal value jumps; along the continued branch (|θ| > π allowed) the
    kinematics still match central differences, and J_r⁻¹ is finite at |θ| = π exactly."""

    def continued(R, ref):
        th = rotvec.from_matrix(R)
        n = np.linalg.norm(th, axis=-1, keepdims=True)
        alt = th * (1.0 - 2.0 * np.pi / n)  # the other representative, |alt| = 2π − |θ|
        pick = np.linalg.norm(alt - ref, axis=-1) < np.linalg.norm(th - ref, axis=-1)
        return np.where(pick[..., None], alt, th)

    # R(t) = H exp(t b) with H a half-turn about n and ω = b constant: |θ| crosses π at t = 0
    n_axis = np.array([0.0, 0.6, 0.8])
    b = 0.5 * n_axis + np.array([0.7, 0.24, -0.18])
    H = so3.exp(np.pi * n_axis)
    for t0 in (0.0, 1e-3, -2e-3):
        th0 = continued(H @ so3.exp(t0 * b), np.pi * n_axis)
        fd = (
            continued(H @ so3.exp((t0 + DT) * b), th0) - continued(H @ so3.exp((t0 - DT) * b), th0)
        ) / (2 * DT)
        np.testing.assert_allclose(rotvec.kinematics(th0, b), fd, atol=1e-8)
    # across the crossing the continued θ leaves the ball; wrap brings it back, same rotation
    th_out = continued(H @ so3.exp(0.05 * b), np.pi * n_axis)
    assert np.linalg.norm(th_out) > np.pi
    np.testing.assert_allclose(
        rotvec.to_matrix(rotvec.wrap(th_out)), H @ so3.exp(0.05 * b), atol=1e-14
    )
    J = rotvec.kinematics_matrix(np.pi * np.array([0.0, 0.6, 0.8]))
    assert np.all(np.isfinite(J))


def test_rotvec_singular_at_two_pi():
    axis = np.array([0.0, 0.6, 0.8])
    with pytest.raises(ChartSingularityError, match="^theta:"):
        rotvec.kinematics(2 * np.pi * axis, [0.1, 0.0, 0.0])
    out = rotvec.kinematics(1.5 * np.pi * axis, [0.1, 0.0, 0.0])
    assert np.all(np.isfinite(out))
    with pytest.raises(ValueError, match="^theta:"):
        rotvec.to_matrix([0.1, 0.2])
    with pytest.raises(ValueError, match="^R:"):
        rotvec.from_matrix(np.full((3, 3), np.nan))


# --------------------------------------------------------------------------- batch shapes


@pytest.mark.parametrize("shape", [(), (5,), (2, 3)])
def test_batch_shapes(shape):
    rng = _rng(14)
    R = so3.random(rng, shape)
    w = rng.normal(size=shape + (3,))
    q = quaternion.from_matrix(R)
    assert q.shape == shape + (4,)
    assert quaternion.to_matrix(q).shape == shape + (3, 3)
    assert quaternion.kinematics(q, w).shape == shape + (4,)
    assert quaternion.kinematics_matrix(q).shape == shape + (4, 3)
    assert quaternion.to_rotvec(q).shape == shape + (3,)
    assert quaternion.rotate(q, w).shape == shape + (3,)
    assert quaternion.slerp(q, q, 0.5).shape == shape + (4,)
    p = mrp.from_matrix(R)
    assert p.shape == shape + (3,)
    assert mrp.kinematics(p, w).shape == shape + (3,)
    assert mrp.switch(p)[1].shape == shape
    assert mrp.kinematics_matrix_inv(p).shape == shape + (3, 3)
    for seq in ("ZYX", "zxz"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", euler.GimbalLockWarning)
            a = euler.from_matrix(R, seq)
        assert a.shape == shape + (3,)
        assert euler.to_matrix(a, seq).shape == shape + (3, 3)
        assert euler.rates_matrix_inv(a, seq).shape == shape + (3, 3)
        assert euler.near_gimbal_lock(a, seq).shape == shape
        if not np.any(euler.near_gimbal_lock(a, seq)):
            assert euler.kinematics(a, w, seq).shape == shape + (3,)
    th = rotvec.from_matrix(R)
    assert th.shape == shape + (3,)
    assert rotvec.kinematics(th, w).shape == shape + (3,)
    # a single element broadcast against the batch
    assert quaternion.multiply(q, [1.0, 0.0, 0.0, 0.0]).shape == shape + (4,)
    assert mrp.compose(p, np.zeros(3)).shape == shape + (3,)


def test_inputs_not_mutated():
    R = so3.random(_rng(15), (4,))
    R0 = R.copy()
    q = quaternion.from_matrix(R, scalar_first=False)
    q0 = q.copy()
    p = mrp.from_matrix(R)
    p0 = p.copy()
    a = euler.from_matrix(R, "xyz")
    a0 = a.copy()
    w = np.ones((4, 3))
    quaternion.kinematics(q, w, scalar_first=False)
    quaternion.conjugate(q, scalar_first=False)
    mrp.switch(p * 3)
    mrp.shadow(p)
    euler.kinematics(a, w, "xyz")
    rotvec.wrap(p * 10)
    for x, x0 in ((R, R0), (q, q0), (p, p0), (a, a0)):
        np.testing.assert_array_equal(x, x0)


# --------------------------------------------------------------------------- hypothesis

_coord = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
_quat = st.tuples(_coord, _coord, _coord, _coord).filter(lambda v: sum(c * c for c in v) > 1e-4)


@settings(max_examples=60, deadline=None)
@given(_quat, st.booleans())
def test_hyp_quaternion_roundtrip(v, scalar_first):
    q = quaternion.normalize(np.array(v), scalar_first=scalar_first)
    R = quaternion.to_matrix(q, scalar_first=scalar_first)
    q2 = quaternion.from_matrix(R, scalar_first=scalar_first)
    # q2 is canonical and equals ±q (the sign of q near w = 0 is not decidable from R)
    np.testing.assert_array_equal(q2, quaternion.canonicalize(q2, scalar_first=scalar_first))
    assert min(np.abs(q2 - q).max(), np.abs(q2 + q).max()) < 1e-14
    np.testing.assert_allclose(
        R, Rot.from_quat(q, scalar_first=scalar_first).as_matrix(), atol=1e-14
    )
    tv = quaternion.to_rotvec(q, scalar_first=scalar_first)
    assert np.linalg.norm(tv) <= np.pi + 1e-12
    np.testing.assert_allclose(so3.exp(tv), R, atol=1e-14)


@settings(max_examples=60, deadline=None)
@given(_quat, _quat)
def test_hyp_quaternion_product_identities(u, v):
    p, q = quaternion.normalize(np.array(u)), quaternion.normalize(np.array(v))
    pq = quaternion.multiply(p, q)
    np.testing.assert_allclose(
        quaternion.conjugate(pq),
        quaternion.multiply(quaternion.conjugate(q), quaternion.conjugate(p)),
        atol=1e-15,
    )
    np.testing.assert_allclose(np.linalg.norm(pq), 1.0, atol=1e-15)
    np.testing.assert_allclose(
        quaternion.to_matrix(pq), quaternion.to_matrix(p) @ quaternion.to_matrix(q), atol=1e-14
    )


@settings(max_examples=60, deadline=None)
@given(st.tuples(_coord, _coord, _coord).map(lambda v: np.array(v) * 3.0))
def test_hyp_mrp_roundtrip(p):
    R = mrp.to_matrix(p)
    p2 = mrp.from_matrix(R)
    assert np.linalg.norm(p2) <= 1.0 + 1e-15
    np.testing.assert_allclose(mrp.to_matrix(p2), R, atol=1e-14)
    n = np.linalg.norm(p)
    if 1e-3 < n < 0.999:
        np.testing.assert_allclose(p2, p, atol=1e-13)
    elif n > 1.001:
        np.testing.assert_allclose(p2, mrp.shadow(p), atol=1e-13)


@settings(max_examples=80, deadline=None)
@given(
    st.sampled_from(euler.SEQUENCES),
    st.tuples(st.floats(-np.pi, np.pi), st.floats(0.0, 1.0), st.floats(-np.pi, np.pi)),
)
def test_hyp_euler_roundtrip(seq, raw):
    a1, u, a3 = raw
    lo, hi = (-np.pi / 2, np.pi / 2) if euler.is_tait_bryan(seq) else (0.0, np.pi)
    a = np.array([a1, lo + u * (hi - lo), a3])
    R = euler.to_matrix(a, seq)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", euler.GimbalLockWarning)
        a2 = euler.from_matrix(R, seq)
    # inside from_matrix's lock band (|cos a2| < 1e-12) the error is ≤ π·1e-12
    np.testing.assert_allclose(euler.to_matrix(a2, seq), R, atol=5e-12)
    if not euler.near_gimbal_lock(a, seq, tol=1e-3):
        np.testing.assert_allclose(_wrap(a2 - a), 0.0, atol=1e-9)
