"""Mutation check: plant one-line bugs, one at a time, and see whether the tests catch them.

Usage (from the repository root)::

    python tools/mutation_check.py              # every mutation, serial
    python tools/mutation_check.py --list       # list the mutations and exit
    python tools/mutation_check.py --only srukf-w0-sign metrics-rms-as-mean
    nice -n 10 python tools/mutation_check.py --jobs 2
    python tools/mutation_check.py --kernels    # the compiled kernels' planted bugs (issue 26)

The repository is copied once into a temporary directory (the working tree is never touched).
The relevant test files of every selected mutation are first run on the unmodified copy (the
*baseline*); tests that already fail there are listed and then deselected. Then, for each
mutation, one exact source line is replaced in a private copy and the mutation's test files run
with ``pytest -x`` in it (``PYTHONPATH`` set to it, so the copy's packages are imported, not
the installed ones). A mutation is **caught** when a test that passes on the baseline fails
(or the run errors where the baseline did not, or hits the time limit), **survived** when the
tests pass, and **stale** when its original line is no longer found exactly once (the source
moved on: update the table below).

Compiled kernels: every pytest run gets ``NUMBA_CACHE_DIR`` inside the run's temporary
directory (the developer's own cache is never read or written). The cache is keyed by a hash of
all kernel sources (``liecontrol._jit``), so a mutant of a kernel is compiled afresh together with
every kernel that calls it, while a mutant elsewhere reuses the baseline's machine code;
``--fresh-cache`` gives every mutant an empty cache of its own instead (slower: each one compiles
every kernel its tests call).

Exit code: 0 when every mutation was caught, 1 when one survived, 2 for stale entries. The
score is caught / (caught + survived).

Each entry is a realistic slip (sign, factor, transposition, wrong formula variant, wrong
distribution), not a syntax error; see ``MUTATIONS``. Add one when a test is added for a bug
that once got through.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutation:
    """Replace the exact text ``old`` (found once in ``path``) by ``new``; run ``tests``."""

    id: str
    path: str
    old: str
    new: str
    tests: tuple[str, ...]
    what: str


EST = ("tests/test_estimation_filters.py", "tests/test_estimation_core.py")
MET = ("tests/test_metrics.py", "tests/test_benchmarks_hand_checks.py")
PROPS = "tests/test_planted_bug_properties.py"
KT = "tests/test_kernels.py"
NUMPY_ROUTE = PROPS + "::test_batched_numpy_route_equals_the_kernel_route"
#: the mutations of the compiled kernels and the families added with them (``--kernels``)
KERNEL_IDS = (
    "sgcmg-rate-scan-skips-gimbal-0", "ideal-clip-flag-strict", "adaptive-regressor-index",
    "adaptive-kernel-regressor-index", "leader-follower-no-in-degree",
    "half-sinc-series-coefficient", "log-near-pi-threshold",
    "kernel-cache-per-file", "kernel-exp-half-angle", "kernel-log-near-pi-sign",
    "kernel-dexpinv-bracket-sign", "kernel-rigid-gyroscopic-sign", "kernel-large-angle-psi",
    "kernel-cmg-bus-torque-sign", "kernel-trace-error-component", "kernel-hdot-command-sign",
)

MUTATIONS: tuple[Mutation, ...] = (
    # ---- the six bugs that once survived the suite -----------------------------------------
    Mutation(
        "srukf-w0-sign", "liecontrol/estimation/srukf.py",
        "np.sqrt(abs(w0)) * dY[0], 1.0 if w0 > 0 else -1.0)",
        "np.sqrt(abs(w0)) * dY[0], 1.0)",
        EST, "negative zeroth covariance weight applied as an update, not a downdate",
    ),
    Mutation(
        "istsrukf-fading-mu", "liecontrol/estimation/istsrukf.py",
        "np.sqrt(mu)[:, None] * self._Sf", "mu[:, None] * self._Sf",
        EST, "fading applied as μ·S instead of √μ·S",
    ),
    Mutation(
        "farrenkopf-cross-sign", "liecontrol/estimation/models.py",
        "c = -(self.sigma_u**2) * dt**2 / 2.0", "c = (self.sigma_u**2) * dt**2 / 2.0",
        EST, "sign of the gyro noise cross term −σ_u² dt²/2 flipped",
    ),
    Mutation(
        "metrics-rms-as-mean", "benchmarks/metrics.py",
        "rms_rate = np.sqrt(trapezoid(rate**2, t) / T) if T > 0 else rate[0]",
        "rms_rate = trapezoid(rate, t) / T if T > 0 else rate[0]",
        MET, "RMS rate computed as the mean rate",
    ),
    Mutation(
        "reference-left-multiplied", "benchmarks/runner.py",
        "R_d = np.asarray(self.R_d0) @ so3.exp((float(t) - self.t0) * w)",
        "R_d = so3.exp((float(t) - self.t0) * w) @ np.asarray(self.R_d0)",
        ("tests/test_scenarios.py", "tests/test_benchmarks_hand_checks.py"),
        "constant-rate reference as exp(tω^) R_d0 instead of R_d0 exp(tω^)",
    ),
    Mutation(
        "montecarlo-not-haar", "benchmarks/montecarlo.py",
        "return scale, rng.normal(size=4), rng.normal(size=3)",
        "return scale, rng.uniform(-1.0, 1.0, size=4), rng.normal(size=3)",
        ("tests/test_benchmarks_hand_checks.py", "tests/test_montecarlo.py"),
        "Monte Carlo attitudes from normalised uniform-cube quaternions instead of Haar",
    ),
    # ---- the bugs of the compiled kernels and new families that once survived (issue 26) -----
    Mutation(
        "sgcmg-rate-scan-skips-gimbal-0", "spacecraft/_kernels.py",
        "    for i in range(dd_out.shape[0]):\n        peak = max(peak, abs(dd_out[i]))",
        "    for i in range(1, dd_out.shape[0]):\n        peak = max(peak, abs(dd_out[i]))",
        (PROPS + "::test_every_gimbal_stays_within_its_rate_limit_when_each_in_turn_is_fastest",),
        "SGCMG command kernel: gimbal 0 left out of the peak-rate scan",
    ),
    Mutation(
        "ideal-clip-flag-strict", "spacecraft/_kernels.py",
        "            at = abs(v) >= clip[i]", "            at = abs(v) > clip[i]",
        (PROPS + "::test_fused_loop_equals_python_loop_in_every_flag_for_every_actuator_and"
         "_controller",),
        "compiled loops' ideal-actuator saturation flag with > (never set at the clip)",
    ),
    Mutation(
        "adaptive-regressor-index", "liecontrol/control/adaptive.py",
        "    out[:, 5] = a2 * v1 + a1 * v2", "    out[:, 5] = a2 * v1 + a1 * v0",
        (PROPS + "::test_adaptive_inertia_update_is_minus_gamma_W_transpose_s_term_by_term",),
        "adaptive inertia update: wrong index in the regressor product Y(a)ᵀv",
    ),
    Mutation(
        "adaptive-kernel-regressor-index", "liecontrol/_kernels/adaptive.py",
        "    rate_th[5] = -g_th * ((x2 * c1 + x1 * c2) + (ar2 * s1 + ar1 * s2))",
        "    rate_th[5] = -g_th * ((x2 * c1 + x1 * c2) + (ar2 * s1 + ar1 * s0))",
        (PROPS + "::test_fused_loop_equals_python_loop_in_every_flag_for_every_actuator_and"
         "_controller",),
        "adaptive law's kernel: the same index slip in Y(a_r)ᵀs (fused loop only)",
    ),
    Mutation(
        "leader-follower-no-in-degree", "liecontrol/control/consensus.py",
        "        wn = wgt[keep] / d[i[keep]]", "        wn = wgt[keep]",
        (PROPS + "::test_leader_follower_law_on_graphs_with_in_degree_above_one",),
        "leader–follower weights not normalised by the in-degree",
    ),
    Mutation(
        "half-sinc-series-coefficient", "liecontrol/_kernels/attitude.py",
        "return 0.5 * (1.0 - t2 / 24.0 * (1.0 - t2 / 80.0))",
        "return 0.5 * (1.0 - t2 / 12.0 * (1.0 - t2 / 80.0))",
        (PROPS + "::test_half_sinc_and_large_angle_error_kernels_over_dense_angles",),
        "half_sinc kernel's small-angle series with θ²/12 (3.4e-8 relative at θ = 9e-4)",
    ),
    Mutation(
        "log-near-pi-threshold", "liecontrol/_kernels/so3.py",
        "LOG_SYMMETRIC_COS = -0.999\n", "LOG_SYMMETRIC_COS = -1.0 + 1e-10\n",
        (PROPS + "::test_log_and_exp_kernels_equal_numpy_over_dense_angles_near_0_and_pi",),
        "log kernel's symmetric-part branch only above cos θ = −1 + 1e-10 (6e-12 off near π)",
    ),
    Mutation(
        "kernel-cache-per-file", "liecontrol/_jit.py",
        "dispatcher._cache = _CACHE_CLASS(dispatcher.py_func)", "dispatcher.enable_caching()",
        ("tests/test_kernel_cache.py",),
        "numba's own per-file cache: an edited helper never reaches its cached callers",
    ),
    # ---- the compiled kernels themselves ------------------------------------------------------
    Mutation(
        "kernel-exp-half-angle", "liecontrol/_kernels/so3.py",
        "    b = 0.5 * q * q\n", "    b = q * q\n",
        (KT + "::test_exp_and_log_kernels_equal_the_numpy_api",),
        "exp kernel: Rodrigues' (1 − cos θ)/θ² without the ½",
    ),
    Mutation(
        "kernel-log-near-pi-sign", "liecontrol/_kernels/so3.py",
        "    sign = -1.0 if (c0 * v0 + c1 * v1 + c2 * v2) < 0.0 else 1.0",
        "    sign = 1.0",
        (PROPS + "::test_log_and_exp_kernels_equal_numpy_over_dense_angles_near_0_and_pi",),
        "log kernel near π: the axis's sign never taken from (R − Rᵀ)^∨",
    ),
    Mutation(
        "kernel-dexpinv-bracket-sign", "liecontrol/_kernels/so3.py",
        "        c * w0 + 0.5 * (t1 * w2 - t2 * w1) + t0 * tw,",
        "        c * w0 - 0.5 * (t1 * w2 - t2 * w1) + t0 * tw,",
        (KT + "::test_dexpinv_kernel_is_the_truncated_right_jacobian_inverse",),
        "RKMK4's dexp⁻¹ kernel with +½[θ, w] in one component",
    ),
    Mutation(
        "kernel-rigid-gyroscopic-sign", "spacecraft/_kernels.py",
        "    r0 = t0 - (w1 * j2 - w2 * j1)", "    r0 = t0 + (w1 * j2 - w2 * j1)",
        (KT + "::test_plant_step_kernel_equals_rkmk4_on_a_numpy_field",),
        "Euler's equation kernel with +ω × Jω in one component",
    ),
    Mutation(
        "kernel-large-angle-psi", "liecontrol/_kernels/attitude.py",
        "        psi = 4.0 * sq4 * sq4", "        psi = 2.0 * sq4 * sq4",
        (PROPS + "::test_half_sinc_and_large_angle_error_kernels_over_dense_angles",),
        "large-angle Ψ kernel as 2 sin²(θ/4) below π/2",
    ),
    Mutation(
        "kernel-cmg-bus-torque-sign", "spacecraft/_kernels.py",
        "        r0 += S0[0, i] * a - C0[0, i] * b", "        r0 += S0[0, i] * a + C0[0, i] * b",
        (KT + "::test_cmg_torque_and_command_kernels_equal_the_cluster_model",),
        "SGCMG bus-torque kernel: A δ̇ with the wrong sign of one −C0 sin δ term",
    ),
    Mutation(
        "kernel-trace-error-component", "liecontrol/_kernels/geometric_pd.py",
        "        e1 = 0.5 * (g02 - g20)", "        e1 = 0.5 * (g20 - g02)",
        (KT + "::test_geometric_pd_kernel_equals_the_law_in_numpy",),
        "geometric PD kernel: one component of the trace error's vee with the wrong sign",
    ),
    Mutation(
        "kernel-hdot-command-sign", "spacecraft/_kernels.py",
        "    q0 = -((w1 * h2 - w2 * h1) + u[0])", "    q0 = -((w1 * h2 - w2 * h1) - u[0])",
        (KT + "::test_cmg_torque_and_command_kernels_equal_the_cluster_model",),
        "SGCMG command kernel: ḣ_cmd with +u in one component",
    ),
    # ---- Lie groups, charts, errors ----------------------------------------------------------
    Mutation(
        "so3-hat-entry", "liecontrol/lie/so3.py",
        "    W[..., 0, 2] = y\n", "    W[..., 0, 2] = -y\n",
        ("tests/test_lie_groups.py", "tests/test_so3.py"), "one entry of the skew matrix",
    ),
    Mutation(
        "so3-exp-coefficient", "liecontrol/lie/so3.py",
        "    b *= 0.5  # (1 − cos θ)/θ²", "    b *= 0.25  # (1 − cos θ)/θ²",
        ("tests/test_lie_groups.py", "tests/test_so3.py"), "Rodrigues' second coefficient halved",
    ),
    Mutation(
        "so3-jr-inv-sign", "liecontrol/lie/so3.py",
        "return np.eye(3) + h[..., None, None] * N + d1[..., None, None] * (N @ N)",
        "return np.eye(3) - h[..., None, None] * N + d1[..., None, None] * (N @ N)",
        ("tests/test_lie_groups.py", "tests/test_so3.py"), "J_r⁻¹ with the left-Jacobian sign",
    ),
    Mutation(
        "quat-inverse-sign", "liecontrol/charts/quaternion.py",
        "np.array([1.0, -1.0, -1.0, -1.0]) / n) / n",
        "np.array([1.0, -1.0, -1.0, 1.0]) / n) / n",
        ("tests/test_charts.py",), "quaternion inverse conjugates only two components",
    ),
    Mutation(
        "mrp-kinematics-sign", "liecontrol/charts/mrp.py",
        "np.eye(3) + so3.hat(p) + p[..., :, None] * p[..., None, :])",
        "np.eye(3) - so3.hat(p) + p[..., :, None] * p[..., None, :])",
        ("tests/test_charts.py",), "MRP kinematics matrix with the wrong skew sign",
    ),
    Mutation(
        "errors-psi-half-angle", "liecontrol/errors.py",
        "Psi[big] = 2.0 - 2.0 * np.cos(0.5 * theta[big])",
        "Psi[big] = 2.0 - 2.0 * np.cos(theta[big])",
        ("tests/test_errors.py",), "large-angle error function without the half angle",
    ),
    Mutation(
        "errors-log-psi-half", "liecontrol/errors.py",
        'Psi = 0.5 * np.einsum("...i,...i->...", phi, phi)',
        'Psi = np.einsum("...i,...i->...", phi, phi)',
        ("tests/test_errors.py",), "log error function Ψ = ‖φ‖² instead of ½‖φ‖²",
    ),
    # ---- integrators ---------------------------------------------------------------------------
    Mutation(
        "rk4-weights", "liecontrol/integrators/rk.py",
        "return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)",
        "return y + (h / 6.0) * (k1 + 2.0 * k2 + k3 + k4)",
        ("tests/test_integrators.py",), "RK4 weights (1, 2, 1, 1)",
    ),
    Mutation(
        "rkmk4-stage4", "liecontrol/integrators/rk.py",
        "    th = h * k3\n", "    th = h2 * k3\n",
        ("tests/test_integrators.py",), "RKMK4 fourth stage evaluated at half the step",
    ),
    # ---- control ------------------------------------------------------------------------------
    Mutation(
        "geometric-pd-damping-sign", "liecontrol/control/geometric_pd.py",
        "M = ff - _apply_gain(self.k_R, e_R) - _apply_gain(self.k_Omega, e_W)",
        "M = ff - _apply_gain(self.k_R, e_R) + _apply_gain(self.k_Omega, e_W)",
        ("tests/test_geometric_pd.py", NUMPY_ROUTE),
        "damping term with the wrong sign (the numpy route: batches without numba)",
    ),
    Mutation(
        "geometric-pd-feedforward", "liecontrol/control/geometric_pd.py",
        "ff = _cross(w, Jw) - (_cross(w, w_d_body) - dw_d_body) @ J.T",
        "ff = _cross(w, Jw) - (_cross(w, w_d_body) + dw_d_body) @ J.T",
        ("tests/test_geometric_pd.py", NUMPY_ROUTE),
        "tracking feed-forward with the wrong ω̇_d sign (the numpy route: batches without numba)",
    ),
    Mutation(
        "adrc-eso-polynomial", "liecontrol/control/adrc.py",
        "k1 * a + k2 * b, k2 * a + k3 * b, k3 * a)",
        "k1 * a + k2 * b, k2 * b + k3 * a, k3 * a)",
        ("tests/test_adrc.py",), "ESO characteristic polynomial: α and β swapped in one term",
    ),
    # ---- plant, actuators, environment -------------------------------------------------------
    Mutation(
        "rigid-body-gyroscopic-sign", "spacecraft/rigid_body.py",
        "rhs = torque - _cross(omega, self._times(cols, omega))",
        "rhs = torque + _cross(omega, self._times(cols, omega))",
        ("tests/test_plant.py",), "Euler's equation with +ω × Jω",
    ),
    Mutation(
        "sgcmg-sin-half-angle", "spacecraft/actuators.py",
        "        t += t\n        np.divide(t, den, out=W[..., :4])",
        "        np.divide(t, den, out=W[..., :4])",
        ("tests/test_sgcmg.py", "tests/test_hot_paths.py"),
        "sin δ from tan(δ/2) without the factor 2",
    ),
    Mutation(
        "gravity-gradient-factor", "spacecraft/environment.py",
        "out = 3.0 * n * n * np.cross(c, Jc)",
        "out = 2.0 * n * n * np.cross(c, Jc)",
        ("tests/test_environment.py",), "gravity-gradient torque 2n² instead of 3n²",
    ),
    # ---- estimation ---------------------------------------------------------------------------
    Mutation(
        "ut-weight-wc0", "liecontrol/estimation/unscented.py",
        "Wc[0] = Wm[0] + 1.0 - alpha * alpha + beta",
        "Wc[0] = Wm[0] + 1.0 - alpha + beta",
        EST, "zeroth covariance weight with α instead of α²",
    ),
    Mutation(
        "mekf-joseph-noise", "liecontrol/estimation/mekf.py",
        "P = A @ self._P @ A.T + K @ Rk @ K.T", "P = A @ self._P @ A.T",
        EST, "Joseph update without the K R Kᵀ term",
    ),
    Mutation(
        "stukf-softening", "liecontrol/estimation/stukf.py",
        "N = V - params.softening * R - H @ Q @ H.T", "N = V - R - H @ Q @ H.T",
        EST, "strong-tracking N without the softening factor",
    ),
    # ---- benchmark metrics --------------------------------------------------------------------
    Mutation(
        "metrics-trapezoid-left", "benchmarks/metrics.py",
        "return np.sum(0.5 * (y[1:] + y[:-1]) * dt, axis=0)",
        "return np.sum(y[1:] * dt, axis=0)",
        MET, "right-rectangle rule instead of the trapezoid",
    ),
    Mutation(
        "metrics-settling-interp", "benchmarks/metrics.py",
        "frac = (e0 - threshold) / (e0 - e1)", "frac = (threshold - e1) / (e0 - e1)",
        MET, "settling-time interpolation from the wrong end",
    ),
    Mutation(
        "metrics-steady-window", "benchmarks/metrics.py",
        "t_steady = t[-1] - steady_fraction * T", "t_steady = t[0] + steady_fraction * T",
        MET, "steady-state window at the start of the run",
    ),
    Mutation(
        "metrics-error-angle-cos", "benchmarks/metrics.py",
        "c = 0.5 * (np.trace(E, axis1=-2, axis2=-1) - 1.0)",
        "c = 0.5 * (np.trace(E, axis1=-2, axis2=-1) + 1.0)",
        MET, "cos θ = (tr E + 1)/2",
    ),
    Mutation(
        "metrics-overshoot-pct", "benchmarks/metrics.py",
        "100.0 * overshoot / np.where(defined, theta0, 1.0)",
        "100.0 * overshoot / np.where(defined, theta0 * 180.0 / np.pi, 1.0)",
        MET, "overshoot percentage against θ₀ in degrees",
    ),
    Mutation(
        "metrics-effort-squared", "benchmarks/metrics.py",
        "effort_sq = trapezoid(u_norm**2, t)", "effort_sq = trapezoid(u_norm, t) ** 2",
        MET, "∫‖u‖²dt computed as (∫‖u‖dt)²",
    ),
    Mutation(
        "metrics-saturation-left-rectangle", "benchmarks/metrics.py",
        "return (f[:-1].astype(np.float64) * np.diff(t)[:, None]).sum(axis=0)",
        "return (f[1:].astype(np.float64) * np.diff(t)[:, None]).sum(axis=0)",
        MET, "saturation time counted with the right rectangle",
    ),
    Mutation(
        "metrics-peak-momentum-axis", "benchmarks/metrics.py",
        "peak_h = np.linalg.norm(h_act, axis=-1).max(axis=0)",
        "peak_h = np.abs(h_act).max(axis=(0, 2))",
        MET, "peak momentum as the largest component instead of the norm",
    ),
    # ---- Monte Carlo --------------------------------------------------------------------------
    Mutation(
        "montecarlo-rate-magnitude", "benchmarks/montecarlo.py",
        "omega0 = direction * (np.deg2rad(cfg.max_rate_deg_s) * frac)[:, None]",
        "omega0 = direction * (np.deg2rad(cfg.max_rate_deg_s) * np.sqrt(frac))[:, None]",
        ("tests/test_montecarlo.py", "tests/test_benchmarks_hand_checks.py"),
        "initial rate magnitude not uniform in [0, max]",
    ),
)


def _copy_repo(dest: Path) -> Path:
    ignore = shutil.ignore_patterns(
        ".git", "__pycache__", "*.pyc", ".pytest_cache", ".ruff_cache", "*.egg-info",
        "results", "figures", "gallery",
    )
    target = dest / "repo"
    shutil.copytree(ROOT, target, ignore=ignore)
    return target


def _pytest(
    repo: Path, tests: tuple[str, ...], timeout: float, cache: Path, extra: tuple[str, ...] = ()
) -> tuple[int, float, str, set[str]]:
    """Run pytest on ``tests`` in ``repo`` with the options ``extra`` and the compiled-kernel
    cache ``cache``: (exit code, seconds, first failure or the summary line, the set of failing
    test ids); exit code −1 on the time limit."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(repo) + os.pathsep + env.get("PYTHONPATH", "")
    env["NUMBA_CACHE_DIR"] = str(cache)
    env.setdefault("OMP_NUM_THREADS", "1")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    cmd = [sys.executable, "-m", "pytest", "-q", "-rfE", "-p", "no:cacheprovider",
           "--no-header", "-o", "addopts=", *extra, *tests]
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, cwd=repo, env=env, capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return -1, time.perf_counter() - t0, "timeout", set()
    lines = p.stdout.strip().splitlines() or [""]
    failed = [ln for ln in lines if ln.startswith(("FAILED ", "ERROR "))]
    ids = {ln.split(" ", 1)[1].split(" - ", 1)[0] for ln in failed}
    first = failed[0] if failed else lines[-1]
    return p.returncode, time.perf_counter() - t0, first[:160], ids


