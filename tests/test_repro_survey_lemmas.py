"""Survey-lemmas reproduction (Jiang, Meng & Yang 2023): the region-of-attraction lemmas checked
on simulations — every lemma is REPRODUCED on the reduced sample count and the table renders,
plus independent checks of the sampling, the momentum envelope and the Lyapunov bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import quick_reproduction
from repro_markdown import PAPER_BY_NUMBER, check_reproduction_markdown

from benchmarks.reproductions import geometric_survey_lemmas as lemmas
from benchmarks.reproductions._common import REPRODUCED
from liecontrol import errors as E
from liecontrol.control import region_of_attraction as roa
from liecontrol.lie import so3
from spacecraft import SgcmgPyramid


@pytest.fixture(scope="module")
def reproduction(tmp_path_factory):
    return quick_reproduction(lemmas, tmp_path_factory.mktemp("lemmas"))


def test_every_lemma_is_reproduced(reproduction):
    code, _, res = reproduction
    failed = [r for r in res["rows"] if r["result"] != "PASS"]
    assert not failed, failed
    assert code == 0
    assert [c["verdict"] for c in res["claims"]] == [REPRODUCED] * 6
    assert len(res["sensitivity"]["variations"]) == 4  # ours, ω_n 0.01 and 0.1, ζ 0.5
    reconstructed = [c for c in res["claims"] if "our reading" in c["reason"]]
    assert len(reconstructed) == 3  # L1 trace region, L2 torque-level, L3 attitude block
    names = [r["case"] for r in res["rows"]]
    assert names == ["L1-global", "L1-trace-region", "L2-survey", "L2-torque", "L4", "L3-SE3"]
    for r in res["rows"][1:]:
        # both sides of every region were sampled, and inside means converged + stayed
        assert r["n_inside"] >= 8 and r["n_outside"] >= 8
        assert r["inside_converged"] == 1.0 and r["inside_stayed"] == 1.0
        assert r["inside_V_monotone"] == 1.0
        assert r["max_rel_dV_inside"] < lemmas.LemmasConfig().v_tol


def test_survey_form_of_lemma2_is_the_exact_sublevel_set(reproduction):
    """With acceleration-level gains K_R = k_p J the survey's Lemma 2 is V(0) < k_p π²/2 exactly,
    so no outside sample lies in the sublevel set; the λ_max(J) forms are strictly tighter."""
    _, _, res = reproduction
    rows = {r["case"]: r for r in res["rows"]}
    assert rows["L2-survey"]["outside_in_sublevel"] == 0.0
    assert rows["L4"]["outside_in_sublevel"] > 0.0
    assert rows["L2-torque"]["outside_in_sublevel"] > 0.0


def test_outputs_written(reproduction):
    _, out, res = reproduction
    for name in ("table.md", "table.csv", "results.json", "lemmas_regions.png",
                 "lemmas_lyapunov.png"):
        assert (out / name).stat().st_size > 0
    md = (out / "table.md").read_text(encoding="utf-8")
    assert str(lemmas.CITATION) in md and not PAPER_BY_NUMBER.search(md)
    parsed = check_reproduction_markdown(md, sensitivity=True)
    assert len(parsed["claims"]) == 6
    assert res["sgcmg"]["result"] == "INFO" and res["sgcmg"]["n_inside"] > 0


def test_sampling_straddles_the_boundary():
    cfg = lemmas.LemmasConfig()
    rng = np.random.default_rng(0)
    case = next(c for c in lemmas.cases(cfg) if c.name == "L4")
    R0, w0 = lemmas.sample_initial_conditions(case, 400, rng)
    assert R0.shape == (400, 3, 3) and w0.shape == (400, 3)
    Psi0, _ = E.large_angle_error(R0, np.eye(3))
    inside = case.condition(Psi0, w0)
    assert 0.4 < inside.mean() < 0.6
    # the designed "near boundary" quarters: ratio to the Lemma 4 radius in [0.9, 1.1]
    lam = np.linalg.eigvalsh(cfg.inertia)[-1]
    ratio = np.linalg.norm(w0, axis=1) / np.sqrt(2 * case.k_eff * (2 - Psi0) / lam)
    assert np.all((ratio[1::4] >= 0.9) & (ratio[1::4] < 1.0))
    assert np.all((ratio[2::4] >= 1.0) & (ratio[2::4] < 1.1))
    # the same seed gives the same samples
    R1, w1 = lemmas.sample_initial_conditions(case, 400, np.random.default_rng(0))
    np.testing.assert_array_equal(w0, w1)


def test_momentum_envelope_against_brute_force():
    """Support function h₀ Σ √(1 − (d·gᵢ)²) against the max of d·h(δ) over a gimbal-angle grid
    (each unit maximised independently on a fine grid)."""
    cluster = SgcmgPyramid(h0=300.0, beta=np.deg2rad(54.73))
    rng = np.random.default_rng(1)
    d = rng.standard_normal((5, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    env = lemmas.momentum_envelope(cluster, d)
    grid = np.linspace(-np.pi, np.pi, 20001)
    delta = np.zeros((grid.size, 4))
    brute = np.zeros(5)
    for i in range(4):
        delta[:] = 0.0
        delta[:, i] = grid
        hi = cluster.unit_momenta(delta)[..., i]  # (N, 3): unit i's momentum over the grid
        brute += cluster.h0 * (hi @ d.T).max(axis=0)
    np.testing.assert_allclose(env, brute, rtol=1e-7)


def test_lyapunov_of_the_acceleration_level_law():
    """For K_R = k_p J the reproduction's V is ½‖ω‖² + k_p θ²/2 (log error)."""
    cfg = lemmas.LemmasConfig()
    case = next(c for c in lemmas.cases(cfg) if c.name == "L2-survey")
    R = so3.exp(np.array([[0.0, 0.0, 2.0]]))
    w = np.array([[0.01, -0.02, 0.03]])
    Psi, _ = E.log_error(R, np.eye(3))
    V = roa.lyapunov_function(case.kind, Psi, w, case.J_eff, case.k_eff)
    assert V[0] == pytest.approx(0.5 * (w**2).sum() + 0.5 * case.k_eff * 4.0, rel=1e-12)
    assert np.allclose(case.k_R, case.k_eff * cfg.inertia)
