"""No silent failure in ``liecontrol`` (issue 12, library side).

One test (or a few) per fault of the issue: each fails on the code before the fix. Every
numerical claim is checked against an independent route (scipy, numpy.linalg, a hand formula).
"""

from __future__ import annotations

import logging
import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from liecontrol._validation import as_array, norm_last
from liecontrol.charts import euler, mrp, quaternion, rotvec
from liecontrol.control import (
    AttitudeReference,
    AttitudeState,
    GeometricPD,
    IntrinsicPID,
    PrescribedPerformance,
    gains_from_bandwidth,
)
from liecontrol.control.mpc import SO3MPC
from liecontrol.estimation import (
    ISTSRUKF,
    MEKF,
    SRUKF,
    STUKF,
    UKF,
    GyrolessAttitudeModel,
    ManifoldUKF,
    NotPositiveDefiniteError,
    euler_rpy_from_quaternion,
    nearest_pd_sqrt,
    numerical_error_transition,
    psd_sqrt,
    sigma_points,
    unscented_transform,
    wrap_angle,
)
from liecontrol.lie import SO3, se3, so3

J = np.diag([10.0, 12.0, 15.0])
X0 = np.r_[quaternion.from_rotvec(np.array([0.05, -0.03, 0.1])), 0.001, -0.002, 0.05]
P0_ADD = np.diag([2.5e-5] * 4 + [4e-6] * 3)
P0_ERR = np.diag([1e-4] * 3 + [4e-6] * 3)
FILTERS = [
    (UKF, P0_ADD),
    (SRUKF, P0_ADD),
    (STUKF, P0_ADD),
    (ISTSRUKF, P0_ADD),
    (ManifoldUKF, P0_ERR),
    (MEKF, P0_ERR),
]
FILTER_IDS = [c.__name__ for c, _ in FILTERS]


