"""Shared test helpers: the seed-000 spacecraft, a per-spacecraft controller multiplexer and
the quick run of a seed reproduction.

Test modules import these directly (``from conftest import ...``; ``tests/`` is on ``sys.path``
under pytest's default import mode).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from liecontrol.control import AttitudeController, AttitudeReference, AttitudeState
from spacecraft import RigidBody, SgcmgActuator, SgcmgPyramid, SingularityRobust, Spacecraft


@pytest.fixture(autouse=True)
def _isolated_registries():
    """Every test starts from the built-in controller and scenario registries: a docs example or
    a test that registers a controller (e.g. a learned policy) must not leak it into later tests
    that run "every registered controller"."""
    from benchmarks import controllers, scenarios

    saved = (dict(controllers.CONTROLLERS), dict(scenarios.SCENARIOS), dict(scenarios.SUITES))
    yield
    for live, snap in zip(
        (controllers.CONTROLLERS, scenarios.SCENARIOS, scenarios.SUITES), saved, strict=True
    ):
        live.clear()
        live.update(snap)


#: Seed-000 inertia [kg·m²] (SPEC §6.1); read-only because every test module shares it.
SEED000_J = np.array(
    [[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]]
)
SEED000_J.setflags(write=False)


def seed000_spacecraft(
    disturbance: object = None, h0: float = 300.0, gimbal_rate_limit: float = 1.0
) -> Spacecraft:
    """The seed-000 spacecraft: :data:`SEED000_J`, a 4-SGCMG pyramid (β = 54.73°, h₀ = 300 N·m·s,
    gimbal rate limit 1 rad/s) with SR steering, gimbals at (45°, −45°, 45°, −45°)."""
    cluster = SgcmgPyramid(h0=h0, beta=np.deg2rad(54.73), gimbal_rate_limit=gimbal_rate_limit)
    actuator = SgcmgActuator(cluster, SingularityRobust(), delta0=np.deg2rad([45, -45, 45, -45]))
    return Spacecraft(RigidBody(SEED000_J), actuator, disturbance)


def attitude_reference(R_d, w_d=None, dw_d=None) -> AttitudeReference:
    """An :class:`AttitudeReference` at ``R_d`` (any batch shape) with ω_d, ω̇_d zero unless
    given."""
    R_d = np.asarray(R_d, float)
    z = np.zeros(R_d.shape[:-2] + (3,))
    return AttitudeReference(
        R_d=R_d,
        omega_d=z if w_d is None else np.asarray(w_d, float),
        omega_dot_d=z if dw_d is None else np.asarray(dw_d, float),
    )


class OnePerSpacecraft(AttitudeController):
    """Spacecraft ``b`` is flown by ``controllers[b]``: several designs in one batched run."""

    def __init__(self, controllers):
        self.controllers = controllers

    def reset(self, t0, batch_size):
        assert batch_size == len(self.controllers)
        for c in self.controllers:
            c.reset(t0, 1)

    def command(self, t, state, reference):
        out = []
        for b, c in enumerate(self.controllers):
            s = slice(b, b + 1)
            h = None if state.h is None else state.h[s]
            out.append(c.command(t, AttitudeState(state.R[s], state.omega[s], h), reference))
        return np.concatenate(out, axis=0)

    def diagnostics(self):
        d = [c.diagnostics() for c in self.controllers]
        out = {}
        for k in sorted(set().union(*d)):
            like = next(x[k] for x in d if k in x)
            fill = np.full_like(like, False if like.dtype == bool else np.nan)
            out[k] = np.concatenate([x.get(k, fill) for x in d], axis=0)
        return out  # keys missing for some controller: NaN (False) rows


def quick_reproduction(module: object, out: Path) -> tuple[int, Path, dict]:
    """Run a seed reproduction's ``main(out, quick=True)``; return its exit code, ``out`` and the
    parsed ``results.json``."""
    code = module.main(out, quick=True)
    return code, out, json.loads((out / "results.json").read_text(encoding="utf-8"))


#: the suite's per-run timing columns: wall times, not results (they differ between routes)
TIMING_METRICS = ("controller_time_us", "sim_wall_time_s")


def suite_on_both_routes(scenarios, names, caplog, members: int = 2):
    """``run_suite`` of ``names`` on ``scenarios`` (``members`` dispersed members, serial) on the
    numba route and on the JAX route: ``(numba, jax)`` results, the JAX run's log lines captured
    by ``caplog`` (logger ``benchmarks.runner``)."""
    import logging

    from benchmarks.runner import run_suite

    kw = {"members": members, "executor": "serial", "progress": False}
    a = run_suite(scenarios, names, **kw)
    with caplog.at_level(logging.INFO, logger="benchmarks.runner"):
        b = run_suite(scenarios, names, backend="jax", **kw)
    return a, b


def assert_same_outcomes(a, b, rtol: float = 1e-9, atol: float = 1e-12) -> None:
    """Two suite results agree run by run on the controllers of ``a`` (``b`` may hold others):
    the same runs (scenario, controller, member), status and verdict, and every finite metric
    but the timing columns to ``rtol``/``atol``."""
    runs = a.outcomes + a.member_outcomes
    names = {o.controller for o in runs}
    got = {(o.scenario, o.controller, o.member): o for o in b.outcomes + b.member_outcomes
           if o.controller in names}  # fmt: skip
    assert runs and len(got) == len(runs)
    for oa in runs:
        ob = got[(oa.scenario, oa.controller, oa.member)]
        assert (oa.status, oa.verdict) == (ob.status, ob.verdict), (oa.controller, oa.member)
        for k, v in oa.metrics.items():
            if k not in TIMING_METRICS and np.isfinite(v):
                where = f"{oa.controller} member {oa.member}: {k}"
                np.testing.assert_allclose(ob.metrics[k], v, rtol=rtol, atol=atol, err_msg=where)


def simulate_python_loop(monkeypatch, *args, **kwargs):
    """``spacecraft.simulate`` forced onto the per-step Python loop (the compiled routes'
    reference in the equality tests)."""
    from spacecraft import simulator as simulator_module

    with monkeypatch.context() as m:
        m.setattr(simulator_module, "fused_supported", lambda *a, **k: None)
        return simulator_module.simulate(*args, **kwargs)


def simulate_fused(monkeypatch, *args, **kwargs):
    """``spacecraft.simulate`` that must run (and finish) in the fused loop."""
    from spacecraft import simulator as simulator_module

    ran = []

    def spying(real):
        def spy(*a, **k):
            out = real(*a, **k)
            ran.append(out is not None)
            return out

        return spy

    with monkeypatch.context() as m:
        # the momentum model's and full CMG model's loop, or the reaction wheels'
        for name in ("run_fused", "run_fused_wheels"):
            m.setattr(simulator_module, name, spying(getattr(simulator_module, name)))
        res = simulator_module.simulate(*args, **kwargs)
    assert ran == [True]
    return res
