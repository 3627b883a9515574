"""The compiled estimation kernels and the fused UKF pass on the gyroless model equal the
numpy route (the model's batched ``rhs``/RK4 and Euler formulas, numpy linear algebra)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_triangular

from liecontrol.charts import quaternion as quat
from liecontrol.estimation import STUKF, UKF, GyrolessAttitudeModel
from liecontrol.estimation import _kernels as K
from liecontrol.estimation.cholesky import NotPositiveDefiniteError, solve_lower
from liecontrol.estimation.models import _rk4, _rpy_from_q


class _NumpyModel(GyrolessAttitudeModel):
    """The same model through numpy only (a subclass: the filters do not fuse it)."""

    def f(self, x, u, dt):
        torque = np.asarray(u, dtype=np.float64)
        return self.normalize(_rk4(lambda yy: self.rhs(yy, torque), x, dt))

    def h(self, x):
        return _rpy_from_q(x[..., :4])


def _problem(steps: int = 60):
    J = np.diag([10.0, 12.0, 15.0])
    m_fast, m_ref = GyrolessAttitudeModel(J), _NumpyModel(J)
    rng = np.random.default_rng(0)
    x = np.r_[quat.from_rotvec(np.array([0.4, -0.3, 2.5])), 0.01, -0.02, 0.05]
    us, zs = [], []
    for k in range(steps):
        u = 2e-3 * np.array([np.sin(0.1 * k), np.cos(0.13 * k), 0.3])
        x = m_ref.f(x[None], u, 1.0)[0]
        us.append(u)
        zs.append(m_ref.h(x[None])[0] + rng.normal(0.0, 2e-3, 3))
    x0 = np.r_[quat.from_rotvec(np.array([0.45, -0.25, 2.45])), 0.0, 0.0, 0.04]
    return m_fast, m_ref, x0, us, zs


@pytest.mark.parametrize("cls", [UKF, STUKF])
def test_fused_ukf_equals_numpy_route(cls):
    m_fast, m_ref, x0, us, zs = _problem()
    P0 = np.diag([2.5e-3] * 4 + [4e-4] * 3)
    fast, ref = cls(m_fast, x0, P0), cls(m_ref, x0, P0)
    assert fast._fused and not ref._fused
    for u, z in zip(us, zs, strict=True):
        fast.predict(u, 1.0)
        ref.predict(u, 1.0)
        np.testing.assert_allclose(fast.x, ref.x, rtol=0, atol=1e-12)
        assert fast.update(z) == ref.update(z)
        np.testing.assert_allclose(fast.x, ref.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fast.P, ref.P, rtol=0, atol=1e-12 * np.abs(ref.P).max())
        assert fast.diagnostics["nis"] == pytest.approx(ref.diagnostics["nis"], rel=1e-9)


def test_model_f_and_h_kernels_equal_numpy():
    m_fast, m_ref, *_ = _problem(1)
    rng = np.random.default_rng(1)
    X = rng.standard_normal((15, 7))
    u = np.array([0.01, -0.02, 0.03])
    np.testing.assert_allclose(m_fast.f(X, u, 0.7), m_ref.f(X, u, 0.7), rtol=0, atol=1e-14)
    np.testing.assert_allclose(m_fast.h(X), m_ref.h(X), rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match=r"^x: quaternion part"):
        m_fast.f(np.zeros((3, 7)), u, 0.7)


def test_cholesky_and_triangular_kernels():
    rng = np.random.default_rng(2)
    A = rng.standard_normal((7, 7))
    P = A @ A.T + 0.1 * np.eye(7)
    L, ok = K.cholesky_sym(P)
    assert ok
    np.testing.assert_allclose(L, np.linalg.cholesky(P), rtol=0, atol=1e-13)
    _, ok = K.cholesky_sym(P - 10.0 * np.eye(7))
    assert not ok
    _, ok = K.cholesky_sym(np.full((3, 3), np.nan))
    assert not ok
    B = rng.standard_normal((7, 4))
    for tr in (False, True):
        ref = solve_triangular(L, B, lower=True, trans=1 if tr else 0)
        np.testing.assert_allclose(solve_lower(L, B, transpose=tr), ref, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(solve_lower(L, B[:, 0], transpose=tr), ref[:, 0], rtol=1e-12)
    L0 = L.copy()
    L0[3, 3] = 0.0
    with pytest.raises(NotPositiveDefiniteError, match=r"^L: singular"):
        solve_lower(L0, B)
    assert K.all_finite(P.ravel(), B[:, 0]) and not K.all_finite(P.ravel(), np.r_[np.inf])


def test_fused_route_repairs_like_the_numpy_route():
    """An indefinite covariance (a sign error in one variance) is repaired by the PD policy on
    both routes, with the same result, in predict and in update."""
    m_fast, m_ref, x0, us, zs = _problem(3)
    P0 = np.diag([2.5e-3] * 4 + [4e-4] * 3)
    for where in ("predict", "update"):
        fast, ref = UKF(m_fast, x0, P0), UKF(m_ref, x0, P0)
        if where == "update":
            fast.predict(us[0], 1.0)
            ref.predict(us[0], 1.0)
        bad = fast.P.copy()
        bad[5, 5] = -bad[5, 5]
        fast._P, ref._P = bad.copy(), bad.copy()
        if where == "predict":
            fast.predict(us[0], 1.0)
            ref.predict(us[0], 1.0)
        else:
            fast.update(zs[0])
            ref.update(zs[0])
        assert fast.diagnostics["repaired"] and ref.diagnostics["repaired"]
        np.testing.assert_allclose(fast.x, ref.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fast.P, ref.P, rtol=0, atol=1e-12 * np.abs(ref.P).max())
    strict = UKF(m_fast, x0, P0, pd_policy="raise")
    bad = strict.P.copy()
    bad[5, 5] = -bad[5, 5]
    strict._P = bad
    with pytest.raises(NotPositiveDefiniteError, match=r"^P: "):
        strict.predict(us[0], 1.0)
