"""Tests of liecontrol.errors (SPEC §4): identities checked against independent routes (explicit
Rodrigues matrices, finite differences, scipy.linalg.expm for SE(3))."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from liecontrol import errors as E
from liecontrol.lie import so3

KINDS = ("trace", "large_angle", "log")
G_TEST = np.array([[1.2, 0.1, 0.0], [0.1, 0.7, -0.05], [0.0, -0.05, 0.9]])

seeds = st.integers(min_value=0, max_value=2**32 - 1)


def rodrigues(theta: float, n: np.ndarray) -> np.ndarray:
    """R = cos θ I + sin θ n^ + (1 − cos θ) n nᵀ for a unit axis n (written out, no so3)."""
    n = np.asarray(n, dtype=float) / np.linalg.norm(n)
    K = np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])
    return np.cos(theta) * np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * np.outer(n, n)


def skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def err(kind: str, R, R_d, G=None):
    return E.attitude_error(kind, R, R_d, **({"G": G} if G is not None else {}))


def random_rot(rng: np.random.Generator) -> np.ndarray:
    return so3.random(rng)


def rel_angle(R, R_d) -> float:
    Rt = R_d.T @ R
    return float(np.arccos(np.clip((np.trace(Rt) - 1) / 2, -1, 1)))


# ---------------------------------------------------------------------------------------------
# positivity and zero set


@settings(max_examples=60, deadline=None)
@given(seed=seeds, kind=st.sampled_from(KINDS))
def test_psi_nonnegative_and_zero_only_at_desired(seed, kind):
    rng = np.random.default_rng(seed)
    R, R_d = random_rot(rng), random_rot(rng)
    G = G_TEST if kind == "trace" else None
    Psi, e_R = err(kind, R, R_d, G)
    assert Psi >= 0
    if rel_angle(R, R_d) > 1e-4:
        assert Psi > 1e-10
    Psi0, e0 = err(kind, R_d, R_d, G)
    assert abs(Psi0) < 1e-14
    np.testing.assert_allclose(e0, 0.0, atol=1e-14)


@settings(max_examples=40, deadline=None)
@given(
    seed=seeds,
    theta=st.floats(min_value=0.0, max_value=np.pi - 1e-6),
)
def test_angle_relations(seed, theta):
    rng = np.random.default_rng(seed)
    n = rng.standard_normal(3)
    n /= np.linalg.norm(n)
    R_d = random_rot(rng)
    R = R_d @ rodrigues(theta, n)
    # large-angle: Ψ = 2 − 2cos(θ/2), e_R = sin(θ/2) n
    Psi, e_R = E.large_angle_error(R, R_d)
    assert Psi == pytest.approx(2 - 2 * np.cos(theta / 2), abs=1e-12)
    np.testing.assert_allclose(e_R, np.sin(theta / 2) * n, atol=1e-9)
    # log: Ψ = θ²/2, e_R = θ n
    Psi, e_R = E.log_error(R, R_d)
    assert Psi == pytest.approx(theta**2 / 2, abs=1e-9)
    np.testing.assert_allclose(e_R, theta * n, atol=1e-8)
    # trace: Ψ = (1 − cos θ)(tr G − nᵀGn)
    Psi, _ = E.trace_error(R, R_d, G_TEST)
    expect = (1 - np.cos(theta)) * (np.trace(G_TEST) - n @ G_TEST @ n)
    assert Psi == pytest.approx(expect, abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(seed=seeds)
def test_large_angle_matches_spec_formula_away_from_pi(seed):
    rng = np.random.default_rng(seed)
    R, R_d = random_rot(rng), random_rot(rng)
    if rel_angle(R, R_d) > np.pi - 1e-3:
        R = R_d @ rodrigues(1.0, [1, 2, 3])
    Rt = R_d.T @ R
    root = np.sqrt(1 + np.trace(Rt))
    Psi, e_R = E.large_angle_error(R, R_d)
    assert Psi == pytest.approx(2 - root, abs=1e-12)
    vee = np.array([Rt[2, 1] - Rt[1, 2], Rt[0, 2] - Rt[2, 0], Rt[1, 0] - Rt[0, 1]])
    np.testing.assert_allclose(e_R, vee / (2 * root), atol=1e-10)
    assert np.linalg.norm(e_R) <= 1 + 1e-12


def test_trace_matches_spec_formula():
    rng = np.random.default_rng(1)
    R, R_d = so3.random(rng, 10), so3.random(rng, 10)
    Psi, e_R = E.trace_error(R, R_d, G_TEST)
    for i in range(10):
        Rt = R_d[i].T @ R[i]
        assert Psi[i] == pytest.approx(np.trace(G_TEST @ (np.eye(3) - Rt)), abs=1e-13)
        A = 0.5 * (G_TEST @ Rt - Rt.T @ G_TEST)
        np.testing.assert_allclose(e_R[i], [A[2, 1], A[0, 2], A[1, 0]], atol=1e-14)
        np.testing.assert_allclose(A, -A.T, atol=1e-14)


def test_default_G_is_documented_value_and_readonly():
    np.testing.assert_array_equal(E.DEFAULT_G, np.diag([0.9, 1.0, 1.1]))
    with pytest.raises(ValueError):
        E.DEFAULT_G[0, 0] = 2.0
    rng = np.random.default_rng(2)
    R, R_d = random_rot(rng), random_rot(rng)
    a = E.trace_error(R, R_d)
    b = E.trace_error(R, R_d, np.diag([0.9, 1.0, 1.1]))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


# ---------------------------------------------------------------------------------------------
# derivative identity and gradient


@settings(max_examples=30, deadline=None)
@given(seed=seeds, kind=st.sampled_from(KINDS))
def test_time_derivative_identity(seed, kind):
    """d/dt Ψ = c e_R·e_Ω along Ṙ = RΩ^, Ṙ_d = R_dΩ_d^ (constant body rates: exact exp flows)."""
    rng = np.random.default_rng(seed)
    R0, Rd0 = random_rot(rng), random_rot(rng)
    W = rng.normal(scale=1.0, size=3)
    Wd = rng.normal(scale=1.0, size=3)
    G = G_TEST if kind == "trace" else None
    t0 = float(rng.uniform(0, 2))

    def at(t):
        return R0 @ so3.exp(W * t), Rd0 @ so3.exp(Wd * t)

    R, R_d = at(t0)
    if kind != "trace" and rel_angle(R, R_d) > np.pi - 0.05:
        return  # Ψ is not differentiable on the antipodal set; identity is for θ < π
    h = 1e-5
    dPsi = (err(kind, *at(t0 + h), G)[0] - err(kind, *at(t0 - h), G)[0]) / (2 * h)
    _, e_R = err(kind, R, R_d, G)
    e_W = E.angular_velocity_error(R, W, R_d, Wd)
    c = E.DERIVATIVE_FACTOR[kind]
    assert dPsi == pytest.approx(c * e_R @ e_W, abs=2e-8)


@settings(max_examples=30, deadline=None)
@given(seed=seeds, kind=st.sampled_from(KINDS))
def test_error_vector_is_gradient(seed, kind):
    """d/dε Ψ(R exp(εη^), R_d) at ε = 0 equals c e_R·η."""
    rng = np.random.default_rng(seed)
    R, R_d = random_rot(rng), random_rot(rng)
    if kind != "trace" and rel_angle(R, R_d) > np.pi - 0.05:
        R = R_d @ rodrigues(2.5, rng.standard_normal(3))
    G = G_TEST if kind == "trace" else None
    eta = rng.standard_normal(3)
    h = 1e-6
    step = scipy.linalg.expm(skew(h * eta))
    fd = (err(kind, R @ step, R_d, G)[0] - err(kind, R @ step.T, R_d, G)[0]) / (2 * h)
    _, e_R = err(kind, R, R_d, G)
    assert fd == pytest.approx(E.DERIVATIVE_FACTOR[kind] * e_R @ eta, abs=1e-8)


def test_angular_velocity_error_is_rate_of_relative_rotation():
    """d/dt R̃ = R̃ e_Ω^ with R̃ = R_dᵀR (seed 002 eq. (13))."""
    rng = np.random.default_rng(3)
    R0, Rd0 = random_rot(rng), random_rot(rng)
    W, Wd = rng.standard_normal(3), rng.standard_normal(3)

    def rel(t):
        return (Rd0 @ so3.exp(Wd * t)).T @ (R0 @ so3.exp(W * t))

    h = 1e-6
    dRt = (rel(h) - rel(-h)) / (2 * h)
    expect = E.angular_velocity_error(R0, W, Rd0, Wd)
    np.testing.assert_allclose(rel(0).T @ dRt, skew(expect), atol=1e-8)
    np.testing.assert_allclose(expect, W - R0.T @ Rd0 @ Wd, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# singular set


@pytest.mark.parametrize("axis", [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, -2, 0.5]])
def test_no_nan_at_exactly_pi(axis):
    n = np.asarray(axis, float) / np.linalg.norm(axis)
    R_d = so3.random(np.random.default_rng(4))
    flip = 2 * np.outer(n, n) - np.eye(3)  # exact rotation by π about n
    R = R_d @ flip
    for kind in KINDS:
        Psi, e_R = err(kind, R, R_d)
        assert np.isfinite(Psi) and np.all(np.isfinite(e_R))
    Psi, e_R = E.large_angle_error(R, R_d)
    assert Psi == pytest.approx(2.0, abs=1e-7)
    assert np.linalg.norm(e_R) == pytest.approx(1.0, abs=1e-7)
    assert abs(abs(e_R @ n) - 1) < 1e-7  # along the axis, sign is the so3.log branch
    Psi, e_R = E.log_error(R, R_d)
    assert Psi == pytest.approx(np.pi**2 / 2, abs=1e-6)
    assert np.linalg.norm(e_R) == pytest.approx(np.pi, abs=1e-6)
    Psi, e_R = E.trace_error(R, R_d, G_TEST)
    assert Psi == pytest.approx(2 * (np.trace(G_TEST) - n @ G_TEST @ n), abs=1e-12)


def test_exact_pi_about_identity_axes_is_exact():
    for kind in KINDS:
        Psi, e_R = err(kind, np.diag([1.0, -1.0, -1.0]), np.eye(3))
        assert np.all(np.isfinite(e_R))
    Psi, e_R = E.large_angle_error(np.diag([-1.0, -1.0, 1.0]), np.eye(3))
    assert Psi == 2.0 or Psi == pytest.approx(2.0, abs=1e-15)
    np.testing.assert_allclose(np.abs(e_R), [0, 0, 1], atol=1e-15)


def test_continuity_near_pi():
    """Approaching π, ‖e_R‖ tends to the value documented at π (one-sided limit)."""
    n = np.array([0.3, -0.4, 0.5])
    n /= np.linalg.norm(n)
    for eps in (1e-4, 1e-8, 1e-12):
        R = rodrigues(np.pi - eps, n)
        Psi, e_R = E.large_angle_error(R, np.eye(3))
        assert Psi == pytest.approx(2 - 2 * np.sin(eps / 2), abs=1e-9)
        np.testing.assert_allclose(e_R, np.cos(eps / 2) * n, atol=1e-7)
        _, e_log = E.log_error(R, np.eye(3))
        np.testing.assert_allclose(e_log, (np.pi - eps) * n, atol=1e-7)


# ---------------------------------------------------------------------------------------------
# shapes, registry, bad input


def test_batch_shapes_and_broadcast_equal_per_element():
    rng = np.random.default_rng(5)
    R = so3.random(rng, (2, 4))
    R_d = so3.random(rng, 4)
    for kind in KINDS:
        Psi, e_R = err(kind, R, R_d)
        assert Psi.shape == (2, 4) and e_R.shape == (2, 4, 3)
        for i in range(2):
            for j in range(4):
                p, e = err(kind, R[i, j], R_d[j])
                assert p.shape == () and e.shape == (3,)
                assert Psi[i, j] == pytest.approx(p, abs=1e-14)
                np.testing.assert_allclose(e_R[i, j], e, atol=1e-14)
        Psi1, _ = err(kind, R, np.eye(3))
        assert Psi1.shape == (2, 4)
    W = rng.standard_normal((2, 4, 3))
    assert E.angular_velocity_error(R, W, R_d, np.zeros(3)).shape == (2, 4, 3)


def test_inputs_not_mutated():
    rng = np.random.default_rng(6)
    R, R_d = so3.random(rng, 3), so3.random(rng, 3)
    G = G_TEST.copy()
    copies = (R.copy(), R_d.copy(), G.copy())
    for kind in KINDS:
        err(kind, R, R_d, G if kind == "trace" else None)
    for a, b in zip((R, R_d, G), copies, strict=True):
        np.testing.assert_array_equal(a, b)


def test_registry():
    assert set(E.ATTITUDE_ERRORS) == set(KINDS) == set(E.DERIVATIVE_FACTOR)
    assert E.DERIVATIVE_FACTOR == {"trace": 2.0, "large_angle": 1.0, "log": 1.0}
    rng = np.random.default_rng(7)
    R, R_d = random_rot(rng), random_rot(rng)
    np.testing.assert_array_equal(E.attitude_error("log", R, R_d)[1], E.log_error(R, R_d)[1])


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: E.large_angle_error(np.eye(3) * 1.01, np.eye(3)), "R:"),
        (lambda: E.log_error(np.eye(3), np.full((3, 3), np.nan)), "R_d:"),
        (lambda: E.trace_error(np.eye(3), np.diag([1.0, -1.0, 1.0])), "R_d:"),
        (lambda: E.trace_error(np.eye(3), np.eye(3), np.eye(3)), "G:"),
        (lambda: E.trace_error(np.eye(3), np.eye(3), np.diag([1.0, 2.0, -3.0])), "G:"),
        (lambda: E.trace_error(np.eye(3), np.eye(3), [[1, 0.2, 0], [0, 2, 0], [0, 0, 3]]), "G:"),
        (lambda: E.trace_error(np.eye(3), np.eye(3), np.eye(2)), "G:"),
        (lambda: E.large_angle_error(np.eye(4), np.eye(3)), "R:"),
        (lambda: E.log_error(so3.identity((2,)), so3.identity((3,))), "R_d:"),
        (lambda: E.attitude_error("quaternion", np.eye(3), np.eye(3)), "kind:"),
        (lambda: E.attitude_error("log", np.eye(3), np.eye(3), G=E.DEFAULT_G), "G:"),
        (lambda: E.attitude_error("trace", np.eye(3), np.eye(3), H=1), "H:"),
        (lambda: E.angular_velocity_error(np.eye(3), [1, 2], np.eye(3), [0, 0, 0]), "omega:"),
        (
            lambda: E.angular_velocity_error(np.eye(3), [1, 2, 3], np.eye(3), [np.inf] * 3),
            "omega_d:",
        ),
    ],
)
def test_bad_input(call, name):
    with pytest.raises(ValueError) as exc:
        call()
    assert str(exc.value).startswith(name)


# ---------------------------------------------------------------------------------------------
# SE(3)


def se3_hat(xi: np.ndarray) -> np.ndarray:
    X = np.zeros((4, 4))
    X[:3, :3] = skew(xi[:3])
    X[:3, 3] = xi[3:]
    return X


def random_pose(rng) -> np.ndarray:
    g = np.eye(4)
    g[:3, :3] = random_rot(rng)
    g[:3, 3] = rng.normal(scale=3.0, size=3)
    return g


@settings(max_examples=30, deadline=None)
@given(seed=seeds)
def test_se3_log_error_inverts_expm(seed):
    rng = np.random.default_rng(seed)
    g_d = random_pose(rng)
    w = rng.standard_normal(3)
    w *= rng.uniform(0, np.pi - 1e-3) / np.linalg.norm(w)
    xi = np.concatenate((w, rng.normal(scale=2.0, size=3)))
    g = g_d @ scipy.linalg.expm(se3_hat(xi))
    np.testing.assert_allclose(E.se3_log_error(g, g_d), xi, atol=1e-9)


def test_se3_log_error_zero_and_batched():
    rng = np.random.default_rng(8)
    g = np.stack([random_pose(rng) for _ in range(5)])
    np.testing.assert_allclose(E.se3_log_error(g, g), 0.0, atol=1e-13)
    out = E.se3_log_error(g, np.eye(4))
    assert out.shape == (5, 6)
    for i in range(5):
        np.testing.assert_allclose(out[i], E.se3_log_error(g[i], np.eye(4)), atol=1e-15)
    # at θ = π the rotation part is finite and the pose is reproduced
    g_pi = np.eye(4)
    g_pi[:3, :3] = np.diag([1.0, -1.0, -1.0])
    g_pi[:3, 3] = [1.0, 2.0, 3.0]
    xi = E.se3_log_error(g_pi, np.eye(4))
    assert np.all(np.isfinite(xi))
    np.testing.assert_allclose(scipy.linalg.expm(se3_hat(xi)), g_pi, atol=1e-12)


def test_se3_error_parts_and_derivative():
    rng = np.random.default_rng(9)
    g0, gd0 = random_pose(rng), random_pose(rng)
    xi, xi_d = rng.standard_normal(6), rng.standard_normal(6)

    def at(t):
        return g0 @ scipy.linalg.expm(t * se3_hat(xi)), gd0 @ scipy.linalg.expm(t * se3_hat(xi_d))

    g, g_d = at(0.0)
    for kind in KINDS:
        out = E.se3_error(g, g_d, xi, xi_d, kind=kind)
        Psi, e_R = E.attitude_error(kind, g[:3, :3], g_d[:3, :3])
        assert out.Psi == pytest.approx(Psi, abs=1e-15)
        np.testing.assert_allclose(out.e_R, e_R, atol=1e-15)
        np.testing.assert_allclose(
            out.e_Omega, E.angular_velocity_error(g[:3, :3], xi[:3], g_d[:3, :3], xi_d[:3])
        )
    out = E.se3_error(g, g_d, xi, xi_d)
    np.testing.assert_allclose(out.e_p, g[:3, 3] - g_d[:3, 3], atol=1e-15)
    h = 1e-6
    dp = (E.se3_error(*at(h), xi, xi_d).e_p - E.se3_error(*at(-h), xi, xi_d).e_p) / (2 * h)
    np.testing.assert_allclose(dp, out.e_v, atol=1e-7)
    # batched
    gb = np.stack([g, g_d])
    outb = E.se3_error(gb, g_d, np.stack([xi, xi_d]), xi_d, kind="trace", G=G_TEST)
    assert outb.Psi.shape == (2,) and outb.e_v.shape == (2, 3)
    assert outb.Psi[1] == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(outb.e_v[1], 0.0, atol=1e-14)


def test_se3_bad_input():
    g = np.eye(4)
    bad = np.eye(4)
    bad[3, 0] = 1.0
    with pytest.raises(ValueError, match="^g:"):
        E.se3_log_error(bad, g)
    with pytest.raises(ValueError, match="^g_d:"):
        E.se3_error(g, np.eye(3), np.zeros(6), np.zeros(6))
    with pytest.raises(ValueError, match="^xi:"):
        E.se3_error(g, g, np.zeros(3), np.zeros(6))
    with pytest.raises(ValueError, match="^G:"):
        E.se3_error(g, g, np.zeros(6), np.zeros(6), kind="log", G=G_TEST)
    with pytest.raises(ValueError, match="^kind:"):
        E.se3_error(g, g, np.zeros(6), np.zeros(6), kind="mrp")


def test_se3_log_error_agrees_with_lie_se3():
    se3 = pytest.importorskip("liecontrol.lie.se3")
    rng = np.random.default_rng(12)
    g = np.stack([random_pose(rng) for _ in range(4)])
    g_d = np.stack([random_pose(rng) for _ in range(4)])
    np.testing.assert_allclose(
        E.se3_log_error(g, g_d), se3.log(se3.compose(se3.inverse(g_d), g)), atol=1e-9
    )


# ----------------------------------------------------------------------------------------------
# unchecked kernels (used by GeometricPD.command on already-checked input)


def _relative_rotations() -> np.ndarray:
    """R̃ over the whole range: tiny angles (Taylor branch), generic, near π and exactly π."""
    rng = np.random.default_rng(5)
    axes = rng.normal(size=(40, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate(
        [
            [0.0, 1e-9, 1e-5, 9e-4],
            rng.uniform(0, np.pi, 28),
            np.pi - np.array([1e-3, 1e-7]),
            [np.pi] * 6,
        ]
    )
    return np.stack([rodrigues(t, n) for t, n in zip(angles, axes, strict=True)])


@pytest.mark.parametrize("kind", KINDS)
def test_unchecked_kernels_match_the_direct_formulas_to_round_off(kind):
    """The unchecked kernels (θ from the log's atan2, one BLAS product for G R̃, the cosine form of
    Ψ only where θ ≥ π/2) agree with the formulas written out on so3.log and plain matmuls, for
    every batch shape and for a strided (transposed-view) stack."""
    Rt = _relative_rotations()
    phi = so3.log(Rt)
    theta = np.linalg.norm(phi, axis=-1)
    if kind == "trace":
        GR = G_TEST @ Rt
        Psi_ref = np.trace(G_TEST) - np.trace(GR, axis1=-2, axis2=-1)
        D = GR - np.swapaxes(Rt, -1, -2) @ G_TEST
        e_ref = 0.5 * np.stack((D[:, 2, 1], D[:, 0, 2], D[:, 1, 0]), axis=-1)
    elif kind == "large_angle":
        Psi_ref = np.where(
            theta < 0.5 * np.pi, 4.0 * np.sin(theta / 4) ** 2, 2.0 - 2.0 * np.cos(theta / 2)
        )
        # sin(θ/2)/θ, with its series ½ − θ²/48 where the quotient loses digits
        hs = np.sin(theta / 2) / np.maximum(theta, 1e-300)
        hs = np.where(theta < 1e-3, 0.5 - theta**2 / 48, hs)
        e_ref = hs[:, None] * phi
    else:
        Psi_ref, e_ref = 0.5 * theta**2, phi
    kernel = E._KERNELS[kind]
    args = (G_TEST,) if kind == "trace" else ()
    strided = np.ascontiguousarray(Rt.transpose(1, 0, 2)).transpose(1, 0, 2)
    for R_in, shape in ((Rt, (40,)), (strided, (40,)), (Rt.reshape(4, 10, 3, 3), (4, 10))):
        Psi, e_R = kernel(R_in, *args)
        assert Psi.shape == shape and e_R.shape == shape + (3,)
        np.testing.assert_allclose(Psi.reshape(-1), Psi_ref, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(e_R.reshape(-1, 3), e_ref, rtol=1e-14, atol=1e-15)
    for i in (0, 3, 17, 39):  # no batch dimension
        Psi, e_R = kernel(Rt[i], *args)
        assert Psi.shape == () and e_R.shape == (3,)
        np.testing.assert_allclose(Psi, Psi_ref[i], rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(e_R, e_ref[i], rtol=1e-14, atol=1e-15)
    assert E.ATTITUDE_ERRORS[kind](Rt, np.eye(3), *args)[0].shape == (40,)


def test_batch_shapes_that_do_not_broadcast_name_the_second_argument():
    R2, R3 = np.tile(np.eye(3), (2, 1, 1)), np.tile(np.eye(3), (3, 1, 1))
    with pytest.raises(ValueError, match=r"^R_d: batch shape \(3,\) does not broadcast with R's"):
        E.log_error(R2, R3)
    g2, g3 = np.tile(np.eye(4), (2, 1, 1)), np.tile(np.eye(4), (3, 1, 1))
    with pytest.raises(ValueError, match=r"^g_d: batch shape \(3,\) does not broadcast with g's"):
        E.se3_log_error(g2, g3)
