"""The manifold UKF hook in the compiled closed loop (liecontrol._kernels.ukf through
spacecraft._fused_sensors).

- the kernels alone against :class:`liecontrol.estimation.ManifoldUKF` on the gyro model: a
  predict/update sequence with a gated measurement agrees to 1e-12 (state, covariance, NIS, gate
  decisions); a covariance that is not positive definite is reported (code 2 / False) where the
  numpy filter repairs it;
- the benchmarks' UKF hook (:class:`benchmarks.runner.FilteredAttitude`, ``estimator="ukf"``)
  between a star tracker with latency, scheduled and random outages and a biased gyro, on the
  SGCMG pyramid, over a batch of 3 with non-zero initial rates: the fused loop equals the Python
  loop (states, torques, estimates, the NEES/NIS/gate log, the filters' final state and the
  generator's) — the χ² gate rejects at least one measurement in that run;
- compiled weights under which the covariance loses definiteness: the compiled run stops and
  the run is repeated in the Python loop, with the Python loop's result.

Tolerances: 1e-12 as the MEKF hook's tests (tests/test_fused_sensors.py) for the states,
torques, estimates, sensor logs and errors; the kernels equal the numpy filter's arithmetic
with its sums taken in index order (bit for bit, checked by hand), but numpy's BLAS sums the
weighted means and covariances in another order, and the UKF's covariance is a weighted sum of
products of ⊟ differences of nearby quaternions (rotations of ~1e-4 rad from O(1)
components), so a last-bit difference is a ~1e-12 relative difference of those differences,
which the filter carries from step to step. The covariance is therefore compared relative to
√(Pᵢᵢ Pⱼⱼ) (1e-10), NEES and NIS (quadratic forms in its inverse) to 1e-10 relative, the
state to 1e-12 relative and 1e-14 absolute. The loop's run below has filters far from
consistent (NEES ~1e4, many gated updates: the same in both loops), which magnifies this.
"""

from __future__ import annotations

import copy
import dataclasses
import logging

import numpy as np
import pytest
from test_fused_sensors import _assert_same, _case, _fused, _python_loop

from liecontrol._jit import JIT_ENABLED
from liecontrol.estimation import GyroAttitudeModel, ManifoldUKF
from spacecraft import simulator as simulator_module
from spacecraft.simulator import simulate

pytestmark = pytest.mark.skipif(not JIT_ENABLED, reason="the fused loop needs numba")


def _cov_close(a: np.ndarray, b: np.ndarray, tol: float = 1e-10) -> None:
    """|a − b| ≤ tol √(bᵢᵢ bⱼⱼ) entry by entry (a correlation-scaled comparison)."""
    d = np.sqrt(np.abs(np.einsum("...ii->...i", b)))
    scale = d[..., :, None] * d[..., None, :]
    assert np.all(np.abs(a - b) <= tol * scale), np.max(np.abs(a - b) / scale)


# ---------------------------------------------------------------- the kernels alone
def _model_and_filter(seed: int = 1):
    rng = np.random.default_rng(seed)
    Sigma = np.diag([1e-8, 4e-8, 2e-9]) + 1e-14 * np.eye(3)
    m = GyroAttitudeModel(
        sigma_v=1e-5, sigma_u=1e-6, sigma_z=np.full(3, np.sqrt(Sigma.max())), sigma_body=Sigma
    )
    P0 = np.zeros((6, 6))
    P0[:3, :3] = Sigma
    P0[3:, 3:] = 1e-6 * np.eye(3)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return rng, m, Sigma, P0, q


