"""Attitude consensus on SO(3): graph utilities, the distributed laws, delay, metrics.

Independent routes: scipy.sparse.csgraph (Laplacian, components), numpy eigenvalues, scipy's
Rotation (logarithms of the hand-computed torques), brute-force pairwise angles, the Lyapunov
function of the leaderless law along a simulated run.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.sparse import csgraph
from scipy.spatial.transform import Rotation

from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.consensus import (
    AttitudeConsensus,
    CommunicationGraph,
    ConsensusGraphWarning,
    LeaderFollowerConsensus,
    consensus_error,
    pairwise_angles,
)
from liecontrol.control.reference import ConstantAttitude
from liecontrol.lie import so3
from spacecraft.actuators import IdealTorqueActuator
from spacecraft.plant import Spacecraft
from spacecraft.rigid_body import RigidBody
from spacecraft.simulator import simulate

J = np.diag([8.0, 10.0, 12.0])


def _rotvec_log(R: np.ndarray) -> np.ndarray:
    return Rotation.from_matrix(R).as_rotvec()


def _random_undirected(rng: np.random.Generator, n: int, p: float) -> np.ndarray:
    U = np.triu((rng.uniform(size=(n, n)) < p) * rng.uniform(0.5, 2.0, size=(n, n)), 1)
    return U + U.T


# ----------------------------------------------------------------------------- graph
def test_laplacian_row_sums_and_scipy() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        A = _random_undirected(rng, int(rng.integers(2, 12)), 0.3)
        g = CommunicationGraph(A)
        L = g.laplacian
        assert np.allclose(L.sum(axis=1), 0.0, atol=1e-12)
        assert np.allclose(L, csgraph.laplacian(A), atol=1e-12)
        # multiplicity of the eigenvalue 0 == number of connected components
        ev = np.linalg.eigvalsh(L)
        zeros = int(np.sum(np.abs(ev) < 1e-9 * max(1.0, ev[-1])))
        n_comp = csgraph.connected_components(A, directed=False)[0]
        assert zeros == n_comp == g.n_components
        assert g.is_connected == (n_comp == 1)
        assert g.has_spanning_tree == (n_comp == 1)  # undirected: spanning tree == connected
        assert (g.algebraic_connectivity > 1e-9) == (n_comp == 1)


def test_directed_laplacian_uses_in_degree() -> None:
    g = CommunicationGraph.tree([-1, 0, 0, 1])
    L = g.laplacian
    assert np.allclose(L.sum(axis=1), 0.0)
    assert np.allclose(np.diag(L), [0.0, 1.0, 1.0, 1.0])
    assert g.leaders == (0,)
    assert g.has_spanning_tree and not g.is_undirected
    assert g.informed_by([0]).all()
    assert g.informed_by([1]).tolist() == [False, True, False, True]


def test_topologies() -> None:
    ring = CommunicationGraph.ring(5)
    assert np.allclose(ring.degree, 2.0) and ring.is_undirected
    # ring Laplacian eigenvalues 2 − 2 cos(2πk/n)
    ev = np.sort(np.linalg.eigvalsh(ring.laplacian))
    k = np.arange(5)
    assert np.allclose(ev, np.sort(2 - 2 * np.cos(2 * np.pi * k / 5)))
    assert np.isclose(ring.algebraic_connectivity, 2 - 2 * np.cos(2 * np.pi / 5))
    full = CommunicationGraph.complete(4)
    assert np.allclose(np.linalg.eigvalsh(full.laplacian), [0, 4, 4, 4])
    path = CommunicationGraph.path(3)
    assert path.adjacency.tolist() == [[0, 1, 0], [1, 0, 1], [0, 1, 0]]


def test_graph_copies_and_freezes_input() -> None:
    A = CommunicationGraph.ring(4).adjacency.copy()
    g = CommunicationGraph(A)
    A[0, 1] = 7.0
    assert g.adjacency[0, 1] == 1.0
    with pytest.raises(ValueError):
        g.adjacency[0, 1] = 3.0


@pytest.mark.parametrize(
    ("adjacency", "match"),
    [
        (np.zeros((2, 3)), "adjacency: expected a square"),
        (np.zeros((1, 1)), "adjacency: a formation needs at least 2"),
        (np.array([[0.0, -1.0], [1.0, 0.0]]), "adjacency: weights must be >= 0"),
        (np.array([[1.0, 1.0], [1.0, 0.0]]), "adjacency: the diagonal must be zero"),
        (np.array([[0.0, np.nan], [1.0, 0.0]]), "adjacency"),
    ],
)
def test_graph_validation(adjacency: np.ndarray, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        CommunicationGraph(adjacency)


def test_graph_argument_errors() -> None:
    with pytest.raises(ValueError, match="^leaders: member 5"):
        CommunicationGraph.ring(4, leaders=[5])
    with pytest.raises(ValueError, match="^leaders: repeated"):
        CommunicationGraph.ring(4, leaders=[1, 1])
    with pytest.raises(TypeError, match="^leaders"):
        CommunicationGraph(np.ones((2, 2)) - np.eye(2), leaders="0")
    with pytest.raises(ValueError, match="^parents: member 1 is on a cycle"):
        CommunicationGraph.tree([-1, 2, 1])
    with pytest.raises(ValueError, match="^parents: expected exactly one root"):
        CommunicationGraph.tree([1, 0])
    with pytest.raises(ValueError, match="^edges: self-loop"):
        CommunicationGraph.from_edges(3, [(1, 1)])
    with pytest.raises(ValueError, match="^edges: edge"):
        CommunicationGraph.from_edges(3, [(0, 3)])
    with pytest.raises(ValueError, match="^weight: must be > 0"):
        CommunicationGraph.ring(4, weight=0.0)
    with pytest.raises(ValueError, match="^n: must be >= 3"):
        CommunicationGraph.ring(2)
    with pytest.raises(ValueError, match="^batch_size: the formation has 5"):
        CommunicationGraph.ring(4).check_batch(5)


# ----------------------------------------------------------------------------- laws
def _state(rng: np.random.Generator, n: int, spread: float = 0.6) -> AttitudeState:
    return AttitudeState(so3.exp(rng.normal(size=(n, 3)) * spread), rng.normal(size=(n, 3)) * 0.1)


def test_leaderless_torque_by_hand() -> None:
    rng = np.random.default_rng(2)
    g = CommunicationGraph(np.array([[0.0, 1.0, 0.5], [1.0, 0.0, 0.0], [0.5, 0.0, 0.0]]))
    c = AttitudeConsensus(g, J, k_R=3.0, k_Omega=5.0)
    c.reset(0.0, 3)
    s = _state(rng, 3)
    u = c.command(0.0, s, AttitudeReference.regulation(np.eye(3)))
    for i in range(3):
        coupling = sum(
            g.adjacency[i, j] * _rotvec_log(s.R[i].T @ s.R[j]) for j in range(3) if j != i
        )
        w = s.omega[i]
        expect = np.cross(w, J @ w) + 3.0 * coupling - 5.0 * w
        assert np.allclose(u[i], expect, atol=1e-12)


def test_torque_uses_neighbours_only() -> None:
    rng = np.random.default_rng(3)
    g = CommunicationGraph.ring(6)
    for ctrl in (
        AttitudeConsensus(g, J, 2.0, 4.0),
        LeaderFollowerConsensus(CommunicationGraph.tree([-1, 0, 1, 2, 3, 4]), J, 2.0, 4.0),
    ):
        ctrl.reset(0.0, 6)
        s = _state(rng, 6)
        ref = AttitudeReference.regulation(np.eye(3))
        u0 = ctrl.command(0.0, s, ref)
        # member 3 is not a neighbour of member 0 in either graph
        R = s.R.copy()
        R[3] = so3.exp(np.array([0.3, -0.2, 0.5])) @ R[3]
        ctrl.reset(0.0, 6)
        u1 = ctrl.command(0.0, AttitudeState(R, s.omega), ref)
        assert np.array_equal(u0[0], u1[0])
        assert not np.allclose(u0[2 if isinstance(ctrl, AttitudeConsensus) else 4], u1[4])


def test_leader_follower_torque_by_hand() -> None:
    rng = np.random.default_rng(4)
    g = CommunicationGraph.tree([-1, 0, 0])
    c = LeaderFollowerConsensus(g, J, k_R=2.0, k_Omega=6.0)
    c.reset(0.0, 3)
    s = _state(rng, 3)
    Rd = so3.exp(np.array([0.1, 0.2, -0.3]))
    wd, dwd = np.array([0.01, 0.0, 0.02]), np.array([0.001, -0.002, 0.0])
    u = c.command(0.0, s, AttitudeReference(Rd, wd, dwd))
    # the leader: geometric PD on the log error with tracking feed-forward
    R, w = s.R[0], s.omega[0]
    eR = _rotvec_log(Rd.T @ R)
    eW = w - R.T @ Rd @ wd
    lead = (
        -2.0 * eR
        - 6.0 * eW
        + np.cross(w, J @ w)
        - J @ (np.cross(w, R.T @ Rd @ wd) - R.T @ Rd @ dwd)
    )
    assert np.allclose(u[0], lead, atol=1e-12)
    # a follower: the same with its parent's attitude and rate, no acceleration feed-forward
    R, w = s.R[1], s.omega[1]
    Rp, wp = s.R[0], s.omega[0]
    eR = _rotvec_log(Rp.T @ R)
    wbar = R.T @ Rp @ wp
    fol = -2.0 * eR - 6.0 * (w - wbar) + np.cross(w, J @ w) - J @ np.cross(w, wbar)
    assert np.allclose(u[1], fol, atol=1e-12)


def test_delay_ring_buffer() -> None:
    rng = np.random.default_rng(5)
    g = CommunicationGraph.ring(4)
    d = 2
    c = AttitudeConsensus(g, J, 2.0, 4.0, delay=d)
    c.reset(0.0, 4)
    states = [_state(rng, 4) for _ in range(5)]
    ref = AttitudeReference.regulation(np.eye(3))
    us = [c.command(0.1 * k, s, ref) for k, s in enumerate(states)]
    for k, s in enumerate(states):
        old = states[max(k - d, 0)]  # the oldest one is held until `delay` samples exist
        for i in range(4):
            coupling = sum(
                _rotvec_log(s.R[i].T @ old.R[j]) for j in range(4) if g.adjacency[i, j] > 0
            )
            w = s.omega[i]
            expect = np.cross(w, J @ w) + 2.0 * coupling - 4.0 * w
            assert np.allclose(us[k][i], expect, atol=1e-12)
    c.reset(0.0, 4)  # reset clears the buffer: the first sample sees current neighbours
    fresh = AttitudeConsensus(g, J, 2.0, 4.0)
    fresh.reset(0.0, 4)
    assert np.array_equal(c.command(0.0, states[4], ref), fresh.command(0.0, states[4], ref))


def test_batch_and_argument_errors() -> None:
    g = CommunicationGraph.ring(5)
    c = AttitudeConsensus(g, J, 1.0, 1.0)
    with pytest.raises(ValueError, match="^batch_size: the formation has 4 spacecraft but graph"):
        c.reset(0.0, 4)
    c.reset(0.0, 5)
    with pytest.raises(ValueError, match="^state: the formation has 3 spacecraft"):
        c.command(0.0, AttitudeState(np.stack([np.eye(3)] * 3), np.zeros((3, 3))), None)
    with pytest.raises(TypeError, match="^graph"):
        AttitudeConsensus(np.eye(3), J, 1.0, 1.0)
    with pytest.raises(ValueError, match="^J: expected shape"):
        AttitudeConsensus(g, np.stack([J] * 4), 1.0, 1.0)
    with pytest.raises(ValueError, match="^k_R"):
        AttitudeConsensus(g, J, -1.0, 1.0)
    with pytest.raises(ValueError, match="^delay: must be >= 0"):
        AttitudeConsensus(g, J, 1.0, 1.0, delay=-1)
    with pytest.raises(ValueError, match="^graph: a leader"):
        LeaderFollowerConsensus(g, J, 1.0, 1.0)
    lf = LeaderFollowerConsensus(CommunicationGraph.tree([-1, 0, 0]), J, 1.0, 1.0)
    lf.reset(0.0, 3)
    bad_ref = AttitudeReference(np.stack([np.eye(3)] * 2), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="^reference: one sample or one per member"):
        lf.command(0.0, AttitudeState(np.stack([np.eye(3)] * 3), np.zeros((3, 3))), bad_ref)
    with pytest.raises(RuntimeError, match="^reset"):
        AttitudeConsensus(g, J, 1.0, 1.0).command(
            0.0, AttitudeState(np.stack([np.eye(3)] * 5), np.zeros((5, 3))), None
        )


def test_disconnected_graph_warns_or_raises() -> None:
    split = CommunicationGraph.from_edges(4, [(0, 1), (2, 3)])
    with pytest.warns(ConsensusGraphWarning, match="^graph: no member informs all others"):
        AttitudeConsensus(split, J, 1.0, 1.0)
    with pytest.raises(ValueError, match="^graph: no member informs"):
        AttitudeConsensus(split, J, 1.0, 1.0, require_connected=True)
    lf = CommunicationGraph.from_edges(4, [(0, 1), (2, 3)], leaders=[0])
    with pytest.warns(ConsensusGraphWarning, match=r"^graph: members \[2, 3\] are not informed"):
        LeaderFollowerConsensus(lf, J, 1.0, 1.0)
    with pytest.raises(ValueError, match="^graph: members"):
        LeaderFollowerConsensus(lf, J, 1.0, 1.0, require_connected=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        AttitudeConsensus(CommunicationGraph.ring(4), J, 1.0, 1.0)  # connected: silent


# ----------------------------------------------------------------------------- closed loop
def _run(ctrl, R0: np.ndarray, reference, t_final: float = 60.0):
    plant = Spacecraft(RigidBody(J), IdealTorqueActuator())
    return simulate(plant, ctrl, reference, plant.initial_state(R0), t_final, dt=0.1, log_every=5)


def test_consensus_converges_on_connected_not_on_disconnected() -> None:
    rng = np.random.default_rng(6)
    R0 = so3.exp(rng.normal(size=(6, 3)) * 0.4)
    ref = ConstantAttitude(np.eye(3))
    ring = _run(AttitudeConsensus(CommunicationGraph.ring(6), J, 8.0, 6.0), R0, ref)
    e = consensus_error(ring.R)
    assert e[0] > 0.5 and e[-1] < 1e-4
    split = CommunicationGraph.from_edges(6, [(0, 1), (1, 2), (3, 4), (4, 5)])
    with pytest.warns(ConsensusGraphWarning):
        ctrl = AttitudeConsensus(split, J, 8.0, 6.0)
    cut = _run(ctrl, R0, ref)
    e_cut = consensus_error(cut.R)
    assert e_cut[-1] > 0.2
    # ... while each half reaches its own consensus
    assert consensus_error(cut.R[-1, :3]) < 1e-4 and consensus_error(cut.R[-1, 3:]) < 1e-4


def test_leaderless_lyapunov_function_decreases() -> None:
    rng = np.random.default_rng(7)
    g = CommunicationGraph.ring(5)
    k_R, k_W = 5.0, 4.0
    res = _run(
        AttitudeConsensus(g, J, k_R, k_W),
        so3.exp(rng.normal(size=(5, 3)) * 0.5),
        ConstantAttitude(np.eye(3)),
        t_final=30.0,
    )
    kin = 0.5 * np.einsum("kbi,ij,kbj->k", res.omega, J, res.omega)
    i, j = np.nonzero(np.triu(g.adjacency))
    phi = so3.log(np.swapaxes(res.R[:, i], -1, -2) @ res.R[:, j])
    pot = 0.5 * k_R * np.sum(phi**2, axis=(-1, -2))
    V = kin + pot
    assert V[-1] < 1e-3 * V[0]
    assert np.all(np.diff(V) <= 1e-6 * V[0])  # non-increasing up to the integrator's error


def test_leader_follower_tracks_spinning_leader_with_delay() -> None:
    from spacecraft.formation import SpinReference

    rng = np.random.default_rng(8)
    g = CommunicationGraph.tree([-1, 0, 0, 1, 1])
    ref = SpinReference(np.eye(3), np.array([0.0, 0.0, 0.02]))
    R0 = so3.exp(rng.normal(size=(5, 3)) * 0.4)
    res = _run(LeaderFollowerConsensus(g, J, 5.0, 8.0), R0, ref, t_final=80.0)
    err = res.attitude_error_angle()
    assert err[0].max() > 0.3 and err[-1].max() < 1e-5
    res_d = _run(LeaderFollowerConsensus(g, J, 5.0, 8.0, delay=3), R0, ref, t_final=80.0)
    err_d = res_d.attitude_error_angle()[-1]
    # with a delay each level lags its parent by ≈ rate × delay (0.02 rad/s × 0.3 s)
    assert err_d[0] < 1e-5
    assert np.allclose(err_d[1:3], 0.006, rtol=0.05)
    assert np.allclose(err_d[3:], 0.012, rtol=0.05)
    # propagating the delayed states at their constant rate removes the lag
    res_p = _run(LeaderFollowerConsensus(g, J, 5.0, 8.0, delay=3, predict=True), R0, ref, 80.0)
    assert res_p.attitude_error_angle()[-1].max() < 1e-5


def test_predict_propagates_received_states() -> None:
    rng = np.random.default_rng(10)
    g = CommunicationGraph.ring(3)
    c = AttitudeConsensus(g, J, 2.0, 4.0, delay=1, predict=True)
    c.reset(0.0, 3)
    s0, s1 = _state(rng, 3), _state(rng, 3)
    ref = AttitudeReference.regulation(np.eye(3))
    c.command(0.0, s0, ref)
    u = c.command(0.25, s1, ref)
    for i in range(3):
        coupling = sum(
            _rotvec_log(s1.R[i].T @ s0.R[j] @ Rotation.from_rotvec(0.25 * s0.omega[j]).as_matrix())
            for j in range(3)
            if j != i
        )
        w = s1.omega[i]
        assert np.allclose(u[i], np.cross(w, J @ w) + 2.0 * coupling - 4.0 * w, atol=1e-12)


# ----------------------------------------------------------------------------- metrics
def test_consensus_error_against_brute_force() -> None:
    rng = np.random.default_rng(9)
    R = so3.exp(rng.normal(size=(7, 5, 3)) * rng.uniform(1e-9, 1.0, size=(7, 1, 1)))
    got = consensus_error(R)
    for k in range(7):
        brute = max(
            np.linalg.norm(_rotvec_log(R[k, i].T @ R[k, j])) for i in range(5) for j in range(5)
        )
        assert np.isclose(got[k], brute, rtol=1e-7, atol=1e-15)
    A = pairwise_angles(R[0])
    assert A.shape == (5, 5) and np.allclose(np.diag(A), 0.0) and np.allclose(A, A.T)
    tiny = so3.exp(np.array([[0.0, 0.0, 0.0], [3e-9, 0.0, 0.0], [0.0, -4e-9, 0.0]]))
    assert np.isclose(consensus_error(tiny), 5e-9, rtol=1e-6)
    with pytest.raises(ValueError, match="^R"):
        consensus_error(np.eye(3)[None])
