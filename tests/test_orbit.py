"""Circular orbit, LVLH frame, Earth-pointing reference, two-body/J2 gravity (SPEC §5.3, §5.6)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from liecontrol.control.base import AttitudeReference
from liecontrol.lie import so3
from spacecraft.orbit import (
    MU_EARTH,
    CircularOrbit,
    EarthPointingReference,
    gravity_acceleration,
    gravity_potential,
    j2_acceleration,
    j2_potential,
    two_body_acceleration,
    two_body_potential,
)

ORBITS = [
    CircularOrbit(),
    CircularOrbit(n=0.00113, inclination=0.9, raan=-0.4, arg_lat0=2.0),
]


def test_kepler_relation_and_from_radius():
    o = CircularOrbit(n=0.0011)
    assert o.n == pytest.approx(np.sqrt(MU_EARTH / o.radius**3), rel=1e-14)
    o2 = CircularOrbit.from_radius(7.0e6)
    assert o2.radius == pytest.approx(7.0e6, rel=1e-13)
    assert o2.period == pytest.approx(2 * np.pi * np.sqrt(7.0e6**3 / MU_EARTH), rel=1e-13)


@pytest.mark.parametrize("orbit", ORBITS)
def test_position_velocity_consistent(orbit):
    t = np.array([0.0, 123.4, 4000.0])
    r, v = orbit.position(t), orbit.velocity(t)
    np.testing.assert_allclose(np.linalg.norm(r, axis=-1), orbit.radius, rtol=1e-14)
    h = 1e-2
    fd = (orbit.position(t + h) - orbit.position(t - h)) / (2 * h)
    np.testing.assert_allclose(fd, v, rtol=1e-8, atol=1e-6)
    # on a circular orbit gravity is the centripetal acceleration −n² r
    np.testing.assert_allclose(two_body_acceleration(r, orbit.mu), -(orbit.n**2) * r, rtol=1e-12)


@pytest.mark.parametrize("orbit", ORBITS)
def test_lvlh_orthonormal_axes_and_rate(orbit):
    t = np.linspace(0.0, 6000.0, 7)
    C = orbit.lvlh_attitude(t)
    assert C.shape == (7, 3, 3)
    np.testing.assert_allclose(
        np.swapaxes(C, -1, -2) @ C, np.broadcast_to(np.eye(3), C.shape), atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-14)
    r, v = orbit.position(t), orbit.velocity(t)
    np.testing.assert_allclose(C[..., :, 2], -r / orbit.radius, atol=1e-14)  # z to nadir
    np.testing.assert_allclose(C[..., :, 1], -np.broadcast_to(orbit.normal, r.shape), atol=1e-14)
    np.testing.assert_allclose(C[..., :, 0], v / np.linalg.norm(v, axis=-1)[..., None], atol=1e-14)
    # rotation rate from the group: log(C(t)ᵀ C(t + dt))/dt = (0, −n, 0), exactly for constant rate
    dt = 10.0
    w = so3.log(np.swapaxes(C, -1, -2) @ orbit.lvlh_attitude(t + dt)) / dt
    np.testing.assert_allclose(w, np.broadcast_to([0.0, -orbit.n, 0.0], w.shape), atol=1e-15)
    assert orbit.lvlh_attitude(5.0).shape == (3, 3)


def test_nadir_in_body():
    orbit = ORBITS[1]
    rng = np.random.default_rng(1)
    R = so3.random(rng, 4)
    c = orbit.nadir_in_body(R, 50.0)
    expected = Rotation.from_matrix(R).inv().apply(-orbit.position(50.0) / orbit.radius)
    np.testing.assert_allclose(c, expected, atol=1e-14)
    # a body aligned with LVLH sees nadir along +z
    np.testing.assert_allclose(
        orbit.nadir_in_body(orbit.lvlh_attitude(50.0)[None], 50.0), [[0, 0, 1]], atol=1e-14
    )


@pytest.mark.parametrize("orbit", ORBITS)
def test_earth_pointing_reference_consistent(orbit):
    O = Rotation.from_euler("ZYX", [0.3, -0.2, 0.5]).as_matrix()
    ref = EarthPointingReference(orbit, offset=O)
    t, h = 321.0, 0.5
    out = ref(t)
    assert isinstance(out, AttitudeReference)
    Rm, R0, Rp = ref(t - h).R_d, out.R_d, ref(t + h).R_d
    # ω_d^ = R_dᵀ Ṙ_d (central differences, error O(h² n³))
    W = R0.T @ (Rp - Rm) / (2 * h)
    np.testing.assert_allclose(so3.vee(0.5 * (W - W.T)), out.omega_d, atol=1e-10)
    np.testing.assert_allclose(out.omega_d, O.T @ [0.0, -orbit.n, 0.0], atol=1e-16)
    # ω̇_d from finite differences of ω_d(t) (recovered on the group)
    w_p = so3.log(Rp.T @ ref(t + 2 * h).R_d) / h
    w_m = so3.log(Rm.T @ R0) / h
    np.testing.assert_allclose((w_p - w_m) / (2 * h), out.omega_dot_d, atol=1e-12)
    # identity offset: desired body = LVLH
    np.testing.assert_allclose(EarthPointingReference(orbit)(t).R_d, orbit.lvlh_attitude(t))


def _fd_grad(U, r, h):
    g = np.zeros_like(r)
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        g[..., i] = (U(r + e) - U(r - e)) / (2 * h)
    return g


@settings(max_examples=25, deadline=None)
@given(
    st.floats(6.6e6, 4.2e7),
    st.floats(-np.pi / 2, np.pi / 2),
    st.floats(-np.pi, np.pi),
)
def test_accelerations_are_minus_gradients(rad, lat, lon):
    r = rad * np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    h = rad * 1e-5
    a0 = two_body_acceleration(r)
    np.testing.assert_allclose(
        a0, -_fd_grad(two_body_potential, r, h), rtol=1e-8, atol=1e-9 * np.abs(a0).max()
    )
    a2 = j2_acceleration(r)
    np.testing.assert_allclose(
        a2, -_fd_grad(j2_potential, r, h), rtol=1e-6, atol=1e-8 * np.abs(a2).max()
    )
    tot = gravity_acceleration(r, J2=1.08263e-3)
    np.testing.assert_allclose(tot, a0 + a2, rtol=1e-15)


def test_j2_known_values():
    # equator (z = 0): a₂ = −(3/2) μ J2 R_e²/r⁴ r̂ (stronger pull over the equatorial bulge)
    r = 7.0e6
    a = j2_acceleration([r, 0.0, 0.0])
    assert a[0] == pytest.approx(-1.5 * MU_EARTH * 1.08263e-3 * 6378137.0**2 / r**4, rel=1e-13)
    # pole: 1 − ... → a_z = −(3/2)μJ2Re²/r⁴ · (3 − 5) = +3μJ2Re²/r⁴ (weaker pull over the pole)
    a = j2_acceleration([0.0, 0.0, r])
    assert a[2] == pytest.approx(3.0 * MU_EARTH * 1.08263e-3 * 6378137.0**2 / r**4, rel=1e-13)


def test_energy_conserved_with_j2():
    # integrate an inclined, eccentric orbit: E = v²/2 + U₀ + U₂ is a constant of motion
    J2 = 1.08263e-3

    def f(t, y):
        return np.concatenate((y[3:], gravity_acceleration(y[:3], J2=J2)))

    r0 = np.array([7.0e6, 0.0, 0.0])
    v0 = np.array([0.0, 6.5e3, 3.5e3])
    sol = solve_ivp(f, (0.0, 6000.0), np.concatenate((r0, v0)), rtol=1e-11, atol=1e-6)
    Y = sol.y.T
    E = 0.5 * np.sum(Y[:, 3:] ** 2, axis=1) + gravity_potential(Y[:, :3], J2=J2)
    assert np.ptp(E) / abs(E[0]) < 1e-8
    # the J2 term matters: dropping it from the energy breaks conservation by far more
    E0 = 0.5 * np.sum(Y[:, 3:] ** 2, axis=1) + gravity_potential(Y[:, :3])
    assert np.ptp(E0) / abs(E0[0]) > 1e-5


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"n": 0.0}, "n"),
        ({"n": -1e-3}, "n"),
        ({"n": np.nan}, "n"),
        ({"mu": -1.0}, "mu"),
        ({"inclination": np.inf}, "inclination"),
    ],
)
def test_bad_orbit(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        CircularOrbit(**kwargs)


def test_bad_inputs():
    with pytest.raises(ValueError, match="^radius:"):
        CircularOrbit.from_radius(-7e6)
    with pytest.raises(ValueError, match="^r:"):
        two_body_acceleration([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="^r:"):
        j2_acceleration([1.0, 2.0])
    with pytest.raises(ValueError, match="^offset:"):
        EarthPointingReference(CircularOrbit(), offset=2 * np.eye(3))
    with pytest.raises(ValueError, match="^R:"):
        CircularOrbit().nadir_in_body(np.eye(2), 0.0)
