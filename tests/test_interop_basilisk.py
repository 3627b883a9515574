"""Basilisk conventions: every conversion of ``liecontrol.interop.basilisk`` against the formulas
of Schaub & Junkins (*Analytical Mechanics of Space Systems*, ch. 3) written out here for the
DCM [BN], and MrpPD's ``feedforward`` options against Basilisk's ``mrpFeedback`` law written
out from its documentation (independent of liecontrol's code)."""

from __future__ import annotations

import numpy as np
import pytest

from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.chart_baselines import MrpPD
from liecontrol.interop import basilisk as bsk
from liecontrol.lie import so3


def _tilde(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _ep_to_dcm(b: np.ndarray) -> np.ndarray:
    """Schaub & Junkins eq. (3.98): [BN] from the Euler parameters β."""
    b0, b1, b2, b3 = b
    return np.array(
        [
            [b0**2 + b1**2 - b2**2 - b3**2, 2 * (b1 * b2 + b0 * b3), 2 * (b1 * b3 - b0 * b2)],
            [2 * (b1 * b2 - b0 * b3), b0**2 - b1**2 + b2**2 - b3**2, 2 * (b2 * b3 + b0 * b1)],
            [2 * (b1 * b3 + b0 * b2), 2 * (b2 * b3 - b0 * b1), b0**2 - b1**2 - b2**2 + b3**2],
        ]
    )


def _mrp_to_dcm(s: np.ndarray) -> np.ndarray:
    """[BN] = I + (8[σ̃]² − 4(1 − σ²)[σ̃]) / (1 + σ²)²."""
    n2 = s @ s
    T = _tilde(s)
    return np.eye(3) + (8 * T @ T - 4 * (1 - n2) * T) / (1 + n2) ** 2


def _prv_to_dcm(v: np.ndarray) -> np.ndarray:
    """[BN] = cos Φ I − sin Φ [ẽ] + (1 − cos Φ) ê êᵀ."""
    phi = np.linalg.norm(v)
    e = v / phi
    return np.cos(phi) * np.eye(3) - np.sin(phi) * _tilde(e) + (1 - np.cos(phi)) * np.outer(e, e)


def _M(axis: int, a: float) -> np.ndarray:
    """Schaub's elementary DCMs M₁, M₂, M₃ (frame rotations)."""
    c, s = np.cos(a), np.sin(a)
    return {
        1: np.array([[1, 0, 0], [0, c, s], [0, -s, c]]),
        2: np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]]),
        3: np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]),
    }[axis]


def _euler_to_dcm(angles: np.ndarray, euler_set: str) -> np.ndarray:
    """Set "ijk": [BN] = M_k(θ₃) M_j(θ₂) M_i(θ₁)."""
    i, j, k = (int(c) for c in euler_set)
    return _M(k, angles[2]) @ _M(j, angles[1]) @ _M(i, angles[0])


def _cases(seed: int, n: int = 12) -> np.ndarray:
    return so3.random(np.random.default_rng(seed), n)


def test_sigma_round_trip_matches_mrp_dcm_formula():
    Rs = _cases(0)
    w = np.random.default_rng(1).normal(size=(len(Rs), 3))
    sigma, w_b = bsk.to_sigma_BN(Rs, w)
    assert np.all(np.linalg.norm(sigma, axis=-1) <= 1 + 1e-12)  # Basilisk's short set
    for R, s in zip(Rs, sigma, strict=True):
        np.testing.assert_allclose(_mrp_to_dcm(s), R.T, atol=1e-12)
    np.testing.assert_array_equal(w_b, w)
    assert w_b is not w
    R_back, w_back = bsk.from_sigma_BN(sigma, w_b)
    np.testing.assert_allclose(R_back, Rs, atol=1e-12)
    np.testing.assert_array_equal(w_back, w)
    # a long-set σ (its shadow) maps to the same attitude
    shadow = -sigma / np.sum(sigma**2, axis=-1, keepdims=True)
    np.testing.assert_allclose(bsk.from_sigma_BN(shadow, w)[0], Rs, atol=1e-10)


def test_dcm_is_the_transpose():
    Rs = _cases(2)
    np.testing.assert_allclose(bsk.dcm_BN(Rs), np.swapaxes(Rs, -1, -2), atol=0)
    np.testing.assert_allclose(bsk.from_dcm_BN(bsk.dcm_BN(Rs)), Rs, atol=0)


def test_ep_and_quaternion_are_the_same_numbers():
    from liecontrol.charts import quaternion

    Rs = _cases(3)
    q = quaternion.from_matrix(Rs)
    beta = bsk.quat_to_ep(q)
    np.testing.assert_array_equal(beta, q)
    for R, b in zip(Rs, beta, strict=True):
        np.testing.assert_allclose(_ep_to_dcm(b), R.T, atol=1e-12)
    np.testing.assert_array_equal(bsk.ep_to_quat(beta), q)
    xyzw = bsk.ep_to_quat(beta, scalar_first=False)
    np.testing.assert_array_equal(xyzw, np.concatenate([q[:, 1:], q[:, :1]], axis=-1))
    np.testing.assert_array_equal(bsk.quat_to_ep(xyzw, scalar_first=False), q)


def test_prv_and_rotation_vector_are_the_same_numbers():
    Rs = _cases(4)
    theta = so3.log(Rs)
    prv = bsk.rotvec_to_prv(theta)
    for R, v in zip(Rs, prv, strict=True):
        np.testing.assert_allclose(_prv_to_dcm(v), R.T, atol=1e-12)
    np.testing.assert_array_equal(bsk.prv_to_rotvec(prv), theta)


