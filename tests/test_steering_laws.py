"""Local-gradient and singular-direction-avoidance steering, the pyramid's singular sets and the
singular-transit comparison (``spacecraft.steering``, ``benchmarks.singular_transit``).

Independent routes: central finite differences of the singularity measure (the gradient the
local-gradient law climbs), ``numpy.linalg.pinv`` (both laws away from singularities), the
second-order momentum change along null motions computed from ``SgcmgPyramid.momentum`` (the
elliptic / hyperbolic classification), and ``jacobian_singularity_measure`` (singular sets).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from benchmarks.runner import build_steering
from benchmarks.scenarios import STEERING_LAWS, SpacecraftSpec
from benchmarks.singular_transit import (
    PATHS,
    TRANSIT_LAWS,
    TransitPath,
    classify_singularity,
    run_comparison,
    singular_gimbal_angles,
    track_path,
    transit_table,
)
from spacecraft.sgcmg import SgcmgPyramid
from spacecraft.steering import (
    GeneralizedSingularityRobust,
    LocalGradient,
    PseudoInverse,
    PseudoInverseNullMotion,
    SingularDirectionAvoidance,
    SingularityRobust,
    jacobian_singularity_measure,
)

CL = SgcmgPyramid(h0=300.0)


def _all_laws() -> dict[str, object]:
    return {name: make(CL) for name, make in TRANSIT_LAWS.items()}


def _singular_sets() -> tuple[np.ndarray, np.ndarray]:
    """Gimbal sets ``(K, 4)`` of singular states for 7 directions u × all 16 sign patterns,
    and their singular directions ``(K, 3)``."""
    us = [
        (1.0, 0.0, 0.0),
        (0.0, 1.0, 0.0),
        (0.0, 0.0, 1.0),
        (1.0, 1.0, 1.0),
        (0.3, -0.8, 0.5),
        (-0.9, 0.2, 0.4),
        (0.96, -0.14, 0.24),
    ]
    deltas, dirs = [], []
    for u in us:
        uu = np.array(u) / np.linalg.norm(u)
        for signs in itertools.product((1.0, -1.0), repeat=4):
            deltas.append(singular_gimbal_angles(CL, uu, signs))
            dirs.append(uu)
    return np.array(deltas), np.array(dirs)


def _second_order_signs(d: np.ndarray, u: np.ndarray) -> set[int]:
    """Signs of u·(h(δ + εn) − h(δ)) over null directions n of A (exact kinematics, not the
    quadratic form): one sign ⇒ elliptic, both ⇒ hyperbolic."""
    _, _, Vt = np.linalg.svd(CL.jacobian(d) / CL.h0)
    N = Vt[2:].T
    eps = 1e-3
    out = set()
    for th in np.linspace(0.0, np.pi, 24, endpoint=False):
        n = N @ np.array([np.cos(th), np.sin(th)])
        dh = u @ (CL.momentum(d + eps * n) - CL.momentum(d)) / (CL.h0 * eps * eps)
        if abs(dh) > 1e-3:
            out.add(int(np.sign(dh)))
    return out


# ---------------------------------------------------------------------------- singular sets
def test_singular_gimbal_angles_are_singular_with_the_given_direction():
    deltas, dirs = _singular_sets()
    A = CL.jacobian(deltas)
    assert np.all(jacobian_singularity_measure(A) < 1e-7)
    # u is normal to every torque axis: Aᵀu = 0
    assert np.max(np.abs(np.einsum("kij,ki->kj", A, dirs))) < 1e-9 * CL.h0
    # all signs +1 is the momentum envelope: |h| is the largest of the 16 patterns
    h = np.linalg.norm(CL.momentum(deltas), axis=-1).reshape(7, 16)
    assert np.all(h[:, 0] >= h.max(axis=1) - 1e-9)


def test_classification_matches_the_second_order_momentum_change():
    deltas, dirs = _singular_sets()
    kinds = {"elliptic": 0, "hyperbolic": 0}
    for d, u in zip(deltas, dirs, strict=True):
        kind, ev, u_svd = classify_singularity(CL, d)
        if kind == "degenerate":
            continue
        assert abs(abs(u_svd @ u) - 1.0) < 1e-6
        signs = _second_order_signs(d, u)
        assert (len(signs) == 1) == (kind == "elliptic"), (np.rad2deg(d), ev, signs)
        kinds[kind] += 1
    assert kinds["elliptic"] > 10 and kinds["hyperbolic"] > 10
    # the envelope (all signs +1) is elliptic; the classic internal set (−90°, 0, 90°, 0) too
    assert classify_singularity(CL, singular_gimbal_angles(CL, (0, 0, 1), (1, 1, 1, 1)))[0] == (
        "elliptic"
    )
    assert classify_singularity(CL, np.deg2rad([-90.0, 0.0, 90.0, 0.0]))[0] == "elliptic"


# ---------------------------------------------------------------------------- every law
@pytest.mark.parametrize("name", list(TRANSIT_LAWS))
def test_every_law_is_finite_at_every_singular_set(name):
    law = _all_laws()[name]
    deltas, dirs = _singular_sets()
    A = CL.jacobian(deltas)
    rng = np.random.default_rng(14)
    for hdot in (dirs * 30.0, rng.normal(size=dirs.shape) * 30.0):  # along u, and generic
        batch = law(A, hdot, deltas, 0.7, CL)
        assert batch.shape == deltas.shape and np.all(np.isfinite(batch))
        for k in (0, 5, 17, 40, 77, 111):  # single spacecraft: the same numbers
            one = law(A[k], hdot[k], deltas[k], 0.7, CL)
            assert np.all(np.isfinite(one))
            np.testing.assert_allclose(one, batch[k], rtol=1e-6, atol=1e-9 * np.abs(one).max())


def _well_conditioned(m_min: float, count: int = 40) -> np.ndarray:
    rng = np.random.default_rng(7)
    d = rng.uniform(-np.pi, np.pi, size=(4000, 4))
    return d[CL.singularity_measure(d) > m_min][:count]


@pytest.mark.parametrize("name", list(TRANSIT_LAWS))
def test_every_law_realises_the_torque_away_from_singularities(name):
    law = _all_laws()[name]
    # PI and the null-motion laws are exact wherever m is not small; SR and GSR keep the
    # damping λ₀ exp(−μ m²) everywhere, below 1e-9 relative only once m ≳ 1.45 (m ≤ 1.54);
    # SDA is exact once the smallest normalised singular value is ≥ σ_t
    d = _well_conditioned(1.45 if name in ("sr", "gsr") else 0.3, 200)
    if name == "sda":
        d = d[np.linalg.svd(CL.jacobian(d) / CL.h0, compute_uv=False)[:, -1] >= law.sigma_t]
    assert len(d) >= 10
    A = CL.jacobian(d)
    hdot = np.random.default_rng(3).normal(size=(len(d), 3)) * 20.0
    dd = law(A, hdot, d, 0.3, CL)
    err = np.linalg.norm(np.einsum("kij,kj->ki", A, dd) - hdot, axis=-1)
    assert np.all(err <= 1e-9 * np.linalg.norm(hdot, axis=-1))


# ---------------------------------------------------------------------------- local gradient
def _fd_gradient(d: np.ndarray, h: float = 1e-6) -> np.ndarray:
    g = np.empty(4)
    for i in range(4):
        e = np.zeros(4)
        e[i] = h
        g[i] = (CL.singularity_measure(d + e) - CL.singularity_measure(d - e)) / (2 * h)
    return g


def test_local_gradient_null_motion_is_the_projected_fd_gradient():
    law = LocalGradient(m_target=1.5, tau=1.0, null_rate_max=1e6, cluster=CL)
    for d in _well_conditioned(0.2, 8):
        A = CL.jacobian(d)
        Ap = np.linalg.pinv(A)
        nu_fd = (np.eye(4) - Ap @ A) @ _fd_gradient(d)
        _, null = law.null_motion(A, d, CL)
        # step control: γ = (m* − m)/(τ |ν|²) when the rate cap does not bind
        m = float(CL.singularity_measure(d))
        expected = (1.5 - m) / (1.0 * (nu_fd @ nu_fd)) * nu_fd
        np.testing.assert_allclose(null, expected, rtol=1e-6)
        # torque-free, and climbs m at the requested rate (m* − m)/τ to first order
        assert np.linalg.norm(A @ null) < 1e-9 * CL.h0 * np.linalg.norm(null)
        s = 1e-6
        rate = (CL.singularity_measure(d + s * null) - CL.singularity_measure(d - s * null)) / (
            2 * s
        )
        assert rate == pytest.approx(1.5 - m, rel=1e-5)


def test_local_gradient_step_control_caps_and_stops():
    d = np.deg2rad([45.0, -45.0, 45.0, -45.0])  # m = 0.77
    A = CL.jacobian(d)
    capped = LocalGradient(m_target=1.5, tau=0.01, null_rate_max=0.05, cluster=CL)
    assert np.linalg.norm(capped.null_motion(A, d, CL)[1]) == pytest.approx(0.05, rel=1e-12)
    above = LocalGradient(m_target=0.5, cluster=CL)  # m > m*: no null motion at all
    assert np.all(above.null_motion(A, d, CL)[1] == 0.0)
    hdot = np.array([10.0, -20.0, 5.0])
    np.testing.assert_allclose(above(A, hdot, d), np.linalg.pinv(A) @ hdot, rtol=1e-9)


def test_local_gradient_raises_m_where_the_pseudo_inverse_does_not():
    """Pure null motion (ḣ = 0) from Wu et al.'s start climbs to the target."""
    law = LocalGradient(m_target=1.0, tau=1.0, null_rate_max=0.2, cluster=CL)
    d = np.deg2rad([45.0, -45.0, 45.0, -45.0])
    h0 = CL.momentum(d)
    for _ in range(400):
        d = d + 0.05 * law(CL.jacobian(d), np.zeros(3), d)
    assert float(CL.singularity_measure(d)) == pytest.approx(1.0, abs=0.02)
    assert np.linalg.norm(CL.momentum(d) - h0) < 1e-2 * CL.h0  # Euler drift only


