"""Regenerate the small PNG figures of the documentation pages into ``docs/figures/``::

    python docs/make_figures.py [--only NAME[,NAME...]] [--out DIR]

Each figure comes from a short simulation or a direct evaluation (the whole script runs in well
under two minutes on one core) and is saved at 90 dpi. Names (and the page that shows them):

- ``geometric_pd_179.png`` (controllers.md): trace / log / large-angle PD on a 179° slew.
- ``pid_ppc.png`` (controllers_pid_ppc.md): PID vs PD under a constant disturbance; the
  prescribed-performance error inside its funnel.
- ``mpc_torque.png`` (mpc.md): a 90° MPC manoeuvre, torque within its box bounds.
- ``so3_log_near_pi.png`` (lie.md): round-trip error of exp/log up to θ = π.
- ``mrp_shadow.png`` (charts.md): |p| of a continuous rotation with and without shadow switch.
- ``lgvi_energy.png`` (integrators.md): energy drift of the LGVI vs RKMK4 and classical RK4.
- ``error_functions.png`` (errors.md): Ψ and ‖e_R‖ against the rotation angle.
- ``cmg_singularity_sweep.png`` (cmg.md): singularity measure over gimbal sweeps.
- ``cmg_singular_transit.png`` (cmg.md): m and torque error of every steering law along the
  singular-transit paths (``benchmarks.singular_transit``).
- ``se3_docking.png`` (se3.md): SE(3) proximity approach, errors and trajectory.
- ``lemmas_regions.png``, ``lemmas_lyapunov.png`` (survey_lemmas.md): the survey-lemmas reproduction
  (``geometric-survey-lemmas``, reduced sample count).
- ``planned_slew.png`` (modes.md): the jerk-limited eigenaxis profile, the geometric PD on the
  step vs the planned 90° slew, Wie & Lu's rate-limited law on a 150° slew.
- ``detumble.png`` (modes.md): B-dot and cross-product detumbling of a 3U CubeSat at two
  inclinations against the averaged dynamics.
- ``sun_acquisition.png`` (modes.md): safe-mode Sun acquisition from 20 tumbling starts
  through an eclipse (``benchmarks.safe_mode``): Sun angle and body rate against time.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time
from collections.abc import Callable

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

DPI = 90
FIG_DIR = pathlib.Path(__file__).resolve().parent / "figures"
J_BUS = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])


def _save(fig: plt.Figure, out: pathlib.Path, name: str) -> pathlib.Path:
    fig.tight_layout()
    path = out / name
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def geometric_pd_179(out: pathlib.Path) -> pathlib.Path:
    """The three error functions with one linear design (matrix gains ∝ J) on the SGCMG-bus
    inertia, ideal torques, 179° rest-to-rest slew about a fixed axis."""
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from liecontrol.lie import so3
    from spacecraft import IdealTorqueActuator, RigidBody, Spacecraft, simulate

    plant = Spacecraft(RigidBody(J_BUS), IdealTorqueActuator())
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    x0 = plant.initial_state(so3.exp(np.deg2rad(179.0) * axis))
    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    for kind in ("trace", "log", "large_angle"):
        k_R, k_W = gains_from_bandwidth(J_BUS, 0.03, 0.9, error=kind, matrix=True)
        ctrl = GeometricPD(J_BUS, k_R, k_W, error=kind)
        res = simulate(plant, ctrl, ConstantAttitude(np.eye(3)), x0, 700.0, 0.5, log_every=4)
        err = np.rad2deg(res.attitude_error_angle()[:, 0])
        axes[0].plot(res.t, err, label=kind)
        axes[1].semilogy(res.t, np.maximum(err, 1e-6), label=kind)
    axes[0].set_ylabel("attitude error [deg]")
    axes[1].set_ylabel("attitude error [deg] (log)")
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(
        "Geometric PD, 179° slew, SGCMG-bus inertia, ω_n = 0.03 rad/s, ζ = 0.9", fontsize=9
    )
    return _save(fig, out, "geometric_pd_179.png")


def pid_ppc(out: pathlib.Path) -> pathlib.Path:
    """PID vs PD under a constant 0.05 N·m disturbance, and PPC from 150° inside its funnel."""
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
    from liecontrol.control.geometric_pid import IntrinsicPID, integral_gain
    from liecontrol.control.prescribed_performance import PrescribedPerformance, ppc_gains
    from liecontrol.lie import so3
    from spacecraft import ConstantTorque, IdealTorqueActuator, RigidBody, Spacecraft, simulate

    J = np.diag([10.0, 12.0, 8.0])
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator(), ConstantTorque([0.0, 0.05, 0.0]))
    k_R, k_W = gains_from_bandwidth(J, 0.5, 0.9, error="log", matrix=True)
    pd = GeometricPD(J, k_R, k_W, error="log")
    pid = IntrinsicPID(J, k_R, k_W, integral_gain(k_R, 0.1), integral_limit=1.0)
    x0 = plant.initial_state(so3.exp(np.deg2rad(30.0) * np.array([1.0, 0.0, 0.0])))
    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    for c, name in ((pd, "PD"), (pid, "intrinsic PID")):
        res = simulate(
            plant, c, ConstantAttitude(np.eye(3)), x0, t_final=80.0, dt=0.05, log_every=4
        )
        axes[0].semilogy(res.t, np.rad2deg(res.attitude_error_angle()[:, 0]), label=name)
    axes[0].set_xlabel("t [s]")
    axes[0].set_ylabel("attitude error [deg]")
    axes[0].set_title("constant 0.05 N m disturbance", fontsize=8)
    axes[0].legend(fontsize=8)
    k1, k2, kc = ppc_gains(0.5, 0.9)
    ppc = PrescribedPerformance(J, rho_inf=0.01, decay=0.3, k1=k1, k2=k2, kc=kc)
    x0 = plant.initial_state(so3.exp(np.deg2rad(150.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14)))
    res = simulate(plant, ppc, ConstantAttitude(np.eye(3)), x0, t_final=30.0, dt=0.02, log_every=2)
    rho = res.controller["rho"][:, 0]
    e = res.controller["e_R"][:, 0]
    axes[1].fill_between(res.t, -rho, rho, color="0.85", label="funnel ±ρ(t)")
    for i in range(3):
        axes[1].plot(res.t, e[:, i], lw=1.0, label=f"e_R,{i + 1}")
    axes[1].set_xlabel("t [s]")
    axes[1].set_title("prescribed performance from 150°", fontsize=8)
    axes[1].legend(fontsize=7, ncol=2)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    return _save(fig, out, "pid_ppc.png")


def mpc_torque(out: pathlib.Path) -> pathlib.Path:
    """The mpc.md example: 90° rest-to-rest with |u_i| ≤ 20 N·m (LGVI plant, 1 s steps)."""
    from liecontrol.control import AttitudeReference, AttitudeState
    from liecontrol.control.mpc import SO3MPC
    from liecontrol.integrators import lgvi_step
    from liecontrol.lie import so3

    J = J_BUS
    u_max = 20.0
    mpc = SO3MPC(J, horizon=20, dt=1.0, Q=[200.0] * 3 + [2e5] * 3, R=[1.0] * 3, u_max=u_max)
    mpc.reset(0.0, 1)
    ref = AttitudeReference.regulation(np.eye(3))
    R = so3.exp(np.deg2rad(90.0) * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    w = np.zeros(3)
    n = 300
    U, err = np.zeros((n, 3)), np.zeros(n)
    for k in range(n):
        u = mpc.command(float(k), AttitudeState(R[None], w[None]), ref)[0]
        U[k], err[k] = u, np.rad2deg(so3.angle(R))
        R, Pi = lgvi_step(R, J @ w, u, u, 1.0, J)
        w = np.linalg.solve(J, Pi)
    t = np.arange(n, dtype=float)
    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    for i in range(3):
        axes[0].step(t, U[:, i], where="post", lw=1.0, label=f"u_{'xyz'[i]}")
    axes[0].axhline(u_max, color="k", ls="--", lw=0.8)
    axes[0].axhline(-u_max, color="k", ls="--", lw=0.8, label="bounds")
    axes[0].set_ylabel("torque [N m]")
    axes[0].legend(fontsize=7, ncol=2)
    axes[1].semilogy(t, np.maximum(err, 1e-6))
    axes[1].set_ylabel("attitude error [deg]")
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("SO(3) MPC (OSQP), 90° manoeuvre, N = 20, box torque |u_i| ≤ 20 N m", fontsize=9)
    return _save(fig, out, "mpc_torque.png")


def so3_log_near_pi(out: pathlib.Path) -> pathlib.Path:
    """max ‖log(exp(θn)) − θn‖ over random axes, θ approaching π (π − θ from 1 down to 1e-12)."""
    from liecontrol.lie import so3

    rng = np.random.default_rng(0)
    n = rng.standard_normal((200, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    gaps = np.logspace(0, -12, 49)
    err = []
    for g in gaps:
        w = (np.pi - g) * n
        err.append(np.abs(so3.log(so3.exp(w)) - w).max())
    fig, ax = plt.subplots(figsize=(5, 3))
    ax.loglog(gaps, err, "o-", ms=3)
    ax.invert_xaxis()
    ax.set_xlabel("π − θ [rad]")
    ax.set_ylabel("max |log(exp(θn)) − θn|")
    ax.set_title("so3.log accuracy near θ = π (200 random axes)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    return _save(fig, out, "so3_log_near_pi.png")


def mrp_shadow(out: pathlib.Path) -> pathlib.Path:
    """A constant rotation rate for 1.9 turns: MRP kinematics integrated (RK4) with and without the
    shadow-set switch at |p| = 1."""
    from liecontrol.charts import mrp

    omega = np.array([0.0, 0.0, 1.0])
    h, n = 0.005, int(round(1.9 * 2 * np.pi / 0.005))
    free, switched = np.zeros(3), np.zeros(3)
    nf, ns = [], []

    def rk4(p: np.ndarray) -> np.ndarray:
        k1 = mrp.kinematics(p, omega)
        k2 = mrp.kinematics(p + 0.5 * h * k1, omega)
        k3 = mrp.kinematics(p + 0.5 * h * k2, omega)
        k4 = mrp.kinematics(p + h * k3, omega)
        return p + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    for _ in range(n):
        nf.append(np.linalg.norm(free))
        ns.append(np.linalg.norm(switched))
        if np.linalg.norm(free) < 50.0:  # the unswitched chart blows up at 360°
            free = rk4(free)
        switched, _ = mrp.switch(rk4(switched))
    angle = np.rad2deg(np.arange(n) * h)
    nf = np.where(np.array(nf) < 50.0, nf, np.nan)
    fig, ax = plt.subplots(figsize=(5.5, 3))
    ax.semilogy(angle, nf, label="no switch: |p| = tan(θ/4) → ∞ at 360°")
    ax.semilogy(angle, ns, label="shadow switch at |p| = 1")
    ax.set_xlabel("rotation angle θ [deg]")
    ax.set_ylabel("|p|")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title("MRP along a constant-rate rotation", fontsize=9)
    return _save(fig, out, "mrp_shadow.png")


def lgvi_energy(out: pathlib.Path) -> pathlib.Path:
    """Free rigid body near the intermediate axis (tumbling), h = 0.05 s for 1000 s: relative
    kinetic-energy error of the LGVI, RKMK4 and classical RK4."""
    from liecontrol.integrators import RigidBodyLGVI, integrate

    J = np.diag([1.0, 2.0, 3.0])
    Jinv = np.linalg.inv(J)

    def rigid_body(t, R, x):  # noqa: ANN001, ANN202 - integrator callback
        return x, -np.cross(x, x @ J) @ Jinv

    R0 = np.eye(3)[None]
    w0 = np.array([[0.05, 1.0, 0.05]])
    h, n = 0.05, 20000
    E0 = 0.5 * float(w0[0] @ J @ w0[0])
    fig, ax = plt.subplots(figsize=(5.5, 3))
    lg = RigidBodyLGVI(J).integrate(R0, w0, h=h, n_steps=n, save_every=20)
    E = 0.5 * np.einsum("kbi,ij,kbj->kb", lg.omega, J, lg.omega)[:, 0]
    ax.semilogy(lg.t, np.maximum(np.abs(E / E0 - 1.0), 1e-17), lw=0.8, label="LGVI")
    for method, label in (("rkmk4", "RKMK4"), ("rk4", "classical RK4")):
        tr = integrate(rigid_body, 0.0, R0, w0, h=h, n_steps=n, method=method, save_every=20)
        E = 0.5 * np.einsum("kbi,ij,kbj->kb", tr.x, J, tr.x)[:, 0]
        ax.semilogy(tr.t, np.maximum(np.abs(E / E0 - 1.0), 1e-17), lw=0.8, label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|E(t)/E(0) − 1|")
    ax.set_title(f"free rigid body, h = {h} s (ω(0) near the intermediate axis)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    return _save(fig, out, "lgvi_energy.png")


def error_functions(out: pathlib.Path) -> pathlib.Path:
    """Ψ and ‖e_R‖ of the three error functions against the angle of R̃ (trace: about each
    eigenvector of G and about (1, 1, 1))."""
    from liecontrol import errors
    from liecontrol.lie import so3

    theta = np.linspace(0.0, np.pi, 361)
    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    axes_list = [
        ("large_angle", np.array([0.0, 0.0, 1.0]), "large-angle"),
        ("log", np.array([0.0, 0.0, 1.0]), "log"),
        ("trace", np.array([1.0, 0.0, 0.0]), "trace, axis e1 (g = 0.9)"),
        ("trace", np.array([0.0, 0.0, 1.0]), "trace, axis e3 (g = 1.1)"),
    ]
    for kind, n, label in axes_list:
        R = so3.exp(theta[:, None] * n)
        Psi, e_R = errors.attitude_error(kind, R, np.eye(3))
        axes[0].plot(np.rad2deg(theta), Psi, label=label)
        axes[1].plot(np.rad2deg(theta), np.linalg.norm(e_R, axis=-1), label=label)
    axes[0].set_ylabel("Ψ")
    axes[1].set_ylabel("‖e_R‖")
    for ax in axes:
        ax.set_xlabel("rotation angle of R_dᵀR [deg]")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("Error functions (trace: G = diag(0.9, 1, 1.1))", fontsize=9)
    return _save(fig, out, "error_functions.png")


def cmg_singularity_sweep(out: pathlib.Path) -> pathlib.Path:
    """The cmg.md sweeps: m over δ₁ (others at the zero-momentum start (45°, −45°, 45°, −45°))
    and over δ = (θ, 0, −θ, 0)."""
    from spacecraft.sgcmg import SgcmgPyramid

    cmg = SgcmgPyramid(h0=300.0)
    theta = np.linspace(-np.pi, np.pi, 721)
    sweep1 = np.tile(np.deg2rad([45.0, -45.0, 45.0, -45.0]), (theta.size, 1))
    sweep1[:, 0] = theta
    sweep2 = np.stack([theta, 0 * theta, -theta, 0 * theta], axis=-1)
    fig, ax = plt.subplots(figsize=(5.5, 3))
    ax.plot(np.rad2deg(theta), cmg.singularity_measure(sweep1), label="δ = (θ, −45°, 45°, −45°)")
    ax.plot(np.rad2deg(theta), cmg.singularity_measure(sweep2), label="δ = (θ, 0, −θ, 0)")
    ax.set_xlabel("θ [deg]")
    ax.set_ylabel("singularity measure m")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    ax.set_title("4-SGCMG pyramid, β = 54.73°", fontsize=9)
    return _save(fig, out, "cmg_singularity_sweep.png")


def cmg_singular_transit(out: pathlib.Path) -> pathlib.Path:
    """The cmg.md singular-transit comparison (benchmarks.singular_transit): m and torque error
    along the elliptic and hyperbolic paths for every steering law."""
    from benchmarks.singular_transit import plot_comparison, run_comparison

    results, _ = run_comparison()
    return plot_comparison(results, out, "cmg_singular_transit.png")


def se3_docking(out: pathlib.Path) -> pathlib.Path:
    """The se3.md example: chaser from 150° / ~100 m to a docking pose 5 m behind a target in a
    circular orbit (SE3TrackingController, RKMK4 dt = 1 s)."""
    from liecontrol.control.se3_control import SE3TrackingController, pose_gains_from_bandwidth
    from liecontrol.lie import se3, so3
    from spacecraft.orbit import CircularOrbit
    from spacecraft.se3_plant import DockingReference, OrbitingTarget, SE3Plant, simulate_pose

    m, J = 500.0, np.diag([300.0, 400.0, 350.0])
    plant = SE3Plant(m, J, method="rkmk4")
    target = OrbitingTarget(CircularOrbit(n=0.0011))
    g_rel = se3.from_rt(so3.exp(np.array([0.0, 0.0, np.pi])), np.array([-5.0, 0.0, 0.0]))
    dock = DockingReference(target, g_rel)
    ctrl = SE3TrackingController(
        m,
        J,
        gravity=plant.gravity_wrench,
        **pose_gains_from_bandwidth(m, J, omega_att=0.1, omega_pos=0.05),
    )
    g0, xi0 = dock.offset_state(
        0.0, np.deg2rad([[150.0, 0.0, 0.0]]), np.array([[60.0, -50.0, 58.0]])
    )
    res = simulate_pose(plant, ctrl, dock, g0, xi0, t_final=300.0, dt=1.0, control_period=1.0)
    # chaser position in the target's (LVLH) frame
    rel = np.array(
        [se3.inverse(target.pose(t)) @ g for t, g in zip(res.t, res.g[:, 0], strict=True)]
    )
    fig, axes = plt.subplots(1, 2, figsize=(8, 3))
    axes[0].semilogy(
        res.t, np.rad2deg(np.maximum(res.attitude_error[:, 0], 1e-12)), label="attitude error [deg]"
    )
    axes[0].semilogy(res.t, np.maximum(res.position_error[:, 0], 1e-12), label="position error [m]")
    axes[0].set_xlabel("t [s]")
    axes[0].legend(fontsize=7)
    axes[1].plot(rel[:, 0, 3], rel[:, 2, 3], label="chaser")
    axes[1].plot([-5.0], [0.0], "k*", ms=9, label="docking point")
    axes[1].plot([0.0], [0.0], "ks", ms=6, label="target")
    axes[1].set_xlabel("x_LVLH (along track) [m]")
    axes[1].set_ylabel("z_LVLH (nadir) [m]")
    axes[1].legend(fontsize=7)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(
        "SE(3) proximity approach (Jiang, Meng & Yang 2023, eqs. 15–16 tracking)", fontsize=9
    )
    return _save(fig, out, "se3_docking.png")


def survey_lemmas_figures(out: pathlib.Path) -> list[pathlib.Path]:
    """The survey-lemmas reproduction's figures from the reduced (quick) sample count."""
    from benchmarks.reproductions import geometric_survey_lemmas as lemmas

    result = lemmas.run(quick=True)
    return lemmas._figures(result, out)


