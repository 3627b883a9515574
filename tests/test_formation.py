"""Formations on the batched plant: SE(3) relative-pose keeping, scenarios, metrics, CLI."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from liecontrol.control.consensus import CommunicationGraph, PoseFormation
from liecontrol.control.se3_control import (
    PoseReference,
    PoseState,
    SE3TrackingController,
    pose_gains_from_bandwidth,
)
from liecontrol.lie import se3, so3
from spacecraft.formation import (
    FORMATION_SCENARIOS,
    FormationScenario,
    formation_scenario,
    formation_table,
    main,
    measure_throughput,
    plot_formation,
    run_formation,
    settling_time,
)
from spacecraft.orbit import CircularOrbit
from spacecraft.se3_plant import SE3Plant

M, JB = 100.0, np.diag([20.0, 25.0, 30.0])


def _tracking(plant: SE3Plant | None = None) -> SE3TrackingController:
    gains = pose_gains_from_bandwidth(M, JB, omega_att=0.1, omega_pos=0.05)
    return SE3TrackingController(
        M, JB, gravity=None if plant is None else plant.gravity_wrench, **gains
    )


def test_settling_time_by_hand() -> None:
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    assert settling_time(t, np.array([5.0, 3.0, 1.0, 0.5, 0.2]), 2.0) == pytest.approx(1.5)
    assert settling_time(t, np.array([1.0, 0.5, 0.1, 0.1, 0.1]), 2.0) == 0.0
    assert math.isnan(settling_time(t, np.array([1.0, 0.5, 0.1, 0.1, 3.0]), 2.0))
    with pytest.raises(ValueError, match="^tolerance"):
        settling_time(t, t, -1.0)
    with pytest.raises(ValueError, match="^err"):
        settling_time(t, t[:3], 1.0)


def test_pose_formation_reference_is_rigid_attachment() -> None:
    rng = np.random.default_rng(0)
    g = CommunicationGraph.tree([-1, 0, 1])
    rel = np.stack(
        [np.eye(4)]
        + [se3.from_rt(so3.exp(rng.normal(size=3) * 0.3), rng.normal(size=3) * 10) for _ in "ab"]
    )
    ctrl = PoseFormation(g, rel, _tracking())
    ctrl.reset(0.0, 3)
    gs = se3.from_rt(so3.exp(rng.normal(size=(3, 3)) * 0.5), rng.normal(size=(3, 3)) * 100)
    xi = rng.normal(size=(3, 6)) * 0.1
    g_ref = se3.from_rt(so3.exp(np.array([0.1, 0.0, 0.2])), np.array([1.0, 2.0, 3.0]))
    ref = PoseReference(g_ref, np.array([0.0, 0.0, 0.01, 1.0, 0.0, 0.0]), np.zeros(6))
    ctrl.command(0.0, PoseState(gs, xi), ref)
    g_d = ctrl.diagnostics()["g_d"]
    assert np.allclose(g_d[0], g_ref @ rel[0])
    assert np.allclose(g_d[1], gs[0] @ rel[1]) and np.allclose(g_d[2], gs[1] @ rel[2])
    # the desired twist of a rigidly attached frame: finite difference of g_p exp(h ξ_p^) g_rel
    h = 1e-6
    ctrl2 = PoseFormation(g, rel, _tracking())
    ctrl2.reset(0.0, 3)
    gs2 = gs.copy()
    gs2[0] = gs[0] @ se3.exp(h * xi[0])
    ctrl2.command(0.0, PoseState(gs2, xi), ref)
    xi_fd = se3.log(se3.inverse(g_d[1]) @ ctrl2.diagnostics()["g_d"][1]) / h
    eta = ctrl.diagnostics()["xi_tilde"]  # ξ̃ = ξ − Ad_{g̃⁻¹} ξ_d, assembled over the levels
    g_t = se3.inverse(g_d[1]) @ gs[1]
    xi_d1 = se3.adjoint(g_t) @ (xi[1] - eta[1])
    assert np.allclose(xi_d1, xi_fd, atol=1e-5)


def test_parent_acceleration_prediction_matches_plant() -> None:
    plant = SE3Plant(M, JB, method="rkmk4")
    ctrl = PoseFormation(
        CommunicationGraph.tree([-1, 0]), np.stack([np.eye(4)] * 2), _tracking(plant)
    )
    rng = np.random.default_rng(1)
    g0 = se3.from_rt(so3.exp(rng.normal(size=3)), np.array([7.0e6, 1.0e3, -2.0e3]))
    xi0 = np.array([0.01, -0.02, 0.005, 10.0, 7500.0, 3.0])
    u = np.array([0.3, -0.1, 0.2, 5.0, -2.0, 1.0])
    pred = ctrl._acceleration(g0[None], xi0[None], u[None])[0]
    # independent route: the plant's own ξ̇
    assert np.allclose(pred, plant.xi_dot(0.0, g0[None], xi0[None], u[None])[0], rtol=1e-10)


def test_pose_formation_converges_and_validates() -> None:
    r = run_formation(formation_scenario("se3-formation-tree-4"))
    assert r.member_error[0].max() > 0.1 and r.position_error[0].max() > 1.0
    assert r.member_error[-1].max() < 1e-6 and r.position_error[-1].max() < 1e-3
    assert 0.0 < r.settling_time < r.t[-1]
    two_parents = CommunicationGraph(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.0]]), leaders=[0])
    with pytest.raises(ValueError, match="^graph: follower 2 receives 2 members"):
        PoseFormation(two_parents, np.stack([np.eye(4)] * 3), _tracking())
    with pytest.raises(ValueError, match="^relative_poses: expected shape"):
        PoseFormation(CommunicationGraph.tree([-1, 0]), np.stack([np.eye(4)] * 3), _tracking())
    with pytest.raises(ValueError, match="^graph: a leader"):
        PoseFormation(CommunicationGraph.ring(3), np.stack([np.eye(4)] * 3), _tracking())
    with pytest.raises(TypeError, match="^tracking"):
        PoseFormation(CommunicationGraph.tree([-1, 0]), np.stack([np.eye(4)] * 2), object())
    ctrl = PoseFormation(CommunicationGraph.tree([-1, 0]), np.stack([np.eye(4)] * 2), _tracking())
    with pytest.raises(ValueError, match="^batch_size: the formation has 3"):
        ctrl.reset(0.0, 3)


def test_pose_formation_with_delay_converges() -> None:
    sc = formation_scenario("se3-formation-tree-4")
    sc = FormationScenario(
        "delayed",
        "",
        "pose",
        CommunicationGraph.tree([-1, 0]),  # one leader, one follower: the delay's effect
        duration=300.0,
        dt=1.0,
        control_period=1.0,
        omega_n=0.1,
        spread=0.5,
        delay=2,
        relative_poses=sc.relative_poses[:2],
    )
    r = run_formation(sc)
    # the leader turns at the orbit rate n: the follower lags the leader by n × delay (2 s) in
    # attitude and by the orbital speed × delay (≈ 15 km) along the track
    lag = 0.0011 * 2.0
    v_tau = CircularOrbit(n=0.0011).radius * 0.0011 * 2.0
    assert r.member_error[-1, 0] < 1e-9
    assert np.isclose(r.member_error[-1, 1], lag, rtol=0.02)
    assert np.isclose(r.position_error[-1, 1], v_tau, rtol=0.02)
    # predict=True propagates the delayed parent state (second order in τ): the lag goes, the
    # transient (the parent's unknown later commands) stays a few % of it
    r_p = run_formation(dataclasses.replace(sc, predict=True))
    assert r_p.member_error[-1].max() < 1e-8 and r_p.position_error[-1].max() < 0.1
    assert r_p.position_error.max() < 0.05 * r.position_error.max()


def test_catalogue_scenarios(tmp_path) -> None:
    assert 3 <= min(f().n for f in FORMATION_SCENARIOS.values())
    assert max(f().n for f in FORMATION_SCENARIOS.values()) <= 10
    results = [
        run_formation(formation_scenario(n))
        for n in ("consensus-ring-6", "consensus-split-6", "leader-follower-tree-7")
    ]
    ring, split, tree = results
    assert ring.consensus_error[-1] < 1e-5 and not math.isnan(ring.settling_time)
    assert split.consensus_error[-1] > 0.1 and math.isnan(split.settling_time)
    assert tree.member_error[-1].max() < 1e-5
    table = formation_table(results)
    assert "consensus-split-6" in table and "never" in table
    # settling times depend on the tolerance: the table shows it, and the delayed and predicted
    # trees (compared side by side) use the same one
    assert "| tolerance |" in table.splitlines()[0] and "| 0.001 rad |" in table
    delayed = formation_scenario("leader-follower-tree-10-delay")
    predicted = formation_scenario("leader-follower-tree-10-predict")
    assert delayed.tolerance == predicted.tolerance
    out = plot_formation(ring, tmp_path / "ring.png")
    assert out.stat().st_size > 1000
    with pytest.raises(ValueError, match="^name: unknown formation scenario"):
        formation_scenario("nope")


def test_scenario_validation() -> None:
    g = CommunicationGraph.ring(3)
    with pytest.raises(ValueError, match="^kind"):
        FormationScenario("x", "", "swarm", g, 1.0)
    with pytest.raises(ValueError, match="^duration"):
        FormationScenario("x", "", "consensus", g, -1.0)
    with pytest.raises(ValueError, match="^relative_poses: required"):
        FormationScenario("x", "", "pose", CommunicationGraph.tree([-1, 0]), 1.0)
    with pytest.raises(ValueError, match="^delay"):
        FormationScenario("x", "", "consensus", g, 1.0, delay=-2)


def test_cli_and_throughput(capsys, tmp_path) -> None:
    assert main(["--only", "leader-follower-tree-7", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "| leader-follower-tree-7 | 7 |" in text
    assert (tmp_path / "formation_leader-follower-tree-7.png").exists()
    with pytest.raises(SystemExit):
        main(["--only", "nope"])
    m = measure_throughput(10, steps=5, repeats=3)
    assert m["member_steps_per_s"] > 0 and m["command_s"] > 0