# ---------------------------------------------------------------------------- SDA
def test_sda_is_the_pseudo_inverse_above_the_threshold_and_with_zero_damping():
    law = SingularDirectionAvoidance()
    d = _well_conditioned(0.6, 10)
    A = CL.jacobian(d)
    assert np.all(np.linalg.svd(A / CL.h0, compute_uv=False)[:, -1] >= law.sigma_t)
    h = np.random.default_rng(1).normal(size=(len(d), 3))
    np.testing.assert_allclose(
        law(A, h), np.einsum("kij,kj->ki", np.linalg.pinv(A), h), rtol=1e-9, atol=1e-15
    )
    # λ₀ = 0: the pseudo-inverse also near a singularity (m ≈ 0.05 on the sweep (θ, 0, −θ, 0))
    dn = np.deg2rad([-85.0, 0.0, 85.0, 0.0])
    An = CL.jacobian(dn)
    np.testing.assert_allclose(
        SingularDirectionAvoidance(lambda0=0.0)(An, h[0]), np.linalg.pinv(An) @ h[0], rtol=1e-8
    )


def test_sda_error_lies_along_the_singular_direction_only():
    law = SingularDirectionAvoidance(lambda0=0.01, sigma_t=0.3)
    d = np.deg2rad([-80.0, 3.0, 84.0, -2.0])  # near the internal set (−90°, 0, 90°, 0)
    A = CL.jacobian(d)
    U, S, _ = np.linalg.svd(A / CL.h0)
    assert S[-1] < 0.3
    hdot = np.array([12.0, -7.0, 30.0])
    err = A @ law(A, hdot) - hdot
    lam = 0.01 * (1.0 - S[-1] / 0.3) ** 2
    u3 = U[:, -1]
    np.testing.assert_allclose(err, -lam / (S[-1] ** 2 + lam) * (u3 @ hdot) * u3, atol=1e-9)
    # SR, by contrast, spreads its error over all three axes
    e_sr = A @ SingularityRobust()(A, hdot) - hdot
    assert np.linalg.norm(e_sr - (u3 @ e_sr) * u3) > 1e-6