@pytest.mark.parametrize("euler_set", list(bsk.EULER_SETS))
def test_all_twelve_euler_sets(euler_set: str):
    seq = bsk.euler_set_to_seq(euler_set)
    assert seq.isupper() and bsk.seq_to_euler_set(seq) == euler_set
    rng = np.random.default_rng(int(euler_set))
    for _ in range(5):
        R = so3.random(rng)
        angles = bsk.matrix_to_euler(R, euler_set)
        np.testing.assert_allclose(_euler_to_dcm(angles, euler_set), R.T, atol=1e-12)
        np.testing.assert_allclose(bsk.euler_to_matrix(angles, euler_set), R, atol=1e-12)


def test_euler_set_names():
    assert bsk.euler_set_to_seq("321") == "ZYX"
    assert bsk.euler_set_to_seq(313) == "ZXZ"
    assert bsk.seq_to_euler_set("ZYX") == "321"
    assert len(bsk.EULER_SETS) == 12 and len(set(bsk.EULER_SETS.values())) == 12


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match=r"^euler_set: unknown Euler set '322'"):
        bsk.euler_set_to_seq("322")
    with pytest.raises(ValueError, match=r"^euler_set:"):
        bsk.euler_set_to_seq(True)
    with pytest.raises(ValueError, match=r"^seq: 'xyz' is extrinsic .* use 'ZYX'"):
        bsk.seq_to_euler_set("xyz")
    with pytest.raises(ValueError, match=r"^seq: 'ZZX' repeats an axis"):
        bsk.seq_to_euler_set("ZZX")
    with pytest.raises(ValueError, match=r"^seq: expected a 3-letter"):
        bsk.seq_to_euler_set("ZY")
    with pytest.raises(ValueError, match=r"^beta: not unit-norm"):
        bsk.ep_to_quat([1.0, 0.1, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^sigma_BN: expected shape"):
        bsk.from_sigma_BN([0.1, 0.2], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^omega: expected shape"):
        bsk.to_sigma_BN(np.eye(3), [0.0, 0.0])
    with pytest.raises(ValueError, match=r"^R: not orthonormal"):
        bsk.to_sigma_BN(2 * np.eye(3), np.zeros(3))
    with pytest.raises(ValueError, match=r"^dcm: not orthonormal"):
        bsk.from_dcm_BN(np.ones((3, 3)))


# ---------------------------------------------------------------------------------------------
# MrpPD feedforward options against Basilisk's mrpFeedback law (no integral term, no wheels,
# no known torque): L_r = K σ + P δω − v × (I ω) + I(ω × ω_r − ω̇_r), u = −L_r, with
# v = ω_r (controlLawType 0, the default) or v = ω (controlLawType 1).

J = np.array([[12.0, 0.5, -0.3], [0.5, 10.0, 0.2], [-0.3, 0.2, 15.0]])


def _basilisk_mrp_feedback(R, w, R_d, w_d, dw_d, K, P, law_type):
    C = R.T @ R_d  # reference → body components
    w_r, dw_r = C @ w_d, C @ dw_d
    sigma = bsk.to_sigma_BN(R_d.T @ R, w)[0]  # σ_B/R: [BR] = [BN][RN]ᵀ = Rᵀ R_d
    dw = w - w_r
    v = w_r if law_type == 0 else w
    Lr = K * sigma + P * dw - np.cross(v, J @ w) + J @ (np.cross(w, w_r) - dw_r)
    return -Lr


@pytest.mark.parametrize(("feedforward", "law_type"), [("reference", 0), ("gyroscopic", 1)])
def test_mrp_pd_feedforward_reproduces_basilisk_mrp_feedback(feedforward: str, law_type: int):
    rng = np.random.default_rng(7)
    B = 8
    R = so3.random(rng, B)
    # errors below a half-turn, where σ needs no shadow switch on either side
    R_d = R @ so3.exp(rng.uniform(-0.6, 0.6, (B, 3)))
    w, w_d, dw_d = (rng.normal(size=(B, 3)) * s for s in (0.3, 0.1, 0.02))
    K, P = 2.5, 7.0
    c = MrpPD(J, K, P, feedforward=feedforward)
    c.reset(0.0, B)
    u = c.command(
        0.0, AttitudeState(R, w), AttitudeReference(R_d=R_d, omega_d=w_d, omega_dot_d=dw_d)
    )
    want = np.stack(
        [
            _basilisk_mrp_feedback(R[b], w[b], R_d[b], w_d[b], dw_d[b], K, P, law_type)
            for b in range(B)
        ]
    )
    np.testing.assert_allclose(u, want, atol=1e-10)


def test_mrp_pd_feedforward_none_and_regulation():
    rng = np.random.default_rng(8)
    R = so3.random(rng, 5)
    w = rng.normal(size=(5, 3)) * 0.3
    ref = AttitudeReference(R_d=np.eye(3), omega_d=np.zeros(3), omega_dot_d=np.zeros(3))
    out = {}
    for ff in ("gyroscopic", "reference", "none"):
        c = MrpPD(J, 2.0, 5.0, feedforward=ff)
        c.reset(0.0, 5)
        out[ff] = c.command(0.0, AttitudeState(R, w), ref)
    sigma = bsk.to_sigma_BN(R, w)[0]
    np.testing.assert_allclose(out["none"], -2.0 * sigma - 5.0 * w, atol=1e-12)
    # regulating (ω_r = 0), Basilisk's default law is the plain PD
    np.testing.assert_allclose(out["reference"], out["none"], atol=1e-12)
    np.testing.assert_allclose(out["gyroscopic"] - out["none"], np.cross(w, w @ J.T), atol=1e-12)
    with pytest.raises(ValueError, match=r"^feedforward: expected one of"):
        MrpPD(J, 2.0, 5.0, feedforward="full")
