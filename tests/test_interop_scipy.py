"""scipy interop: SO3/SE3 ⇄ scipy Rotation/RigidTransform, scipy's verbs on SO3 checked against
scipy itself, and scipy Rotation objects accepted wherever an attitude is."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import transform as sst
from scipy.spatial.transform import Rotation

from liecontrol.control.base import AttitudeState
from liecontrol.errors import attitude_error
from liecontrol.lie import SE3, SO3, se3, so3
from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft

HAS_RIGID = hasattr(sst, "RigidTransform")


def _rotations(rng: np.random.Generator) -> Rotation:
    """Random rotations plus the hard cases: identity, tiny angles, half-turns and near π."""
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    special = np.array(
        [np.zeros(3), 1e-12 * axis, 1e-7 * axis, np.pi * axis, (np.pi - 1e-9) * axis,
         np.pi * np.array([0.0, 0.0, 1.0]), np.pi * np.array([1.0, 0.0, 0.0])]
    )  # fmt: skip
    return Rotation.concatenate([Rotation.from_rotvec(special), Rotation.random(20, rng=rng)])


def _same_rotation(R1: np.ndarray, R2: np.ndarray, atol: float = 1e-12) -> None:
    np.testing.assert_allclose(R1, R2, atol=atol, rtol=0)


def test_from_scipy_as_scipy_round_trip_stacked_and_single():
    r = _rotations(np.random.default_rng(0))
    S = SO3.from_scipy(r)
    assert S.batch_shape == (len(r),)
    _same_rotation(S.R, r.as_matrix(), atol=0)
    back = S.as_scipy()
    assert isinstance(back, Rotation)
    # scipy stores a quaternion, so the matrix round trip is exact only to round-off
    _same_rotation(back.as_matrix(), r.as_matrix())
    one = SO3.from_scipy(r[3])
    assert one.batch_shape == ()
    assert one.as_scipy().single


def test_quat_verbs_match_scipy_with_scalar_first_stated():
    r = _rotations(np.random.default_rng(1))
    S = SO3.from_scipy(r)
    # ours: scalar-first by default; scipy: scalar-last by default
    np.testing.assert_allclose(S.as_quat(scalar_first=False), r.as_quat(canonical=True), atol=1e-12)
    np.testing.assert_allclose(
        S.as_quat(), r.as_quat(canonical=True, scalar_first=True), atol=1e-12
    )
    _same_rotation(SO3.from_quat(r.as_quat(), scalar_first=False).R, r.as_matrix())
    _same_rotation(SO3.from_quat(r.as_quat(scalar_first=True)).R, r.as_matrix())
    # non-unit quaternions are normalised, as scipy does
    _same_rotation(SO3.from_quat(3.0 * r.as_quat(), scalar_first=False).R, r.as_matrix())


@pytest.mark.parametrize("seq", ["ZYX", "XYZ", "ZXZ", "YXY", "xyz", "zyx", "zxz", "yzy"])
def test_euler_verbs_match_scipy(seq: str):
    r = Rotation.random(30, rng=np.random.default_rng(2))
    S = SO3.from_scipy(r)
    np.testing.assert_allclose(S.as_euler(seq), r.as_euler(seq), atol=1e-10)
    np.testing.assert_allclose(
        S.as_euler(seq, degrees=True), r.as_euler(seq, degrees=True), atol=1e-8
    )
    angles = r.as_euler(seq, degrees=True)
    _same_rotation(SO3.from_euler(seq, angles, degrees=True).R, r.as_matrix())


def test_rotvec_magnitude_inv_match_scipy_including_zero_and_pi():
    r = _rotations(np.random.default_rng(3))
    S = SO3.from_scipy(r)
    # at exactly π the rotation vector's sign is a convention: compare as rotations
    _same_rotation(so3.exp(S.as_rotvec()), r.as_matrix(), atol=1e-9)
    away = r.magnitude() < np.pi - 1e-6
    np.testing.assert_allclose(S.as_rotvec()[away], r.as_rotvec()[away], atol=1e-10)
    np.testing.assert_allclose(S.magnitude(), r.magnitude(), atol=1e-9)
    np.testing.assert_allclose(
        S.as_rotvec(degrees=True)[away], r.as_rotvec(degrees=True)[away], atol=1e-8
    )
    _same_rotation(SO3.from_rotvec(r.as_rotvec()).R, r.as_matrix())
    _same_rotation(SO3.from_rotvec(r.as_rotvec(degrees=True), degrees=True).R, r.as_matrix())
    _same_rotation(S.inv().R, r.inv().as_matrix())
    _same_rotation(SO3.from_matrix(r.as_matrix()).R, r.as_matrix(), atol=0)


def test_mean_matches_scipy_chordal_mean():
    rng = np.random.default_rng(4)
    base = Rotation.random(rng=rng)
    r = base * Rotation.from_rotvec(0.4 * rng.standard_normal((25, 3)))
    S = SO3.from_scipy(r)
    _same_rotation(S.mean().R, r.mean().as_matrix(), atol=1e-10)
    w = rng.uniform(0.1, 2.0, 25)
    _same_rotation(S.mean(w).R, r.mean(weights=w).as_matrix(), atol=1e-10)
    # a hand case: two rotations about z by ±a average to the identity
    two = SO3.from_rotvec([[0.0, 0.0, 0.3], [0.0, 0.0, -0.3]])
    _same_rotation(two.mean().R, np.eye(3))


def test_random_accepts_seed_generator_and_legacy_order():
    a = SO3.random(5, rng=7)
    b = SO3.random(5, rng=np.random.default_rng(7))
    assert a.batch_shape == (5,)
    np.testing.assert_array_equal(a.R, b.R)
    assert SO3.random().batch_shape == ()
    assert SO3.random(size=(2, 3), rng=1).batch_shape == (2, 3)
    legacy = SO3.random(np.random.default_rng(1), (2, 3))
    np.testing.assert_array_equal(legacy.R, so3.random(np.random.default_rng(1), (2, 3)))
    so3.validate(a.R)


@pytest.mark.skipif(not HAS_RIGID, reason="scipy < 1.16 has no RigidTransform")
def test_se3_rigid_transform_round_trip_and_twist_order():
    rng = np.random.default_rng(5)
    xi = np.concatenate([rng.uniform(-2, 2, (8, 3)), rng.uniform(-3, 3, (8, 3))], axis=-1)
    xi[0, :3] = [np.pi, 0.0, 0.0]  # a half-turn
    g = SE3.exp(xi)
    t = g.as_scipy()
    assert isinstance(t, sst.RigidTransform)
    np.testing.assert_allclose(t.as_matrix(), g.g, atol=1e-12)
    np.testing.assert_allclose(SE3.from_scipy(t).g, g.g, atol=1e-12)
    # scipy's exponential coordinates are (ω, v), like ours
    np.testing.assert_allclose(
        sst.RigidTransform.from_exp_coords(xi).as_matrix(), se3.exp(xi), atol=1e-12
    )
    np.testing.assert_allclose(g.inv().g, t.inv().as_matrix(), atol=1e-12)


def test_attitude_entry_points_accept_scipy_rotation():
    r = Rotation.from_rotvec([0.3, -0.2, 0.1])
    rs = Rotation.random(4, rng=np.random.default_rng(6))
    np.testing.assert_allclose(so3.log(r), [0.3, -0.2, 0.1], atol=1e-12)
    assert so3.log(rs).shape == (4, 3)
    _same_rotation(SO3(r).R, r.as_matrix(), atol=0)
    st = AttitudeState(R=rs, omega=np.zeros((4, 3)))
    _same_rotation(st.R, rs.as_matrix(), atol=0)
    for got, want in zip(
        attitude_error("log", rs, r),
        attitude_error("log", rs.as_matrix(), r.as_matrix()),
        strict=True,
    ):
        np.testing.assert_array_equal(got, want)
    plant = Spacecraft(RigidBody(np.diag([1.0, 2.0, 3.0])), IdealTorqueActuator())
    s0 = plant.initial_state(rs)
    _same_rotation(s0.R, rs.as_matrix(), atol=0)
    # our own SO3 objects are accepted the same way
    np.testing.assert_allclose(so3.log(SO3(r)), [0.3, -0.2, 0.1], atol=1e-12)


def test_rotation_of_the_wrong_length_names_the_argument():
    plant = Spacecraft(RigidBody(np.diag([1.0, 2.0, 3.0])), IdealTorqueActuator())
    with pytest.raises(ValueError, match=r"^omega: batch shape \(5,\) does not match"):
        AttitudeState(R=Rotation.random(3, rng=1), omega=np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"^(R0|omega0)"):
        plant.initial_state(Rotation.random(3, rng=1), omega0=np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"^w: got a Rotation object where an array of numbers"):
        so3.exp(Rotation.random(rng=1))  # a Rotation where a vector belongs
    with pytest.raises(ValueError, match=r"^weights: expected shape \(4,\)"):
        SO3.random(4, rng=0).mean(np.ones(3))


def test_bad_input_messages():
    with pytest.raises(TypeError, match=r"^rotation: expected scipy"):
        SO3.from_scipy(np.eye(3))
    with pytest.raises(TypeError, match=r"^rng: expected"):
        SO3.random(2, rng=1.5)
    with pytest.raises(ValueError, match=r"^num: must be >= 0"):
        SO3.random(-1)
    with pytest.raises(ValueError, match=r"^q: zero quaternion"):
        SO3.from_quat([0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^seq:"):
        SO3.from_euler("ZZX", [0.1, 0.2, 0.3])
    with pytest.raises(TypeError, match=r"^degrees:"):
        SO3.identity().as_euler("ZYX", degrees="yes")
    with pytest.raises(ValueError, match=r"^self: mean needs a stack"):
        SO3.identity().mean()
    with pytest.raises(ValueError, match=r"^weights: must not all be zero"):
        SO3.random(3, rng=0).mean(np.zeros(3))
    with pytest.raises(ValueError, match=r"^R: not orthonormal"):
        SO3.from_matrix(np.diag([1.0, 1.0, 1.1]))
    if HAS_RIGID:
        with pytest.raises(TypeError, match=r"^transform: expected scipy"):
            SE3.from_scipy(Rotation.identity())


def test_inputs_are_not_mutated():
    q = np.array([[0.5, 0.5, 0.5, 0.5], [2.0, 0.0, 0.0, 0.0]])
    q0 = q.copy()
    SO3.from_quat(q)
    np.testing.assert_array_equal(q, q0)
    w = np.array([1.0, 2.0, 3.0])
    SO3.random(3, rng=0).mean(w)
    np.testing.assert_array_equal(w, [1.0, 2.0, 3.0])