def _check_import_origin(repo: Path) -> None:
    """The copy's packages must shadow the installed (editable) ones."""
    env = dict(os.environ, PYTHONPATH=str(repo))
    out = subprocess.run(
        [sys.executable, "-c", "import liecontrol, spacecraft, benchmarks as b; "
         "print(liecontrol.__file__, spacecraft.__file__, b.__file__)"],
        cwd=repo, env=env, capture_output=True, text=True, check=True,
    ).stdout
    if any(not Path(p).resolve().is_relative_to(repo.resolve()) for p in out.split()):
        raise SystemExit(f"imports do not come from the copy: {out}")


def _run_one(
    m: Mutation, base: Path, timeout: float, known: set[str], base_rc: int, cache: Path | None
) -> tuple[str, float, str]:
    """Apply ``m`` in a private copy of the pristine copy ``base`` (so runs can overlap);
    ``known``: tests failing on the baseline (deselected), ``base_rc``: its exit code;
    ``cache``: the shared kernel cache, ``None`` for an empty one of the mutant's own.

    ``-x``: the first failure decides (without it, a mutation that breaks many property-based
    tests spends minutes in hypothesis shrinking)."""
    src = (base / m.path).read_text(encoding="utf-8")
    if src.count(m.old) != 1:
        return "stale", 0.0, f"original text found {src.count(m.old)} times"
    with tempfile.TemporaryDirectory(prefix=f"mut-{m.id}-") as d:
        repo = Path(d) / "repo"
        shutil.copytree(base, repo, ignore=shutil.ignore_patterns("__pycache__"))
        (repo / m.path).write_text(src.replace(m.old, m.new), encoding="utf-8")
        deselect = tuple(a for k in sorted(known) for a in ("--deselect", k))
        own = Path(d) / "numba-cache" if cache is None else cache
        rc, dt, tail, ids = _pytest(repo, m.tests, timeout, own, ("-x", *deselect))
    new = sorted(ids - known)
    if new:
        more = f" (+{len(new) - 1} more)" if len(new) > 1 else ""
        return "caught", dt, f"FAILED {new[0]}{more}"
    if rc == -1:
        return "caught (timeout)", dt, tail
    if rc not in (0, 1) and rc != base_rc:
        return f"caught (rc={rc})", dt, tail
    return "SURVIVED", dt, tail


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", metavar="ID", help="run only these mutations")
    ap.add_argument("--list", action="store_true", help="list the mutations and exit")
    ap.add_argument("--jobs", type=int, default=1, help="mutations run at the same time")
    ap.add_argument("--timeout", type=float, default=240.0,
                    help="per mutation run [s] (a hang counts as caught); the baseline gets 4×")
    ap.add_argument("--no-baseline", action="store_true",
                    help="skip the unmodified run (then any failure counts as caught)")
    ap.add_argument("--kernels", action="store_true",
                    help="only the mutations of the compiled kernels (KERNEL_IDS)")
    ap.add_argument("--fresh-cache", action="store_true",
                    help="an empty compiled-kernel cache for every mutant (default: one cache "
                    "for the run, keyed by the kernel sources)")
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error(f"--jobs: must be >= 1, got {args.jobs}")
    muts = list(MUTATIONS)
    if args.only:
        known = {m.id for m in MUTATIONS}
        unknown = sorted(set(args.only) - known)
        if unknown:
            ap.error(f"--only: unknown mutation ids {unknown}; see --list")
        muts = [m for m in muts if m.id in set(args.only)]
    if args.kernels:
        muts = [m for m in muts if m.id in KERNEL_IDS]
    if args.list:
        for m in muts:
            print(f"{m.id:36s} {m.path:40s} {m.what}")
        return 0

    with tempfile.TemporaryDirectory(prefix="mutation-check-") as tmp:
        base = _copy_repo(Path(tmp))
        _check_import_origin(base)
        shared = Path(tmp) / "numba-cache"
        known: set[str] = set()
        base_rc = 0
        if not args.no_baseline:
            tests = tuple(sorted({t for m in muts for t in m.tests}))
            base_rc, dt, tail, known = _pytest(base, tests, 4.0 * args.timeout, shared)
            print(f"baseline ({len(tests)} test files, {dt:.0f} s): {tail}")
            if base_rc == -1:
                print("baseline timed out: raise --timeout")
                return 2
            for k in sorted(known):
                print(f"  already failing, ignored: {k}")
        t0 = time.perf_counter()
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            results = list(
                pool.map(
                    lambda m: _run_one(
                        m, base, args.timeout, known, base_rc,
                        None if args.fresh_cache else shared,
                    ),
                    muts,
                )  # fmt: skip
            )
        for m, (status, dt, tail) in zip(muts, results, strict=True):
            print(f"{status:16s} {dt:6.1f} s  {m.id:36s} {m.what}")
            print(f"{'':26s}{m.path}: {tail}")
        caught = sum(r[0].startswith("caught") for r in results)
        survived = sum(r[0] == "SURVIVED" for r in results)
        stale = sum(r[0] == "stale" for r in results)
        total = caught + survived
        score = f"{caught}/{total} = {100.0 * caught / total:.0f} %" if total else "n/a"
        print(f"\nscore: {score} caught; {survived} survived, {stale} stale "
              f"({time.perf_counter() - t0:.0f} s)")
    if stale:
        return 2
    return 1 if survived else 0


if __name__ == "__main__":
    raise SystemExit(main())