def _rot_x(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# ------------------------------------------------------------------ fault 1: MPC return codes


def _mpc(**kw):
    return SO3MPC(J, horizon=3, dt=1.0, Q=np.diag([10.0] * 3 + [100.0] * 3), R=np.eye(3),
                  u_max=1.0, **kw)


def _state_and_ref():
    st = AttitudeState(so3.exp(np.array([[0.3, -0.4, 0.2]])), np.zeros((1, 3)))
    return st, AttitudeReference.regulation(np.eye(3))


def test_mpc_rejects_empty_constraint_interval_instead_of_reporting_solved():
    """1 ≤ C u ≤ −1 is no QP at all: before the fix OSQP refused the data, the return code was
    ignored and the step reported status 1 with u = 0 at a 0.54 rad error."""
    ctrl = _mpc(extra_constraints=lambda s: (np.eye(3), 1.0, -1.0))
    st, ref = _state_and_ref()
    ctrl.reset(0.0, 1)
    with pytest.raises(ValueError, match=r"^extra_constraints: lower bound exceeds upper bound"):
        ctrl.command(0.0, st, ref)


class _RejectingSolver:
    """Wraps OSQP's compiled solver; ``update_data_vec`` reports a data-validation failure
    (exit code 1, what OSQP returns for l > u) without touching the problem."""

    def __init__(self, inner):
        self._inner = inner
        self.calls = 0

    def update_data_vec(self, *args):
        self.calls += 1
        return 1

    def __getattr__(self, name):
        return getattr(self._inner, name)


def test_mpc_failed_update_triggers_the_fallback_and_is_logged(caplog):
    ctrl = _mpc()
    st, ref = _state_and_ref()
    ctrl.reset(0.0, 1)
    ctrl.command(0.0, st, ref)
    assert ctrl.diagnostics()["status"][0] == 1
    qp = ctrl._qps[0]
    if qp._s is None:  # pragma: no cover - another osqp version
        pytest.skip("osqp without the compiled solver object")
    qp._s = _RejectingSolver(qp._s)
    with caplog.at_level(logging.WARNING, logger="liecontrol.control.mpc"):
        u = ctrl.command(1.0, st, ref)
    d = ctrl.diagnostics()
    assert d["status"][0] == -12 and d["fallback_active"][0]
    assert "update_data_vec rejected" in caplog.text and "fallback GeometricPD" in caplog.text
    pd = GeometricPD(J, *gains_from_bandwidth(J, 0.1, 1.0, matrix=True))
    pd.reset(0.0, 1)
    np.testing.assert_allclose(u, np.clip(pd.command(1.0, st, ref), -1.0, 1.0), atol=1e-12)


# ------------------------------------------------------------------ fault 3: J⁻¹ at |w| = 2πk


@pytest.mark.parametrize("k", [1, 2])
def test_jacobian_inverses_raise_at_the_singular_set(k):
    w = np.array([0.0, 2.0 * np.pi * k, 0.0])
    for f in (so3.left_jacobian_inv, so3.right_jacobian_inv):
        with pytest.raises(ValueError, match=r"^w: the SO\(3\) Jacobian inverse is singular"):
            f(w)
    for f in (se3.left_jacobian_inv, se3.right_jacobian_inv):
        with pytest.raises(ValueError, match=r"^xi: the SO\(3\) Jacobian inverse is singular"):
            f(np.r_[w, 1.0, 2.0, 3.0])


@pytest.mark.parametrize("offset", [-1e-6, 1e-6, -1e-3, 0.5])
def test_jacobian_inverses_stay_accurate_near_the_singular_set(offset):
    """Against numpy's inverse of J_r (an independent route): relative error ~ eps·cond(J)."""
    n = np.array([1.0, -2.0, 2.0]) / 3.0
    w = (2.0 * np.pi + offset) * n
    for jac, inv in ((so3.right_jacobian, so3.right_jacobian_inv),
                     (so3.left_jacobian, so3.left_jacobian_inv)):
        Ji = inv(w)
        ref = np.linalg.inv(jac(w))
        cond = np.linalg.cond(jac(w))
        assert np.abs(Ji - ref).max() <= 1e-14 * cond * np.abs(ref).max()
        assert np.abs(jac(w) @ Ji - np.eye(3)).max() < 1e-14 * cond


def test_jacobians_and_exp_of_huge_rotation_vectors_are_finite_and_correct():
    """Overflow used to give NaN: exp([1e160, 0, 0]) is the rotation about x by the float angle
    1e160 (libm reduces it exactly), by hand."""
    th = 1e160
    np.testing.assert_allclose(so3.exp([th, 0.0, 0.0]), _rot_x(th), atol=1e-15)
    for f in (so3.left_jacobian, so3.right_jacobian, so3.right_jacobian_inv):
        assert np.all(np.isfinite(f([th, -th, 0.5 * th])))
    # J_r in axis–angle form at a huge angle: I − ((1−cos θ)/θ) n^ + (1 − sin θ/θ) n^² → n nᵀ
    n = np.array([1.0, -1.0, 0.5]) / 1.5
    np.testing.assert_allclose(so3.right_jacobian(1e300 * n), np.outer(n, n), atol=1e-15)
    # a mixed batch: the huge row does not change the ordinary one
    w = np.array([[th, 0.0, 0.0], [0.1, 0.2, -0.3]])
    np.testing.assert_allclose(so3.exp(w)[1], Rotation.from_rotvec(w[1]).as_matrix(), atol=1e-15)
    assert np.all(np.isfinite(se3.exp(np.r_[1e300, 0.0, 0.0, 1e300, 1.0, 0.0])))
    with pytest.raises(ValueError, match="^xi: the SE"):
        se3.left_jacobian_inv(np.full(6, 1e200))


# ------------------------------------------------------------------ fault 4: filters


def _gyroless_truth(K: int, seed: int):
    m = GyrolessAttitudeModel(J)
    rng = np.random.default_rng(seed)
    x = X0.copy()
    xs, zs = [], []
    for _ in range(K):
        x = m.f(x[None], np.zeros(3), 1.0)[0]
        xs.append(x)
        zs.append(m.h(x[None])[0] + rng.normal(0.0, m.sigma_z))
    return m, np.array(xs), np.array(zs)


def test_gate_threshold_is_the_chi2_quantile():
    m = GyrolessAttitudeModel(J)
    f = UKF(m, X0, P0_ADD, gate_probability=1e-3)
    assert f.gate_threshold == pytest.approx(chi2.ppf(1.0 - 1e-3, 3), rel=1e-12)
    assert UKF(m, X0, P0_ADD, gate_probability=None).gate_threshold == np.inf
    for bad in (0.0, 1.0, float("nan"), "x", [0.1, 0.2]):
        with pytest.raises(ValueError, match="^gate_probability"):
            UKF(m, X0, P0_ADD, gate_probability=bad)
    with pytest.raises(ValueError, match="^gate_max_consecutive"):
        UKF(m, X0, P0_ADD, gate_max_consecutive=0)


@pytest.mark.parametrize(("cls", "P0"), FILTERS, ids=FILTER_IDS)
def test_every_filter_gates_outliers_and_keeps_tracking(cls, P0, caplog):
    """A 3 rad outlier every other step: before the fix STUKF/ISTSRUKF diverged at steps 6–8
    with an error naming the quaternion, the others accepted NIS ≈ 1e6."""
    m, xs, zs = _gyroless_truth(20, 0)
    f = cls(m, X0, P0)
    gated = 0
    with caplog.at_level(logging.WARNING, logger="liecontrol.estimation"):
        for k, z in enumerate(zs):
            ok = f.step(np.zeros(3), 1.0, z + (3.0 if k % 2 else 0.0))
            d = f.diagnostics
            if k % 2:
                assert not ok and d["gated"] and d["update_rejected"]
                assert d["reason"].startswith("nu: innovation rejected by the χ² gate")
                assert d["nis"] > 1e5 > d["gate_threshold"]
                gated += 1
            else:
                assert ok and not d["gated"] and d["nis"] < d["gate_threshold"]
    assert gated == 10 and "χ² gate" in caplog.text
    err = f.error(xs[-1])[:3] if cls in (MEKF, ManifoldUKF) else None
    if err is None:
        q = f.x[:4] * np.sign(f.x[0])
        err = 2.0 * (q[1:] - xs[-1][1:4] * np.sign(xs[-1][0]))
    assert np.linalg.norm(err) < 0.01


def test_gate_can_be_disabled_and_a_lost_filter_recovers():
    m, _, zs = _gyroless_truth(6, 1)
    f = UKF(m, X0, P0_ADD, gate_probability=None)
    assert f.step(np.zeros(3), 1.0, zs[0] + 3.0)  # accepted without the gate
    assert f.diagnostics["nis"] > 1e5
    g = UKF(m, X0, P0_ADD, gate_max_consecutive=2)
    res = [g.step(np.zeros(3), 1.0, z + 0.5) for z in zs[:4]]  # a persistent 0.5 rad bias
    assert res[:2] == [False, False] and res[2]  # the third in a row is let through


def test_mekf_repair_restores_a_valid_covariance():
    """P[0, 0] negated: before the fix the MEKF 'repaired' P_zz, then P reached eigenvalues
    −1e38 … 1e55 and step 3 failed with an error about the quaternion."""
    m, xs, zs = _gyroless_truth(15, 2)
    f = MEKF(m, X0, P0_ERR)
    f.step(np.zeros(3), 1.0, zs[0])
    f.predict(np.zeros(3), 1.0)
    P_before = f.P
    f._P[0, 0] = -f._P[0, 0]  # the gross loss of positive-definiteness of the issue
    f.update(zs[1])
    assert f.diagnostics["repaired"]
    for z in zs[2:]:
        f.step(np.zeros(3), 1.0, z)
        eig = np.linalg.eigvalsh(f.P)
        assert eig.min() > 0.0 and eig.max() < 10.0 * np.abs(P_before).max()
    assert np.linalg.norm(f.error(xs[-1])[:3]) < 0.01
    g = MEKF(m, X0, P0_ERR, pd_policy="raise")
    g.step(np.zeros(3), 1.0, zs[0])
    g.predict(np.zeros(3), 1.0)
    g._P[0, 0] = -g._P[0, 0]
    with pytest.raises(NotPositiveDefiniteError, match="^P: lost positive-definiteness"):
        g.update(zs[1])


def test_nearest_pd_sqrt_mirror_undoes_a_sign_flip_exactly():
    P = np.diag([4.0, 2.0, 1.0])
    Pbad = P.copy()
    Pbad[1, 1] = -2.0
    S = nearest_pd_sqrt(Pbad, mirror=True)
    np.testing.assert_allclose(S @ S.T, P, rtol=1e-14)
    S0 = nearest_pd_sqrt(Pbad)  # Higham clipping: the flipped variance goes to the floor
    np.testing.assert_allclose(np.diag(S0 @ S0.T), [4.0, 4e-12, 1.0], rtol=1e-9)
    for bad in (0.0, -1.0, float("nan"), 2.0):
        with pytest.raises(ValueError, match="^floor:"):
            nearest_pd_sqrt(P, floor=bad)
    np.testing.assert_allclose(nearest_pd_sqrt(P.tolist()), np.linalg.cholesky(P))


def test_divergence_names_the_covariance():
    class Exploding(GyrolessAttitudeModel):
        def Q_err(self, dt):
            return np.full((6, 6), np.inf)

    f = MEKF(Exploding(J), X0, P0_ERR)
    with pytest.raises(NotPositiveDefiniteError, match="^P: "):
        f.predict(np.zeros(3), 1.0)


# ------------------------------------------------------------------ the so3/se3 array layer


@pytest.mark.parametrize(
    ("M", "fragment"),
    [
        (2.0 * np.eye(3), "not orthonormal"),
        (np.diag([1.0, 1.0, -1.0]), "reflection"),
        (np.zeros((3, 3)), "not orthonormal"),
    ],
)
def test_so3_log_rejects_non_rotations(M, fragment):
    """These returned [0, 0, 0] before."""
    for f in (so3.log, so3.angle, so3.inverse, so3.adjoint):
        with pytest.raises(ValueError, match=rf"^R: .*{fragment}"):
            f(M)
    with pytest.raises(ValueError, match=rf"^R2: .*{fragment}"):
        so3.compose(np.eye(3), M)


def test_se3_array_functions_check_finiteness_and_the_last_row():
    g = se3.exp(np.array([0.1, 0.2, 0.3, 1.0, 2.0, 3.0]))
    nan = g.copy()
    nan[0, 3] = np.nan
    row = g.copy()
    row[3, 3] = np.inf
    for f in (se3.inverse, se3.adjoint, se3.coadjoint, se3.rotation, se3.translation, se3.log):
        with pytest.raises(ValueError, match="^g: contains 1 non-finite"):
            f(nan)
        with pytest.raises(ValueError, match="^g: contains 1 non-finite"):
            f(row)
    shifted = g.copy()
    shifted[3, 0] = 0.5
    with pytest.raises(ValueError, match=r"^g: last row is not \(0, 0, 0, 1\)"):
        se3.act(shifted, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="^g1: contains"):
        se3.distance(nan, g)
    with pytest.raises(ValueError, match="^g1: contains"):
        se3.compose(nan, g)
    with pytest.raises(ValueError, match="^s: contains"):
        se3.interpolate(g, g, np.nan)


def test_batch_mismatch_names_the_argument():
    R3 = so3.exp(np.zeros((3, 3)))
    R4 = so3.exp(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="^R2: batch shape"):
        so3.compose(R3, R4)
    with pytest.raises(ValueError, match="^p: batch shape"):
        so3.act(R3, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="^q: batch shape"):
        quaternion.multiply(np.tile([1.0, 0, 0, 0], (3, 1)), np.tile([1.0, 0, 0, 0], (4, 1)))
    with pytest.raises(ValueError, match="^omega: batch shape"):
        euler.kinematics(np.zeros((3, 3)), np.zeros((4, 3)), "ZYX")


def test_unchecked_variants_equal_the_checked_functions():
    R = so3.random(np.random.default_rng(3), 50)
    np.testing.assert_array_equal(so3.log_unchecked(R), so3.log(R))
    np.testing.assert_array_equal(so3.angle_unchecked(R), so3.angle(R))
    g = se3.random(np.random.default_rng(4), 20)
    np.testing.assert_array_equal(se3.inverse_unchecked(g), se3.inverse(g))
    np.testing.assert_array_equal(se3.adjoint_unchecked(g), se3.adjoint(g))
    np.testing.assert_array_equal(se3.log_unchecked(g), se3.log(g))


# ------------------------------------------------------------------ overflow


def test_quaternion_normalize_and_friends_do_not_overflow():
    q = np.array([0.6, 0.0, 0.8, 0.0])
    np.testing.assert_allclose(quaternion.normalize(1e300 * q), q, rtol=1e-15)
    np.testing.assert_allclose(quaternion.normalize(1e-300 * q), q, rtol=1e-15)
    assert quaternion.norm(1e300 * q) == pytest.approx(1e300, rel=1e-15)
    np.testing.assert_allclose(quaternion.inverse(1e300 * q), 1e-300 * quaternion.conjugate(q))
    with pytest.raises(ValueError, match="^q: the product"):
        quaternion.multiply(1e200 * q, 1e200 * q)
    with pytest.raises(ValueError, match="^omega: "):
        quaternion.kinematics(1e200 * q, [1e200, 0.0, 0.0])
    th = 1e160
    np.testing.assert_allclose(
        quaternion.from_rotvec([th, 0.0, 0.0]), [math.cos(th / 2), math.sin(th / 2), 0, 0]
    )


def test_mrp_long_vectors_use_the_shadow_and_stay_finite():
    """p and its shadow −p/|p|² are the same rotation (independent of the to_matrix formula);
    before the fix |p| = 1e300 gave NaN."""
    rng = np.random.default_rng(5)
    p = rng.normal(size=(20, 3)) * 3.0
    np.testing.assert_allclose(mrp.to_matrix(p), mrp.to_matrix(mrp.shadow(p)), atol=1e-14)
    big = np.array([1e300, -2e299, 0.0])
    np.testing.assert_allclose(mrp.to_matrix(big), np.eye(3), atol=1e-15)  # θ → 2π
    G = mrp.kinematics_matrix(p)
    np.testing.assert_allclose(mrp.kinematics_matrix_inv(p), np.linalg.inv(G), rtol=1e-10)
    assert np.all(np.isfinite(mrp.kinematics_matrix_inv(big)))
    with pytest.raises(ValueError, match="^p: G"):
        mrp.kinematics_matrix(big)


def test_unscented_transform_overflow_raises():
    with pytest.raises(ValueError, match="^P: "):
        unscented_transform(lambda X: X * X, np.zeros(2), 1e300 * np.eye(2))
    with pytest.raises(ValueError, match="^g: returned non-finite"):
        unscented_transform(lambda X: np.where(X > 0, X, np.inf), np.zeros(2), np.eye(2))


@pytest.mark.parametrize("make", [
    lambda: GeometricPD(J, 1.0, 1.0),
    lambda: IntrinsicPID(J, 1.0, 1.0, 0.1),
    lambda: PrescribedPerformance(J, 0.01, 0.1),
], ids=["GeometricPD", "IntrinsicPID", "PrescribedPerformance"])
def test_controllers_raise_on_overflow_and_on_a_nan_time(make):
    c = make()
    ref = AttitudeReference.regulation(np.eye(3))
    c.reset(0.0, 1)
    with pytest.raises(ValueError, match="^omega: the command is not finite"):
        c.command(0.0, AttitudeState(np.eye(3)[None], np.array([[1e300, 5e299, 0.0]])), ref)
    c.reset(0.0, 1)
    with pytest.raises(ValueError, match="^t: "):
        c.command(float("nan"), AttitudeState(np.eye(3)[None], np.zeros((1, 3))), ref)


# ------------------------------------------------------------------ tolerances, complex, scalars


def test_tolerance_arguments_are_validated():
    lock = np.array([0.1, np.pi / 2, 0.2])
    for bad in (float("nan"), -1e-6, 0.0, "1e-6", [1e-6, 1e-6]):
        with pytest.raises((ValueError, TypeError), match="^lock_tol:"):
            euler.rates_matrix(lock, "ZYX", lock_tol=bad)
        with pytest.raises((ValueError, TypeError), match="^norm_tol:"):
            quaternion.to_matrix([1.0, 0, 0, 0], norm_tol=bad)
        with pytest.raises((ValueError, TypeError), match="^atol:"):
            so3.validate(np.eye(3), atol=bad)
        with pytest.raises((ValueError, TypeError), match="^singular_tol:"):
            rotvec.kinematics_matrix([0.1, 0.0, 0.0], singular_tol=bad)
    with pytest.raises(ValueError, match="^lock_tol: must be < 1"):
        euler.rates_matrix([0.1, 0.2, 0.3], "ZYX", lock_tol=2.0)


def test_complex_input_is_rejected_not_truncated():
    R = so3.exp([0.1, 0.2, 0.3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning must not even be raised
        with pytest.raises(ValueError, match="^R: complex values are not accepted"):
            SO3(R + 0.5j)
        with pytest.raises(ValueError, match="^w: complex"):
            so3.exp(np.array([0.1, 0.2j, 0.0]))
        # a complex dtype with zero imaginary parts is a real number
        np.testing.assert_array_equal(as_array(R + 0j, "R"), R)


def test_scalars_are_required_where_documented():
    with pytest.raises(ValueError, match="^omega_n: expected a scalar"):
        gains_from_bandwidth(J, np.array([0.1, 0.2]))
    with pytest.raises(ValueError, match="^omega_n: the gains"):
        gains_from_bandwidth(J, 1e300)  # an OverflowError before
    with pytest.raises(ValueError, match="^G: "):
        gains_from_bandwidth(J, 0.1, G="abc")


# ------------------------------------------------------------------ low-level estimation helpers


def test_estimation_helpers_validate_and_accept_lists():
    np.testing.assert_allclose(wrap_angle([3 * np.pi, -np.pi, 0.5]), [np.pi, np.pi, 0.5])
    with pytest.raises(ValueError, match="^a: "):
        wrap_angle([np.nan])
    X = sigma_points([0.0, 1.0], [[1.0, 0.0], [0.5, 2.0]], 2.0)
    np.testing.assert_allclose(X, [[0, 1], [2, 2], [0, 5], [-2, 0], [0, -3]])
    with pytest.raises(ValueError, match="^gamma: must be > 0"):
        sigma_points([0.0, 1.0], np.eye(2), 0.0)
    with pytest.raises(ValueError, match="^S: expected shape"):
        sigma_points([0.0, 1.0], np.eye(3), 1.0)
    rpy = euler_rpy_from_quaternion([[0.9, 0.1, -0.3, 0.2]])
    ref = Rotation.from_quat([0.1, -0.3, 0.2, 0.9]).as_euler("ZYX")[::-1]
    np.testing.assert_allclose(rpy[0], ref, atol=1e-14)
    with pytest.raises(ValueError, match="^q: zero quaternion"):
        euler_rpy_from_quaternion([0.0, 0.0, 0.0, 0.0])
    A = psd_sqrt([[4.0, 0.0], [0.0, 0.0]])  # singular: the eigen route
    np.testing.assert_allclose(A @ A.T, [[4.0, 0.0], [0.0, 0.0]], atol=1e-15)
    with pytest.raises(ValueError, match="^Q: not symmetric"):
        psd_sqrt([[1.0, 1.0], [0.0, 1.0]])
    m = GyrolessAttitudeModel(J)
    for kw, name in (({"dt": 0.0}, "dt"), ({"dt": 1.0, "eps": 0.0}, "eps")):
        args = {"dt": 1.0, **kw}
        with pytest.raises(ValueError, match=f"^{name}: must be > 0"):
            numerical_error_transition(m, list(X0), [0.0, 0.0, 0.0], **args)


def test_norm_last_matches_hypot_at_the_extremes():
    a = np.array([[3e300, 4e300], [3e-300, 4e-300], [0.0, 0.0], [3.0, 4.0]])
    np.testing.assert_allclose(norm_last(a), np.hypot(a[:, 0], a[:, 1]), rtol=1e-15)


def test_state_containers_validate():
    with pytest.raises(ValueError, match="^R: contains"):
        AttitudeState(np.full((1, 3, 3), np.nan), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="^omega: batch shape"):
        AttitudeState(np.eye(3)[None], np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^omega_d: "):
        AttitudeReference(np.eye(3), [np.inf, 0.0, 0.0], np.zeros(3))
