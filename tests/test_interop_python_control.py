"""python-control plants: the rigid body (liecontrol.interop.python_control) and the SGCMG
spacecraft (spacecraft.python_control). Exact linearisations against central finite differences
of the nonlinear vector fields and against ``control.linearize``; a short nonlinear response
against liecontrol's own integrator; bad input."""

from __future__ import annotations

import numpy as np
import pytest

control = pytest.importorskip("control", reason="python-control not installed (extra [interop])")

from scipy.integrate import solve_ivp  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from liecontrol.charts import mrp  # noqa: E402
from liecontrol.interop import python_control as pc  # noqa: E402
from spacecraft import SgcmgPyramid  # noqa: E402
from spacecraft import python_control as spc  # noqa: E402

J = np.array([[12.0, 0.5, -0.3], [0.5, 10.0, 0.2], [-0.3, 0.2, 15.0]])


def _hat(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _fd_jacobians(f, x0: np.ndarray, u0: np.ndarray, eps: float = 1e-6):
    """Central differences of x ↦ f(0, x, u) and u ↦ f(0, x, u)."""
    A = np.stack(
        [(f(0.0, x0 + e, u0) - f(0.0, x0 - e, u0)) / (2 * eps) for e in eps * np.eye(len(x0))],
        axis=-1,
    )
    B = np.stack(
        [(f(0.0, x0, u0 + e) - f(0.0, x0, u0 - e)) / (2 * eps) for e in eps * np.eye(len(u0))],
        axis=-1,
    )
    return A, B


@pytest.mark.parametrize("attitude", ["mrp", "quaternion"])
def test_rigid_body_linearisation_matches_finite_differences(attitude: str):
    R0 = Rotation.from_rotvec([0.4, -0.7, 1.1])  # a scipy Rotation is accepted
    sys = pc.rigid_body_attitude_system(J, attitude=attitude)
    x0 = pc.attitude_equilibrium(R0, attitude=attitude)
    u0 = np.zeros(3)
    np.testing.assert_allclose(sys.updfcn(0.0, x0, u0, None), 0.0, atol=1e-15)  # rest
    lin = pc.linearize_attitude(J, R0, attitude=attitude)
    A_fd, B_fd = _fd_jacobians(lambda t, x, u: sys.updfcn(t, x, u, None), x0, u0)
    np.testing.assert_allclose(lin.A, A_fd, atol=1e-8)
    np.testing.assert_allclose(lin.B, B_fd, atol=1e-8)
    ref = control.linearize(sys, x0, u0)
    np.testing.assert_allclose(lin.A, ref.A, atol=1e-6)
    np.testing.assert_allclose(lin.B, ref.B, atol=1e-6)
    assert lin.nstates == pc.ATTITUDE_CHARTS[attitude] and lin.ninputs == 3


def test_rigid_body_vector_field_off_equilibrium_matches_equations():
    sys = pc.rigid_body_attitude_system(J)
    rng = np.random.default_rng(0)
    s, w, u = rng.normal(size=3) * 0.3, rng.normal(size=3), rng.normal(size=3)
    dx = sys.updfcn(0.0, np.concatenate([s, w]), u, None)
    G = 0.25 * ((1 - s @ s) * np.eye(3) + 2 * _hat(s) + 2 * np.outer(s, s))
    np.testing.assert_allclose(dx[:3], G @ w, atol=1e-14)
    np.testing.assert_allclose(J @ dx[3:] + np.cross(w, J @ w), u, atol=1e-12)


def test_rigid_body_response_agrees_with_an_independent_integration():
    sys = pc.rigid_body_attitude_system(J)
    x0 = np.concatenate(
        [mrp.from_matrix(Rotation.from_rotvec([0.2, 0.1, -0.3])), [0.1, -0.2, 0.05]]
    )
    T = np.linspace(0.0, 2.0, 21)
    U = np.tile([[0.3], [-0.1], [0.2]], (1, T.size))
    resp = control.input_output_response(
        sys, T, U, x0, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12}
    )

    # the same equations through scipy's RK45 on R (rotation matrix) and ω: σ from R at the end
    def f(t, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        dR = R @ _hat(w)
        dw = np.linalg.solve(J, U[:, 0] - np.cross(w, J @ w))
        return np.concatenate([dR.ravel(), dw])

    R0 = mrp.to_matrix(x0[:3])
    sol = solve_ivp(f, (0.0, 2.0), np.concatenate([R0.ravel(), x0[3:]]), rtol=1e-11, atol=1e-12)
    R_end = sol.y[:9, -1].reshape(3, 3)
    np.testing.assert_allclose(resp.states[:3, -1], mrp.from_matrix(R_end), atol=1e-7)
    np.testing.assert_allclose(resp.states[3:, -1], sol.y[9:, -1], atol=1e-7)


@pytest.mark.parametrize("delta0", [[0.0, 0.0, 0.0, 0.0], [0.3, -0.2, 0.5, 1.0]])
def test_sgcmg_linearisation_matches_finite_differences(delta0):
    pyr = SgcmgPyramid(h0=50.0)
    Jb = np.diag([300.0, 350.0, 250.0])
    R0 = Rotation.from_euler("ZYX", [30.0, -20.0, 10.0], degrees=True)
    sys = spc.sgcmg_attitude_system(Jb, pyr)
    x0 = spc.sgcmg_equilibrium(delta0, R0)
    u0 = np.zeros(4)
    lin = spc.linearize_sgcmg(Jb, delta0, pyr, R0)
    A_fd, B_fd = _fd_jacobians(lambda t, x, u: sys.updfcn(t, x, u, None), x0, u0)
    np.testing.assert_allclose(lin.A, A_fd, atol=1e-7)
    np.testing.assert_allclose(lin.B, B_fd, atol=1e-7)
    ref = control.linearize(sys, x0, u0)
    np.testing.assert_allclose(lin.A, ref.A, atol=1e-5)
    np.testing.assert_allclose(lin.B, ref.B, atol=1e-5)
    # the stored momentum couples the body rates gyroscopically: ∂ω̇/∂ω = J⁻¹ h₀^
    h0 = pyr.momentum(np.asarray(delta0, dtype=float))
    np.testing.assert_allclose(
        lin.A[3:6, 3:6] @ np.ones(3), np.linalg.solve(Jb, np.cross(h0, np.ones(3))), atol=1e-12
    )


def test_sgcmg_momentum_exchange_conserves_inertial_momentum():
    """With gimbal-rate input only, the body + cluster momentum in body axes obeys
    d/dt(Jω + h) = −ω × (Jω + h): its norm is conserved along a nonlinear response."""
    pyr = SgcmgPyramid(h0=20.0)
    Jb = np.diag([300.0, 350.0, 250.0])
    sys = spc.sgcmg_attitude_system(Jb, pyr)
    x0 = spc.sgcmg_equilibrium([0.1, 0.2, -0.3, 0.4])
    x0[3:6] = [0.01, -0.02, 0.015]
    T = np.linspace(0.0, 5.0, 26)
    U = 0.1 * np.vstack([np.sin(T), np.cos(T), -np.sin(2 * T), np.ones_like(T)])
    resp = control.input_output_response(
        sys, T, U, x0, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12}
    )
    H = np.array([Jb @ x[3:6] + pyr.momentum(x[6:]) for x in resp.states.T])
    n = np.linalg.norm(H, axis=-1)
    np.testing.assert_allclose(n, n[0], rtol=1e-7)


def test_bad_input():
    with pytest.raises(ValueError, match=r"^attitude: expected one of"):
        pc.rigid_body_attitude_system(J, attitude="euler")
    with pytest.raises(ValueError, match=r"^J:"):
        pc.rigid_body_attitude_system(-J)
    with pytest.raises(ValueError, match=r"^R0: expected one rotation"):
        pc.attitude_equilibrium(Rotation.random(3, rng=0))
    with pytest.raises(ValueError, match=r"^R0: not orthonormal"):
        pc.linearize_attitude(J, 2 * np.eye(3))
    with pytest.raises(TypeError, match=r"^pyramid: expected SgcmgPyramid"):
        spc.sgcmg_attitude_system(J, pyramid="pyramid")
    with pytest.raises(ValueError, match=r"^delta0: expected shape"):
        spc.sgcmg_equilibrium([0.0, 0.0, 0.0])