def test_kernels_equal_the_numpy_manifold_ukf(caplog):
    from liecontrol._kernels import mekf as MK
    from liecontrol._kernels import ukf as UK

    rng, m, Sigma, P0, q = _model_and_filter()
    f = ManifoldUKF(m, np.r_[q, 0.0, 0.0, 0.0], P0)
    w = f.weights
    x, P = np.empty(7), np.empty((6, 6))
    assert MK.mekf_gyro_init(q.copy(), P0, x, P)
    np.testing.assert_array_equal(x, f.x)
    np.testing.assert_array_equal(P, f.P)
    codes = []
    with caplog.at_level(logging.WARNING, logger="liecontrol.estimation"):
        for k in range(120):
            u = np.array([0.01, -0.02, 0.005]) + 1e-4 * rng.normal(size=3)
            f.predict(u, 0.2)
            assert UK.ukf_gyro_predict(x, P, u, 0.2, m.sigma_v, m.sigma_u, w.gamma, w.Wm, w.Wc)
            if k % 2 == 0:
                z = m.h(f.x[None])[0] + 1e-4 * rng.normal(size=3)
                if k == 50:
                    z = z + 0.05  # an outlier: the gate rejects it
                accepted = f.update(z)
                code, nis = UK.ukf_gyro_update(
                    x, P, z, Sigma, f.gate_threshold, True, w.gamma, w.Wm, w.Wc
                )
                codes.append(code)
                assert code == (0 if accepted else 1)
                np.testing.assert_allclose(nis, f.diagnostics["nis"], rtol=1e-9)
            np.testing.assert_allclose(x, f.x, rtol=1e-12, atol=1e-15)
            _cov_close(P, f.P)
    assert 1 in codes and not f.diagnostics["repaired"]
    # a covariance that is not positive definite: the kernels report it (no repair)
    P_bad = P.copy()
    P_bad[0, 0] = -1e-9
    assert not UK.ukf_gyro_predict(x, P_bad, u, 0.2, m.sigma_v, m.sigma_u, w.gamma, w.Wm, w.Wc)
    code, nis = UK.ukf_gyro_update(x, P_bad, z, Sigma, 30.0, True, w.gamma, w.Wm, w.Wc)
    assert code == 2 and np.isnan(nis)


# ---------------------------------------------------------------- the hook in the loop
def _spec():
    from benchmarks.scenarios import SensorSpec

    return SensorSpec(
        estimator="ukf", star_tracker_latency=0.2, outage_rate=0.05, outage_duration=2.0,
        star_tracker_outages=((4.0, 5.0),), gyro_bias=(1e-4, -5e-5, 2e-5),
    )  # fmt: skip


def _ukf_both(B=3, t_final=12.0, hook_cls=None, first=_fused, actuator="sgcmg", **kw):
    """(fused, hook, rng), (Python, hook, rng) with the benchmarks' UKF hook on the SGCMG
    pyramid (or another ``actuator`` of :func:`test_fused_sensors._case`)."""
    from benchmarks.runner import build_sensors

    plant, ctrl, ref, x0 = _case(actuator, B=B)
    assert np.all(np.abs(x0.omega) > 0.0)  # non-zero initial rates
    out = []
    for run in (first, _python_loop):
        sensors, hook, rng = build_sensors(_spec())
        if hook_cls is not None:
            hook = hook_cls(hook.spec, hook.attitude, hook.rate, hook.gyro)
        res = run(plant, copy.deepcopy(ctrl), ref, x0, t_final, 0.1, sensors=sensors,
                  measurement=hook, rng=rng, **kw)  # fmt: skip
        out.append((res, hook, rng))
    return out


def test_ukf_hook_in_the_fused_loop_equals_the_python_loop(caplog):
    """The UKF between the sensors (latency, scheduled and random outages, gyro bias) and the
    law, over a batch with control_period > dt and log_every > 1: the log, the estimate, the
    filters' final state and their consistency log (NEES, NIS, gate) equal the Python loop's."""
    with caplog.at_level(logging.WARNING, logger="liecontrol.estimation"):
        (fa, ha, ra), (py, hp, rp) = _ukf_both(control_period=0.2, log_every=3)
    _assert_same(fa, py)
    assert ra.bit_generator.state == rp.bit_generator.state
    rejected = sum(sum(hp._log[b]["gated"]) for b in range(3))
    assert rejected >= 1  # the gate acted in this run
    compiled = [r.getMessage() for r in caplog.records if "(compiled loop)" in r.getMessage()]
    assert len(compiled) == 1
    assert compiled[0].startswith(f"ManifoldUKF (compiled loop): {int(rejected)} innovation(s)")
    valid = fa.sensors["star_tracker_valid"]
    assert not valid.all()  # the outages happened
    for b in range(3):
        for key, vp in hp._log[b].items():
            va = ha._log[b][key]
            assert len(va) == len(vp) > 0, key
            # NEES and NIS: quadratic forms in P⁻¹ (P_zz⁻¹), relative to the module docstring's
            # last-bit differences of P (this run's filters are far from consistent: NEES ~1e4)
            rtol = 1e-10 if key in ("nees", "nees_full", "nis") else 1e-12
            np.testing.assert_allclose(va, vp, rtol=rtol, atol=1e-12, err_msg=key)
        fa_b, fp_b = ha._filters[b], hp._filters[b]
        assert type(fa_b) is type(fp_b) is ManifoldUKF
        # the bias estimate to 1e-14 rad/s (last bits of a lost filter's 3.6e-4, see above)
        np.testing.assert_allclose(fa_b.x, fp_b.x, rtol=1e-12, atol=1e-14)
        _cov_close(fa_b.P, fp_b.P)
        assert fa_b._gated_run == fp_b._gated_run
        ca, cp = ha.consistency(b, since=6.0), hp.consistency(b, since=6.0)
        assert sorted(ca) == sorted(cp)
        for k in cp:
            np.testing.assert_allclose(ca[k], cp[k], rtol=1e-10, err_msg=k)
    assert ha._t_last == hp._t_last
    np.testing.assert_allclose(ha._z_last, hp._z_last, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ha._w_last, hp._w_last, rtol=1e-12, atol=1e-15)