def planned_slew(out: pathlib.Path) -> pathlib.Path:
    """The 90° slew of ``slew-90`` on the SGCMG bus: the jerk-limited eigenaxis profile
    (``slew-90-planned``'s limits), the geometric PD (large-angle, common tuning) flying the step
    and the planned profile, and Wie & Lu's rate-limited law on a 150° slew."""
    from benchmarks.runner import build_plant
    from benchmarks.scenarios import PLANNED_SLEW_LIMITS, SGCMG_SPACECRAFT, SLEW_AXIS
    from liecontrol.control import ConstantAttitude
    from liecontrol.control.eigenaxis import RateLimitedEigenaxis, wie_lu_gains
    from liecontrol.control.geometric_pd import GeometricPD
    from liecontrol.control.slew_profile import EigenaxisSlewProfile
    from liecontrol.control.tuning import ClosedLoopSpec, tune_geometric_pd
    from liecontrol.lie import so3
    from spacecraft import simulate

    plant, J = build_plant(SGCMG_SPACECRAFT), SGCMG_SPACECRAFT.J
    axis = np.array(SLEW_AXIS)
    R0 = so3.exp(np.pi / 2 * axis)
    prof = EigenaxisSlewProfile(R0, np.eye(3), **PLANNED_SLEW_LIMITS)
    fig, axes = plt.subplots(1, 3, figsize=(11, 3))
    t = np.linspace(0.0, prof.slew_time + 10.0, 1200)
    S = np.array([prof.angle_at(x) for x in t])
    lim = PLANNED_SLEW_LIMITS
    for k, (lab, scale) in enumerate(
        (
            ("s/θ", 1 / prof.angle),
            ("ṡ/max_rate", 1 / lim["max_rate"]),
            ("s̈/max_accel", 1 / lim["max_accel"]),
            ("s⃛/max_jerk", 1 / lim["max_jerk"]),
        )
    ):
        axes[0].plot(t, S[:, k] * scale, label=lab, lw=1.2 if k < 3 else 0.8)
    axes[0].set_title(f"profile: 90°, T = {prof.slew_time:.1f} s", fontsize=9)
    axes[0].legend(fontsize=7)
    gains = tune_geometric_pd(J, ClosedLoopSpec(0.03, 0.9, 0.2), error="large_angle")
    for name, ref in (("step", ConstantAttitude(np.eye(3))), ("planned", prof)):
        res = simulate(
            plant,
            GeometricPD(J, **gains),
            ref,
            plant.initial_state(R0),
            350.0,
            0.1,
            control_period=0.2,
            log_every=5,
        )
        to_target = np.rad2deg(np.linalg.norm(so3.log(res.R[:, 0]), axis=-1))
        track = np.rad2deg(res.attitude_error_angle()[:, 0])
        axes[1].semilogy(res.t, np.maximum(to_target, 1e-6), label=f"{name}: to target")
        if name == "planned":
            axes[1].semilogy(res.t, np.maximum(track, 1e-6), "--", label="planned: to R_d(t)")
    axes[1].axhline(0.1, color="k", lw=0.6)
    axes[1].set_title("geometric PD, error [deg]", fontsize=9)
    axes[1].legend(fontsize=7)
    c = RateLimitedEigenaxis(J, max_rate=0.02, **wie_lu_gains(0.03, 0.9))
    res = simulate(
        plant,
        c,
        ConstantAttitude(np.eye(3)),
        plant.initial_state(so3.exp(np.deg2rad(150.0) * axis)),
        400.0,
        0.1,
        control_period=0.2,
        log_every=5,
    )
    axes[2].plot(res.t, np.rad2deg(np.linalg.norm(res.omega[:, 0], axis=1)), label="‖ω‖")
    axes[2].axhline(np.rad2deg(0.02), color="k", ls="--", lw=0.8, label="max_rate")
    axes[2].set_title("Wie & Lu, 150° slew: body rate [deg/s]", fontsize=9)
    axes[2].legend(fontsize=7)
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.grid(True, which="both", alpha=0.3)
    return _save(fig, out, "planned_slew.png")


