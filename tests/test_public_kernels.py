"""``liecontrol.kernels``: the public compiled kernels are the library's own (one implementation)
and equal the batched NumPy layer — rotations near 0, π/2 (exp's polynomial switch) and π
(log's symmetric-part branch), the error functions on both sides of the algebraic route's
switch at π/2, the desired rates, the feed-forward and the whole geometric PD against
``GeometricPD.command``."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import liecontrol.kernels as lk
from liecontrol import errors
from liecontrol.control import AttitudeReference, AttitudeState, GeometricPD
from liecontrol.lie import so3


def _rotations(rng, angles):
    axes = rng.normal(size=(len(angles), 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return axes * np.asarray(angles)[:, None]


ANGLES = np.concatenate(
    [
        [0.0, 1e-12, 1e-8, 1e-4, 1e-3 * (1 - 1e-9), 1e-3, 1e-3 * (1 + 1e-9)],
        np.pi / 2 + np.linspace(-1e-6, 1e-6, 9),
        np.pi - np.logspace(-12, -1, 12),
        [np.pi],
        np.linspace(0.0, np.pi, 61),
    ]
)


def test_every_public_kernel_is_the_librarys_own():
    for name in lk.__all__:
        fn = getattr(lk, name)
        owner = importlib.import_module(fn.__module__ if hasattr(fn, "__module__") else "")
        assert getattr(owner, name) is fn, name
        assert owner.__name__.startswith("liecontrol._kernels"), name


def test_exp_and_log_equal_the_numpy_layer_near_0_half_pi_and_pi():
    rng = np.random.default_rng(11)
    w = _rotations(rng, ANGLES)
    R = so3.exp(w)
    for k in range(len(w)):
        E = np.array(lk.exp9(*w[k])).reshape(3, 3)
        np.testing.assert_allclose(E, R[k], rtol=0, atol=2e-15)  # a few ulp of 1
        out = np.empty((3, 3))
        lk.exp_into(*w[k], out)
        np.testing.assert_array_equal(out, E)
        v = np.array(lk.log_of(np.ascontiguousarray(R[k])))
        ref = so3.log(R[k])
        # at π the rotation vector's sign is either: compare the rotations they give
        np.testing.assert_allclose(so3.exp(v), so3.exp(ref), rtol=0, atol=1e-14)
        assert np.linalg.norm(v) <= np.pi + 1e-15
        np.testing.assert_array_equal(v, np.array(lk.log9(*R[k].ravel())))
        Rm = np.empty((3, 3))
        lk.right_multiply_exp_into(np.ascontiguousarray(R[k]), 0.1, -0.2, 0.05, Rm)
        np.testing.assert_allclose(Rm, R[k] @ so3.exp(np.array([0.1, -0.2, 0.05])), atol=1e-15)


@pytest.mark.parametrize("kind", ["large_angle", "log"])
def test_error_functions_equal_the_numpy_layer_on_both_sides_of_the_switch(kind):
    rng = np.random.default_rng(12)
    R_d = so3.random(rng, (len(ANGLES),))
    R = R_d @ so3.exp(_rotations(rng, ANGLES))
    psi_ref, e_ref = (errors.large_angle_error if kind == "large_angle" else errors.log_error)(
        R, R_d
    )
    for k in range(len(ANGLES)):
        T = lk.body_from_desired(np.ascontiguousarray(R[k]), np.ascontiguousarray(R_d[k]))
        np.testing.assert_allclose(np.array(T).reshape(3, 3), R[k].T @ R_d[k], atol=1e-15)
        if kind == "large_angle":
            psi, e0, e1, e2 = lk.large_angle_error_algebraic(T)
            p2, th, f0, f1, f2 = lk.large_angle_error(T)
            np.testing.assert_allclose([p2, f0, f1, f2], [psi, e0, e1, e2], rtol=1e-12, atol=1e-15)
            assert 0.0 <= th <= np.pi + 1e-15
        else:
            e0, e1, e2 = lk.error_log(T)
            psi = 0.5 * (e0 * e0 + e1 * e1 + e2 * e2)
        np.testing.assert_allclose(psi, psi_ref[k], rtol=1e-12, atol=1e-15)
        if ANGLES[k] < np.pi - 1e-6:  # at π the log's sign is either
            np.testing.assert_allclose([e0, e1, e2], e_ref[k], rtol=1e-12, atol=1e-15)


def test_half_sinc_on_both_sides_of_its_series_switch():
    for th in [0.0, 1e-8, 1e-3 * (1 - 1e-12), 1e-3, 1e-3 * (1 + 1e-12), 0.5, np.pi]:
        ref = 0.5 if th == 0.0 else np.sin(th / 2) / th
        assert lk.half_sinc(th) == pytest.approx(ref, rel=1e-15, abs=0)


def test_rates_feedforward_matvec_and_dexpinv_against_direct_formulas():
    rng = np.random.default_rng(13)
    J = np.array([[900.0, 10.0, -5.0], [10.0, 800.0, 3.0], [-5.0, 3.0, 600.0]])
    for _ in range(50):
        R, R_d = so3.random(rng), so3.random(rng)
        w, w_d, dw_d, v = (rng.normal(size=3) for _ in range(4))
        T = lk.body_from_desired(R, R_d)
        wb = R.T @ R_d @ w_d
        db = R.T @ R_d @ dw_d
        got = np.array(lk.desired_rates_in_body(T, w_d, dw_d))
        np.testing.assert_allclose(got, np.concatenate([wb, db]), atol=1e-14)
        ff = np.array(lk.tracking_feedforward(J, *w, *v, *wb, *db))
        np.testing.assert_allclose(
            ff, np.cross(v, J @ w) - J @ (np.cross(w, wb) - db), rtol=1e-13, atol=1e-10
        )
        np.testing.assert_allclose(np.array(lk.matvec3(J, *w)), J @ w, rtol=1e-15)
        th = 0.3 * rng.normal(size=3)
        ref = w + 0.5 * np.cross(th, w) + np.cross(th, np.cross(th, w)) / 12.0
        np.testing.assert_allclose(np.array(lk.dexpinv_rkmk4(*th, *w)), ref, atol=1e-15)


@pytest.mark.parametrize("error", ["large_angle", "log", "trace"])
def test_geometric_pd_one_is_the_built_in_law(error):
    rng = np.random.default_rng(14)
    J = np.diag([1200.0, 1000.0, 800.0])
    K_R, K_W = 40.0 * np.eye(3), np.diag([300.0, 250.0, 200.0])
    ctrl = GeometricPD(J, K_R, K_W, error=error)
    # the law's own parameters (error code, J, K_R, K_Ω, G) as its kernel receives them
    p = ctrl.fused_kernel(1).params
    code = int(p[0])
    assert code == {"large_angle": 0, "log": 1, "trace": 2}[error]
    G = np.ascontiguousarray(p[28:37].reshape(3, 3))
    B = 16
    R, R_d = so3.random(rng, (B,)), so3.random(rng, (B,))
    w, w_d, dw_d = (0.05 * rng.normal(size=(B, 3)) for _ in range(3))
    ctrl.reset(0.0, B)
    u_ref = ctrl.command(0.0, AttitudeState(R, w), AttitudeReference(R_d, w_d, dw_d))
    for b in range(B):
        M, d = np.empty(3), np.empty(7)
        lk.geometric_pd_one(code, J, K_R, K_W, G, R[b], w[b], R_d[b], w_d[b], dw_d[b], M, d)
        np.testing.assert_allclose(M, u_ref[b], rtol=1e-12, atol=1e-12)