def test_a_covariance_that_loses_definiteness_repeats_the_run_in_the_python_loop(caplog):
    """A hook whose compiled UKF has weights under which the propagated covariance is not
    positive definite (W₀ᶜ = −1e9): the kernel reports it at the first prediction, the compiled
    run stops, and the whole run is repeated in the Python loop from the same generator state —
    the result is the Python loop's (its numpy filter, with the default weights, needs no
    repair here)."""
    from benchmarks.runner import FilteredAttitude

    class Sharp(FilteredAttitude):
        def fused_hook(self):
            spec = super().fused_hook()
            g, Wm, Wc = spec.weights
            Wc = Wc.copy()
            Wc[0] = -1e9
            return dataclasses.replace(spec, weights=(g, Wm, Wc))

    ran = []
    real = simulator_module.run_fused

    def spy(*a, **k):
        out = real(*a, **k)
        ran.append(out is not None)
        return out

    simulator_module.run_fused = spy
    try:
        with caplog.at_level(logging.INFO):
            (fa, ha, ra), (py, hp, rp) = _ukf_both(
                B=2, t_final=3.0, hook_cls=Sharp, first=simulate, control_period=0.2
            )
    finally:
        simulator_module.run_fused = real
    assert ran == [False]  # the compiled run was tried and gave up
    assert "the estimator hook's covariance lost positive definiteness" in caplog.text
    _assert_same(fa, py)
    assert ra.bit_generator.state == rp.bit_generator.state
    for b in range(2):
        np.testing.assert_array_equal(ha._filters[b].x, hp._filters[b].x)
        np.testing.assert_array_equal(ha._filters[b].P, hp._filters[b].P)
        assert ha._log[b] == hp._log[b]


def test_estimator_hook_kind_is_checked():
    from spacecraft._fused_sensors import EstimatorHook

    args = ("st", "gyro", 1e-5, 1e-6, np.eye(3), np.eye(6), 30.0, 10)
    with pytest.raises(ValueError, match="^kind:"):
        EstimatorHook(*args, kind="ekf")
    with pytest.raises(ValueError, match="^weights:"):
        EstimatorHook(*args, kind="ukf")
    assert EstimatorHook(*args).filter_name == "MEKF"


def test_ukf_hook_with_reaction_wheels_in_the_fused_loop_equals_the_python_loop():
    """The same hook on the wheels' compiled loop (spacecraft._fused_wheels): the log, the
    estimate and the filters' final state equal the Python loop's (the NumPy assembly, whose
    BLAS sums differ in the last bits: the filter's state to 1e-10 relative)."""
    (fa, ha, _), (py, hp, _) = _ukf_both(actuator="wheels", control_period=0.2, log_every=3)
    _assert_same(fa, py)
    for b in range(3):
        np.testing.assert_allclose(ha._filters[b].x, hp._filters[b].x, rtol=1e-10, atol=1e-15)
        P = hp._filters[b].P
        np.testing.assert_allclose(ha._filters[b].P, P, rtol=0, atol=1e-10 * np.abs(P).max())