def detumble(out: pathlib.Path) -> pathlib.Path:
    """Detumbling a 3U CubeSat from a separation tumble with B-dot and the cross-product law
    (k = 5e-5 N·m·s, 80 % duty cycle) at two inclinations, against the averaged dynamics."""
    import math

    from spacecraft.detumble import (
        DetumbleLaw,
        Magnetometer,
        separation_tumble,
        simulate_detumble,
    )
    from spacecraft.geomagnetic import TiltedDipoleField
    from spacecraft.orbit import CircularOrbit

    J = np.diag([0.0419, 0.0419, 0.0067])
    w0 = separation_tumble(1, (5.0, 10.0), seed=1)
    k, d, thr = 5e-5, 0.8, math.radians(1.0)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3), sharey=True)
    lam, V = np.linalg.eigh(J)
    c = V.T @ w0[0]
    for ax, inc in zip(axes, (97.5, 51.6), strict=True):
        orbit = CircularOrbit.from_altitude(530e3, inclination=math.radians(inc))
        tt = np.linspace(0.0, orbit.period, 400)
        B2 = float(np.mean(np.sum(TiltedDipoleField().inertial(tt, orbit.position(tt)) ** 2, -1)))
        for law in ("bdot", "cross-product"):
            gain = k if law == "cross-product" else k / B2
            res = simulate_detumble(
                J,
                DetumbleLaw(gain, m_max=0.2, law=law, period=2.0, duty_cycle=d),
                w0,
                6000.0,
                threshold=thr,
                orbit=orbit,
                magnetometer=Magnetometer(1e-7, (2e-7, -1e-7, 3e-7)),
                dt=1.0,
            )
            ax.plot(res.t, np.rad2deg(np.linalg.norm(res.omega[:, 0], axis=1)), label=law, lw=0.9)
        t = np.linspace(0.0, 6000.0, 300)
        avg = np.linalg.norm(c[None] * np.exp(-(2 / 3) * d * k * t[:, None] / lam), axis=1)
        ax.plot(t, np.rad2deg(avg), "k--", lw=1, label="averaged (2/3)dk/J")
        ax.axhline(1.0, color="grey", lw=0.6)
        ax.set_title(f"530 km, i = {inc}°", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("‖ω‖ [deg/s]")
    axes[0].legend(fontsize=7)
    return _save(fig, out, "detumble.png")


def sun_acquisition(out: pathlib.Path) -> pathlib.Path:
    """Safe-mode Sun acquisition from 20 seeded tumbling starts, coarse Sun sensors and a gyro,
    through the eclipse (``benchmarks.safe_mode``, rate damping only in the shadow)."""
    from benchmarks.safe_mode import sun_acquisition_run

    r = sun_acquisition_run(20, seed=0)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3), sharex=True)
    for ax in axes:
        ax.axvspan(r.eclipse_entry_s, r.eclipse_exit_s, color="0.85", lw=0, label="eclipse")
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("t [s]")
    axes[0].plot(r.t, r.sun_angle_deg, lw=0.6)
    axes[0].axhline(r.tol_deg, color="k", ls="--", lw=0.8, label=f"{r.tol_deg:g}°")
    axes[0].set_yscale("log")
    axes[0].set_ylim(0.1, 180.0)
    axes[0].set_ylabel("Sun angle of +z [deg]")
    axes[0].legend(fontsize=7, loc="upper right")
    axes[1].plot(r.t, r.rate_deg_s, lw=0.6)
    axes[1].set_yscale("log")
    axes[1].set_ylabel("‖ω‖ [deg/s]")
    return _save(fig, out, "sun_acquisition.png")


