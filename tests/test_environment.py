"""Gravity-gradient torque (SPEC §5.3): formula, independent point-mass route, equilibria."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liecontrol.lie import so3
from spacecraft.disturbances import ConstantTorque, SumOfDisturbances
from spacecraft.environment import GravityGradientTorque
from spacecraft.orbit import CircularOrbit, two_body_acceleration

J_DIAG = np.array([520.0, 450.0, 660.0])
P = Rotation.from_euler("ZYX", [0.4, -0.3, 1.1]).as_matrix()
J_FULL = P @ np.diag(J_DIAG) @ P.T
ORBIT = CircularOrbit(n=0.0011, inclination=0.7, raan=0.2)


def _point_masses(J_diag, P, size=0.5):
    """Six point masses (pairs ±a_k along the principal axes P e_k) with inertia P diag(J) Pᵀ."""
    s = 0.5 * (J_diag.sum() - 2 * J_diag)  # second moments Σ m ρ_k² about each principal axis
    m = s / (2 * size**2)
    pos, mass = [], []
    for k in range(3):
        for sign in (1.0, -1.0):
            pos.append(sign * size * P[:, k])
            mass.append(m[k])
    return np.array(pos), np.array(mass)


def test_equals_formula_computed_independently():
    rng = np.random.default_rng(3)
    R = so3.random(rng, 5)
    t = 1234.5
    gg = GravityGradientTorque(J_FULL, ORBIT)
    T = gg(t, R, np.zeros((5, 3)))
    # ĉ from scipy, then 3n² ĉ × Jĉ by hand
    r = ORBIT.position(t)
    c = Rotation.from_matrix(R).inv().apply(-r / np.linalg.norm(r))
    expected = 3 * ORBIT.n**2 * np.cross(c, c @ J_FULL.T)
    np.testing.assert_allclose(T, expected, rtol=1e-12, atol=1e-18)


def test_matches_point_mass_sum_of_exact_gravity():
    """Independent route: Σ ρ_i × m_i Rᵀ a(r + Rρ_i) with the exact point-mass field."""
    rng = np.random.default_rng(4)
    R = so3.random(rng, 4)
    t = 500.0
    pos, mass = _point_masses(J_DIAG, P)
    r_c = ORBIT.position(t)
    rho_in = np.einsum("bij,kj->bki", R, pos)  # (B, 6, 3) inertial offsets
    a = two_body_acceleration(r_c + rho_in, ORBIT.mu)
    a_body = np.einsum("bji,bkj->bki", R, a)
    T_exact = np.sum(mass[None, :, None] * np.cross(pos[None], a_body), axis=1)
    T = GravityGradientTorque(J_FULL, ORBIT)(t, R, np.zeros((4, 3)))
    # the formula is the first term in (size / r); next terms are O(size/r) ~ 1e-7 relative
    np.testing.assert_allclose(T, T_exact, rtol=1e-5, atol=1e-6 * np.abs(T_exact).max())


def test_vanishes_for_principal_axis_nadir_aligned_body():
    gg = GravityGradientTorque(np.diag(J_DIAG), ORBIT)
    t = np.array([0.0, 900.0, 3000.0])
    C = ORBIT.lvlh_attitude(t)
    for tk, Ck in zip(t, C, strict=True):
        # body = LVLH, and body turned by half-turns/quarter-turns (nadir still on a principal axis)
        flips = np.stack([np.eye(3), np.diag([-1.0, -1.0, 1.0]), so3.exp([np.pi / 2, 0, 0])])
        T = gg(tk, Ck @ flips, np.zeros((3, 3)))
        np.testing.assert_allclose(T, 0.0, atol=1e-15)
    # a small pitch θ gives the linearised pitch torque −3n²(J_xx − J_zz)θ (Wie, Space Vehicle
    # Dynamics and Control, §6.3; x along track, z nadir): destabilising here, as J_zz > J_xx
    th = 1e-4
    R = C[0] @ so3.exp([0.0, th, 0.0])
    T = gg(0.0, R[None], np.zeros((1, 3)))[0]
    assert T[1] == pytest.approx(-3 * ORBIT.n**2 * (J_DIAG[0] - J_DIAG[2]) * th, rel=1e-3)
    np.testing.assert_allclose(T[[0, 2]], 0.0, atol=1e-15)


def test_function_form_equals_the_source_and_the_pitch_closed_form():
    """``gravity_gradient_torque(J, ĉ, n)`` (the function form) gives the disturbance source's
    torque for the same nadir vectors, and the linearised pitch torque −3n²(J_xx − J_zz)θ."""
    from spacecraft.environment import gravity_gradient_torque

    rng = np.random.default_rng(5)
    R = so3.random(rng, 4)
    t = 321.0
    r = ORBIT.position(t)
    c = np.einsum("bji,j->bi", R, -r / np.linalg.norm(r))
    T_src = GravityGradientTorque(J_FULL, ORBIT)(t, R, np.zeros((4, 3)))
    np.testing.assert_allclose(gravity_gradient_torque(J_FULL, c, ORBIT.n), T_src, rtol=1e-12,
                               atol=1e-18)
    th = 1e-4
    c_pitch = np.array([-np.sin(th), 0.0, np.cos(th)])  # nadir (z) seen after a pitch θ
    T = gravity_gradient_torque(np.diag(J_DIAG), c_pitch, ORBIT.n)
    assert T[1] == pytest.approx(-3 * ORBIT.n**2 * (J_DIAG[0] - J_DIAG[2]) * th, rel=1e-3)


def test_plugs_into_sum_of_disturbances():
    gg = GravityGradientTorque(J_FULL, ORBIT)
    d = SumOfDisturbances({"gg": gg, "bias": ConstantTorque([0.0, 0.1, 0.0])})
    R = so3.random(np.random.default_rng(0), 2)
    w = np.zeros((2, 3))
    comps = d.components(10.0, R, w)
    np.testing.assert_allclose(d(10.0, R, w), comps["gg"] + comps["bias"])
    assert comps["gg"].shape == (2, 3)


def test_bad_inputs():
    with pytest.raises(ValueError, match="^J:"):
        GravityGradientTorque(np.diag([1.0, 1.0, 3.0]), ORBIT)  # triangle inequality
    with pytest.raises(ValueError, match="^J:"):
        GravityGradientTorque(np.array([[1.0, 0.2, 0], [0, 1, 0], [0, 0, 1]]), ORBIT)
    with pytest.raises(ValueError, match="^orbit:"):
        GravityGradientTorque(np.eye(3), 0.0011)
    with pytest.raises(ValueError, match="^n:"):
        CircularOrbit(n=0.0)