# ---------------------------------------------------------------------------- registry, bad input
@pytest.mark.parametrize(
    "name, cls",
    [
        ("gsr", GeneralizedSingularityRobust),
        ("local-gradient", LocalGradient),
        ("sda", SingularDirectionAvoidance),
        ("pinv", PseudoInverse),
        ("pinv-null-motion", PseudoInverseNullMotion),
    ],
)
def test_registered_names_build_the_laws(name, cls):
    assert name in STEERING_LAWS
    law = build_steering(SpacecraftSpec(steering=name), CL)
    assert isinstance(law, cls)
    d = np.deg2rad([60.0, -60.0, 60.0, -60.0])
    assert np.all(np.isfinite(law(CL.jacobian(d), np.ones(3), d, 0.0, CL)))


@pytest.mark.parametrize(
    "make, arg",
    [
        (lambda: LocalGradient(m_target=0.0), "m_target"),
        (lambda: LocalGradient(tau=-1.0), "tau"),
        (lambda: LocalGradient(null_rate_max=float("nan")), "null_rate_max"),
        (lambda: LocalGradient(cluster="pyramid"), "cluster"),
        (lambda: SingularDirectionAvoidance(lambda0=-0.1), "lambda0"),
        (lambda: SingularDirectionAvoidance(sigma_t=0.0), "sigma_t"),
        (lambda: LocalGradient()(CL.jacobian(np.zeros(4)), np.ones(3), np.zeros(4)), "cluster"),
        (lambda: LocalGradient(cluster=CL)(CL.jacobian(np.zeros(4)), np.ones(3)), "delta"),
        (lambda: LocalGradient(cluster=CL)(np.zeros((3, 4)), np.ones(3), np.zeros(3)), "delta"),
        (lambda: SingularDirectionAvoidance()(np.zeros((2, 4)), np.ones(3)), "A"),
        (lambda: singular_gimbal_angles(CL, (0.0, 0.0, 0.0), (1, 1, 1, 1)), "u"),
        (lambda: singular_gimbal_angles(CL, (1.0, 0.0, 0.0), (1, 1, 0, 1)), "signs"),
        (lambda: singular_gimbal_angles(CL, CL.gimbal_axes()[:, 0], (1, 1, 1, 1)), "u"),
        (lambda: TransitPath("p", (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), "direction"),
        (lambda: TransitPath("p", (0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0), rate=0.0), "rate"),
        (lambda: track_path(PseudoInverse(), CL, PATHS[0], dt=0.0), "dt"),
        (lambda: run_comparison(laws=("nope",)), "laws"),
    ],
)
def test_bad_input_names_the_argument(make, arg):
    with pytest.raises((ValueError, TypeError)) as exc:
        make()
    assert str(exc.value).startswith(arg), str(exc.value)


def test_sda_does_not_mutate_and_handles_a_zero_jacobian():
    A = CL.jacobian(np.deg2rad([-90.0, 0.0, 90.0, 0.0]))
    A0, h = A.copy(), np.array([1.0, 2.0, 3.0])
    SingularDirectionAvoidance()(A, h)
    assert np.array_equal(A, A0)
    np.testing.assert_array_equal(SingularDirectionAvoidance()(np.zeros((3, 4)), h), 0.0)


# ---------------------------------------------------------------------------- comparison
def test_singular_transit_comparison_on_a_short_horizon():
    """The paths' singularity types, and on the hyperbolic path the null-motion laws pass where
    the pseudo-inverse loses torque (coarse step: the behaviour, not the table's numbers)."""
    short = tuple(p for p in PATHS if p.name in ("elliptic-x", "hyperbolic"))
    results, kinds = run_comparison(dt=0.04, laws=("pinv", "local-gradient", "sda"), paths=short)
    assert kinds == {"elliptic-x": "elliptic", "hyperbolic": "hyperbolic"}
    by = {(r.path, r.law): r for r in results}
    for r in results:
        assert np.all(np.isfinite(r.m)) and np.all(np.isfinite(r.torque_error))
        assert r.max_gimbal_rate <= CL.gimbal_rate_limit + 1e-12
    # elliptic with ḣ along the singular direction: no law here gets through without error
    assert by["elliptic-x", "pinv"].final_momentum_error > 0.2
    # hyperbolic: local gradient keeps m up and gets through; PI saturates near m ≈ 0
    lg, pi = by["hyperbolic", "local-gradient"], by["hyperbolic", "pinv"]
    assert lg.min_m > 0.1 and lg.max_torque_error < 0.1 and lg.final_momentum_error < 1e-3
    assert pi.min_m < 0.05 and pi.max_torque_error > 0.3
    table = transit_table(results, kinds)
    assert table.count("\n") == 2 + len(results) and "hyperbolic (hyperbolic)" in table