FIGURES: dict[str, Callable[[pathlib.Path], object]] = {
    "geometric_pd_179": geometric_pd_179,
    "pid_ppc": pid_ppc,
    "mpc_torque": mpc_torque,
    "so3_log_near_pi": so3_log_near_pi,
    "mrp_shadow": mrp_shadow,
    "lgvi_energy": lgvi_energy,
    "error_functions": error_functions,
    "cmg_singularity_sweep": cmg_singularity_sweep,
    "cmg_singular_transit": cmg_singular_transit,
    "se3_docking": se3_docking,
    "survey_lemmas": survey_lemmas_figures,
    "planned_slew": planned_slew,
    "detumble": detumble,
    "sun_acquisition": sun_acquisition,
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=None, help="comma-separated figure names")
    ap.add_argument("--out", type=pathlib.Path, default=FIG_DIR)
    a = ap.parse_args(argv)
    names = list(FIGURES) if a.only is None else a.only.split(",")
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        ap.error(f"unknown figure(s) {unknown}; choose from {list(FIGURES)}")
    a.out.mkdir(parents=True, exist_ok=True)
    for name in names:
        t0 = time.perf_counter()
        paths = FIGURES[name](a.out)
        for p in paths if isinstance(paths, list) else [paths]:
            size = pathlib.Path(p).stat().st_size / 1024
            print(f"{name}: {p} ({size:.0f} kB, {time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
