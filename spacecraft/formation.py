"""Formations of spacecraft on the batched plant: scenarios, metrics, figures and a CLI.

The simulator's batch axis becomes the members of a formation: one
:class:`spacecraft.plant.Spacecraft` (or :class:`spacecraft.se3_plant.SE3Plant`) integrates all
``N`` members at once, and a consensus controller of :mod:`liecontrol.control.consensus` gives each
member a torque (wrench) computed from its own state and its neighbours' on a
:class:`~liecontrol.control.consensus.CommunicationGraph`.

Scenarios (:data:`FORMATION_SCENARIOS`, 3–10 members):

- ``consensus-ring-6`` — leaderless attitude consensus on an undirected ring of 6;
- ``consensus-ring-6-delay`` — the same with a 5-sample (0.5 s) communication delay;
- ``consensus-split-6`` — the ring cut into two halves (disconnected): no consensus;
- ``leader-follower-tree-7`` — a binary tree of 7; the leader tracks a slowly spinning
  reference, every follower its parent;
- ``leader-follower-tree-10-delay`` — a 10-member tree with a 3-sample delay;
- ``leader-follower-tree-10-predict`` — the same with the delayed states propagated to the present
  at their constant rate (``predict=True``): the delay-induced lag disappears;
- ``se3-formation-tree-4`` — relative-pose keeping on SE(3) in low orbit: the leader flies the
  LVLH frame, three followers hold poses 20–40 m away.

Metrics: the consensus error ``max_ij ‖log(R_iᵀR_j)‖`` (:func:`~liecontrol.control.consensus.
consensus_error`) — for a leader–follower formation the *formation* error ``max_i ‖log(R_d,iᵀR_i)‖``
to each member's desired attitude is reported alongside — and its settling time (first time after
which it stays below ``tolerance``; linear interpolation between samples; ``NaN`` and the word
"never" in the table when it does not settle within the run).

Run ``python -m spacecraft.formation`` for the table (``--out DIR`` writes one figure per scenario
with every member's attitude error; ``--throughput`` measures member-steps per second at N = 10 and
N = 100 and the cost of one control call). The generic benchmark runner cannot express these runs
(its scenarios are single spacecraft judged against one reference for every registered
controller), so they have this module's own runner.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liecontrol._validation import as_array, as_int, as_scalar, check_positive_scalar
from liecontrol.control.base import AttitudeReference, AttitudeState
from liecontrol.control.consensus import (
    MAX_DELAY,
    AttitudeConsensus,
    CommunicationGraph,
    ConsensusGraphWarning,
    LeaderFollowerConsensus,
    PoseFormation,
    consensus_error,
)
from liecontrol.control.geometric_pd import gains_from_bandwidth
from liecontrol.control.se3_control import (
    PoseReference,
    PoseState,
    SE3TrackingController,
    pose_gains_from_bandwidth,
)
from liecontrol.lie import se3, so3

from .actuators import IdealTorqueActuator
from .orbit import CircularOrbit
from .plant import Spacecraft
from .rigid_body import RigidBody
from .se3_plant import DockingReference, OrbitingTarget, SE3Plant, simulate_pose
from .simulator import simulate

__all__ = [
    "FormationScenario",
    "FormationResult",
    "SpinReference",
    "FORMATION_SCENARIOS",
    "formation_scenario",
    "run_formation",
    "settling_time",
    "formation_table",
    "plot_formation",
    "measure_throughput",
]

_KINDS = ("consensus", "leader-follower", "pose")
#: inertia of every member in the attitude scenarios [kg·m²] (a small satellite)
J_MEMBER = np.diag([8.0, 10.0, 12.0])


@dataclass(frozen=True)
class SpinReference:
    """``R_d(t) = R_0 exp(t ω_d^)`` with a constant body rate ``ω_d`` [rad/s] (``ω̇_d = 0``): the
    path a leader follows in the leader–follower scenarios."""

    R_0: np.ndarray
    omega_d: np.ndarray

    def __post_init__(self) -> None:
        R = so3.validate(self.R_0, "R_0")
        if R.shape != (3, 3):
            raise ValueError(f"R_0: expected shape (3, 3), got {R.shape}")
        w = as_array(self.omega_d, "omega_d", (3,))
        if w.shape != (3,):
            raise ValueError(f"omega_d: expected shape (3,), got {w.shape}")
        object.__setattr__(self, "R_0", R.copy())
        object.__setattr__(self, "omega_d", w.copy())

    def __call__(self, t: float) -> AttitudeReference:
        t = as_scalar(t, "t")
        return AttitudeReference.unchecked(
            self.R_0 @ so3.exp(t * self.omega_d), self.omega_d, np.zeros(3)
        )


@dataclass(frozen=True)
class FormationScenario:
    """One formation case.

    Attributes:
        name: identifier; description: one line for the table.
        kind: ``"consensus"`` (leaderless), ``"leader-follower"`` (SO(3)) or ``"pose"`` (SE(3)
            leader–follower tree).
        graph: the communication graph (its size is the number of members).
        duration: simulated time [s]; dt: integration step [s]; control_period [s].
        omega_n: closed-loop bandwidth the gains are designed for [rad/s].
        spread: initial attitude spread: each member starts at ``exp(δ^)`` with ``δ`` uniform in
            a ball of this radius [rad] about the nominal attitude.
        delay: communication delay [control periods].
        predict: propagate the delayed neighbour states to the present at their constant body
            rate / twist (delay compensation of :mod:`liecontrol.control.consensus`).
        tolerance: the settling threshold of the consensus error [rad].
        seed: seeds the initial attitudes.
        relative_poses: ``(N, 4, 4)`` for ``"pose"`` (relative to the parent / the reference).
        position_spread: initial position offset of each member from its desired pose [m]
            (``"pose"`` only).
        position_tolerance: settling threshold of the position errors [m] (``"pose"`` only).
    """

    name: str
    description: str
    kind: str
    graph: CommunicationGraph
    duration: float
    dt: float = 0.1
    control_period: float = 0.1
    omega_n: float = 0.3
    spread: float = 0.8
    delay: int = 0
    predict: bool = False
    tolerance: float = 1e-3
    seed: int = 0
    relative_poses: np.ndarray | None = None
    position_spread: float = 5.0
    position_tolerance: float = 0.01

    def __post_init__(self) -> None:
        for name in ("name", "description"):
            if not isinstance(getattr(self, name), str):
                raise TypeError(f"{name}: expected a str, got {getattr(self, name)!r}")
        if self.kind not in _KINDS:
            raise ValueError(f"kind: must be one of {_KINDS}, got {self.kind!r}")
        if not isinstance(self.graph, CommunicationGraph):
            raise TypeError(
                f"graph: expected a CommunicationGraph, got {type(self.graph).__name__}"
            )
        for name in (
            "duration",
            "dt",
            "control_period",
            "omega_n",
            "spread",
            "tolerance",
            "position_tolerance",
        ):
            object.__setattr__(self, name, check_positive_scalar(getattr(self, name), name))
        object.__setattr__(
            self, "position_spread", as_scalar(self.position_spread, "position_spread")
        )
        object.__setattr__(self, "delay", as_int(self.delay, "delay", 0))
        if self.delay > MAX_DELAY:
            raise ValueError(f"delay: must be <= {MAX_DELAY} control periods, got {self.delay}")
        if not isinstance(self.predict, bool):
            raise TypeError(f"predict: expected a bool, got {self.predict!r}")
        object.__setattr__(self, "seed", as_int(self.seed, "seed", 0))
        if self.kind != "pose" and self.relative_poses is not None:
            raise ValueError(f"relative_poses: only for kind='pose', not {self.kind!r}")
        if self.kind == "pose":
            if self.relative_poses is None:
                raise ValueError("relative_poses: required for a pose formation")
            g = se3.validate(self.relative_poses, "relative_poses")
            if g.shape != (self.graph.n, 4, 4):
                raise ValueError(
                    f"relative_poses: expected shape ({self.graph.n}, 4, 4), got {g.shape}"
                )
            g = g.copy()
            g.setflags(write=False)
            object.__setattr__(self, "relative_poses", g)

    @property
    def n(self) -> int:
        """Number of members."""
        return self.graph.n


# ------------------------------------------------------------------------------- scenarios
def _binary_tree(n: int) -> CommunicationGraph:
    return CommunicationGraph.tree([-1] + [(i - 1) // 2 for i in range(1, n)])


def _pose_tree() -> FormationScenario:
    # leader 0 flies the LVLH frame; 1 trails it by 20 m, 2 leads by 20 m, 3 sits 20 m behind 1
    # and 10 m radially out, turned 90° about the orbit normal
    rel = np.stack(
        [
            np.eye(4),
            se3.from_rt(np.eye(3), np.array([-20.0, 0.0, 0.0])),
            se3.from_rt(np.eye(3), np.array([20.0, 0.0, 0.0])),
            se3.from_rt(so3.exp(np.array([0.0, 0.0, np.pi / 2])), np.array([-20.0, 0.0, 10.0])),
        ]
    )
    return FormationScenario(
        "se3-formation-tree-4",
        "SE(3) leader–follower tree of 4 in low orbit, 20–40 m relative poses",
        "pose",
        CommunicationGraph.tree([-1, 0, 0, 1]),
        duration=400.0,
        dt=1.0,
        control_period=1.0,
        omega_n=0.1,
        spread=0.5,
        tolerance=1e-3,
        relative_poses=rel,
    )


FORMATION_SCENARIOS: dict[str, Callable[[], FormationScenario]] = {
    "consensus-ring-6": lambda: FormationScenario(
        "consensus-ring-6",
        "leaderless consensus, undirected ring of 6",
        "consensus",
        CommunicationGraph.ring(6),
        duration=80.0,
    ),
    "consensus-ring-6-delay": lambda: FormationScenario(
        "consensus-ring-6-delay",
        "leaderless consensus, ring of 6, 0.5 s communication delay",
        "consensus",
        CommunicationGraph.ring(6),
        duration=80.0,
        delay=5,
    ),
    "consensus-split-6": lambda: FormationScenario(
        "consensus-split-6",
        "leaderless consensus, ring of 6 cut into two halves (disconnected)",
        "consensus",
        CommunicationGraph.from_edges(6, [(0, 1), (1, 2), (3, 4), (4, 5)]),
        duration=80.0,
    ),
    "leader-follower-tree-7": lambda: FormationScenario(
        "leader-follower-tree-7",
        "binary tree of 7, leader tracks a 0.02 rad/s spin",
        "leader-follower",
        _binary_tree(7),
        duration=80.0,
    ),
    "leader-follower-tree-10-delay": lambda: FormationScenario(
        "leader-follower-tree-10-delay",
        "binary tree of 10, leader tracks a 0.02 rad/s spin, 0.3 s delay",
        "leader-follower",
        _binary_tree(10),
        duration=80.0,
        delay=3,
        # each level lags its parent by ≈ rate × delay = 0.006 rad; the tree has depth 3
        tolerance=0.025,
    ),
    "leader-follower-tree-10-predict": lambda: FormationScenario(
        "leader-follower-tree-10-predict",
        "as leader-follower-tree-10-delay, delayed states propagated at constant rate",
        "leader-follower",
        _binary_tree(10),
        duration=80.0,
        delay=3,
        predict=True,
        # the same tolerance as the unpredicted run, so the two settling times compare
        tolerance=0.025,
    ),
    "se3-formation-tree-4": _pose_tree,
}


def formation_scenario(name: str) -> FormationScenario:
    """The catalogued scenario ``name`` (:data:`FORMATION_SCENARIOS`)."""
    if not isinstance(name, str) or name not in FORMATION_SCENARIOS:
        raise ValueError(
            f"name: unknown formation scenario {name!r}; known: {sorted(FORMATION_SCENARIOS)}"
        )
    return FORMATION_SCENARIOS[name]()


# ------------------------------------------------------------------------------- metrics
def settling_time(t: object, err: object, tolerance: float) -> float:
    """First time after which ``err`` ``(K,)`` stays ≤ ``tolerance``; the crossing after the last
    sample above it is linearly interpolated. ``t[0]`` if it never exceeds it, ``NaN`` if it is
    above the tolerance at the end (it never settled)."""
    t = as_array(t, "t")
    err = as_array(err, "err")
    tol = check_positive_scalar(tolerance, "tolerance")
    if t.ndim != 1 or err.shape != t.shape or t.size == 0:
        raise ValueError(f"err: expected shape {t.shape} like t (K,) with K >= 1, got {err.shape}")
    above = np.flatnonzero(err > tol)
    if above.size == 0:
        return float(t[0])
    k = int(above[-1])
    if k == t.size - 1:
        return math.nan
    e0, e1 = err[k], err[k + 1]
    return float(t[k] + (t[k + 1] - t[k]) * (e0 - tol) / (e0 - e1))


@dataclass(frozen=True)
class FormationResult:
    """A formation run.

    Attributes:
        scenario: the :class:`FormationScenario`.
        t: ``(K,)`` sample times [s].
        R: ``(K, N, 3, 3)`` member attitudes.
        member_error: ``(K, N)`` each member's attitude error [rad]: to its desired attitude
            (leader–follower, pose) or to the formation's chordal mean attitude (consensus).
        consensus_error: ``(K,)`` ``max_ij ‖log(R_iᵀR_j)‖`` [rad].
        settling_time: of the tracked error (consensus error for ``"consensus"``, the largest
            member error otherwise) below ``scenario.tolerance`` — for pose formations also the
            largest position error below ``scenario.position_tolerance`` — [s]; NaN if it never
            settles.
        position_error: ``(K, N)`` [m] for pose formations (else empty).
        wall_time: seconds the closed loop took.
    """

    scenario: FormationScenario
    t: np.ndarray
    R: np.ndarray
    member_error: np.ndarray
    consensus_error: np.ndarray
    settling_time: float
    position_error: np.ndarray
    wall_time: float

    @property
    def tracked_error(self) -> np.ndarray:
        """``(K,)`` the error the settling time is measured on."""
        if self.scenario.kind == "consensus":
            return self.consensus_error
        return self.member_error.max(axis=1)

    @property
    def member_steps_per_second(self) -> float:
        """Throughput: members × integration steps / wall time."""
        steps = round((self.t[-1] - self.t[0]) / self.scenario.dt)
        return self.scenario.n * steps / max(self.wall_time, 1e-12)


def _ball(rng: np.random.Generator, n: int, radius: float) -> np.ndarray:
    """``n`` rotation vectors uniform in the ball of ``radius`` [rad]."""
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * radius * rng.uniform(size=(n, 1)) ** (1.0 / 3.0)


def _chordal_mean_error(R: np.ndarray) -> np.ndarray:
    """``(K, N)`` angle of every member to the projected (chordal) mean of ``(K, N, 3, 3)``."""
    M = so3.project(R.mean(axis=1))
    return so3.angle(np.swapaxes(M[:, None], -1, -2) @ R)


def _slowest_rate(graph: CommunicationGraph) -> float:
    """Smallest non-zero eigenvalue of the symmetrised Laplacian: ``λ₂`` on a connected graph,
    the smallest of the components' ``λ₂`` otherwise."""
    S = 0.5 * (graph.adjacency + graph.adjacency.T)
    ev = np.linalg.eigvalsh(np.diag(S.sum(axis=1)) - S)
    return float(ev[ev > 1e-9 * ev[-1]].min())


def _controller(
    sc: FormationScenario, J: np.ndarray
) -> AttitudeConsensus | LeaderFollowerConsensus:
    # the per-member PD bandwidth design; for consensus the coupling gain is divided by the
    # slowest non-zero Laplacian eigenvalue so the slowest disagreement mode has frequency ω_n
    k_R, k_W = gains_from_bandwidth(J, sc.omega_n, 1.0, error="log")
    if sc.kind == "consensus":
        k_R = k_R / _slowest_rate(sc.graph)
        return AttitudeConsensus(sc.graph, J, k_R, k_W, delay=sc.delay, predict=sc.predict)
    return LeaderFollowerConsensus(sc.graph, J, k_R, k_W, delay=sc.delay, predict=sc.predict)


def run_formation(scenario: FormationScenario, log_every: int = 1) -> FormationResult:
    """Run ``scenario`` on the batched plant (batch = members) and compute its metrics."""
    if not isinstance(scenario, FormationScenario):
        raise TypeError(f"scenario: expected a FormationScenario, got {type(scenario).__name__}")
    log_every = as_int(log_every, "log_every", 1)
    if scenario.kind == "pose":
        return _run_pose(scenario, log_every)
    sc = scenario
    rng = np.random.default_rng(sc.seed)
    N = sc.n
    if sc.kind == "consensus":
        reference: Callable[[float], AttitudeReference] = SpinReference(np.eye(3), np.zeros(3))
        R0 = so3.exp(_ball(rng, N, sc.spread))
    else:
        reference = SpinReference(np.eye(3), np.array([0.0, 0.0, 0.02]))
        R0 = so3.exp(_ball(rng, N, sc.spread))
    plant = Spacecraft(RigidBody(J_MEMBER), IdealTorqueActuator())
    with warnings.catch_warnings():
        # the split scenario is disconnected on purpose
        warnings.simplefilter("ignore", ConsensusGraphWarning)
        ctrl = _controller(sc, J_MEMBER)
    t0 = time.perf_counter()
    res = simulate(
        plant,
        ctrl,
        reference,
        plant.initial_state(R0),
        t_final=sc.duration,
        dt=sc.dt,
        control_period=sc.control_period,
        log_every=log_every,
    )
    wall = time.perf_counter() - t0
    cons = consensus_error(res.R)
    if sc.kind == "consensus":
        member = _chordal_mean_error(res.R)
        tracked = cons
    else:
        member = res.attitude_error_angle()
        tracked = member.max(axis=1)
    return FormationResult(
        sc,
        res.t,
        res.R,
        member,
        cons,
        settling_time(res.t, tracked, sc.tolerance),
        np.empty((0,)),
        wall,
    )


def _run_pose(sc: FormationScenario, log_every: int) -> FormationResult:
    m, J = 100.0, np.diag([20.0, 25.0, 30.0])
    plant = SE3Plant(m, J, method="rkmk4")
    target = OrbitingTarget(CircularOrbit(n=0.0011))
    gains = pose_gains_from_bandwidth(m, J, omega_att=sc.omega_n, omega_pos=0.5 * sc.omega_n)
    track = SE3TrackingController(m, J, gravity=plant.gravity_wrench, **gains)
    assert sc.relative_poses is not None  # checked by FormationScenario
    ctrl = PoseFormation(sc.graph, sc.relative_poses, track, delay=sc.delay, predict=sc.predict)
    reference = DockingReference(target, np.eye(4))
    # every member's nominal pose relative to the leader: compose along the tree
    N = sc.n
    A = sc.graph.adjacency
    G = np.empty((N, 4, 4))
    done = np.zeros(N, dtype=bool)
    for k in sc.graph.leaders:
        G[k], done[k] = sc.relative_poses[k], True
    while not done.all():
        for i in np.flatnonzero(~done):
            p = int(np.flatnonzero(A[i])[0])
            if done[p]:
                G[i], done[i] = G[p] @ sc.relative_poses[i], True
    rng = np.random.default_rng(sc.seed)
    g0 = np.empty((N, 4, 4))
    xi0 = np.empty((N, 6))
    rot = _ball(rng, N, sc.spread)
    pos = _ball(rng, N, sc.position_spread)
    for i in range(N):
        gi, xii = DockingReference(target, G[i]).offset_state(0.0, rot[i : i + 1], pos[i : i + 1])
        g0[i], xi0[i] = gi[0], xii[0]
    t0 = time.perf_counter()
    res = simulate_pose(
        plant,
        ctrl,
        reference,
        g0,
        xi0,
        t_final=sc.duration,
        dt=sc.dt,
        control_period=sc.control_period,
        log_every=log_every,
    )
    wall = time.perf_counter() - t0
    # errors against the *nominal* formation (every member's pose relative to the flown LVLH
    # frame), not the tracking controller's per-sample target
    g_T = np.stack([target.pose(float(t)) for t in res.t])
    g_nom = g_T[:, None] @ G[None]
    R = res.g[..., :3, :3]
    member = so3.angle(np.swapaxes(g_nom[..., :3, :3], -1, -2) @ R)
    pos_err = np.linalg.norm(res.g[..., :3, 3] - g_nom[..., :3, 3], axis=-1)
    # relative attitudes differ by design: the consensus error of the formation is measured on
    # R_i G_iᵀ (each member's attitude mapped back to the leader's frame)
    R_back = R @ np.swapaxes(G[None, :, :3, :3], -1, -2)
    cons = consensus_error(R_back)
    # settled when both the attitudes and the positions have settled
    t_att = settling_time(res.t, member.max(axis=1), sc.tolerance)
    t_pos = settling_time(res.t, pos_err.max(axis=1), sc.position_tolerance)
    t_set = math.nan if math.isnan(t_att) or math.isnan(t_pos) else max(t_att, t_pos)
    return FormationResult(sc, res.t, R, member, cons, t_set, pos_err, wall)


# ------------------------------------------------------------------------------- output
def formation_table(results: Sequence[FormationResult]) -> str:
    """A Markdown table: members, graph, delay, final consensus and member errors, the settling
    tolerance (attitude [rad], and position [m] for pose formations), settling time,
    throughput. Settling times compare only between rows with the same tolerance."""
    if isinstance(results, (str, bytes)) or not isinstance(results, Sequence):
        raise TypeError(f"results: expected a sequence of FormationResult, got {results!r}")
    for r in results:
        if not isinstance(r, FormationResult):
            raise TypeError(f"results: expected FormationResult items, got {type(r).__name__}")
    rows = [
        "| scenario | N | kind | delay | consensus err. end [rad] | max member err. end [rad] "
        "| tolerance | settling [s] | member-steps/s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        s = r.scenario
        st = "never" if math.isnan(r.settling_time) else f"{r.settling_time:.1f}"
        # the settling time depends on the tolerance: show it so rows compare honestly
        tol = f"{s.tolerance:g} rad"
        if s.kind == "pose":
            tol += f", {s.position_tolerance:g} m"
        rows.append(
            f"| {s.name} | {s.n} | {s.kind} | {s.delay} | {r.consensus_error[-1]:.2e} | "
            f"{r.member_error[-1].max():.2e} | {tol} | {st} | {r.member_steps_per_second:,.0f} |"
        )
    return "\n".join(rows)


def plot_formation(result: FormationResult, path: str | Path) -> Path:
    """Write a figure of every member's attitude error and the consensus error (and, for pose
    formations, every member's position error) to ``path`` (PNG); return the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    r = result
    n_ax = 3 if r.position_error.size else 2
    fig, axes = plt.subplots(n_ax, 1, figsize=(7, 2.6 * n_ax), sharex=True)
    floor = 1e-12
    for i in range(r.scenario.n):
        axes[0].semilogy(r.t, np.maximum(r.member_error[:, i], floor), label=f"member {i}")
    what = "chordal mean" if r.scenario.kind == "consensus" else "desired attitude"
    axes[0].set_ylabel(f"angle to {what} [rad]")
    axes[0].legend(fontsize=7, ncol=5)
    axes[1].semilogy(r.t, np.maximum(r.consensus_error, floor), "k")
    # the tolerance on the panel of the error the settling time is measured on
    ax = axes[1] if r.scenario.kind == "consensus" else axes[0]
    ax.axhline(r.scenario.tolerance, color="grey", ls="--", lw=0.8)
    if n_ax == 3:
        axes[2].axhline(r.scenario.position_tolerance, color="grey", ls="--", lw=0.8)
    if not math.isnan(r.settling_time):
        for a in axes:
            a.axvline(r.settling_time, color="tab:red", ls=":", lw=0.8)
    axes[1].set_ylabel("max_ij |log(R_iᵀR_j)| [rad]")
    if n_ax == 3:
        for i in range(r.scenario.n):
            axes[2].semilogy(r.t, np.maximum(r.position_error[:, i], floor))
        axes[2].set_ylabel("position error [m]")
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(f"{r.scenario.name}: {r.scenario.description}", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def measure_throughput(n: int, steps: int = 200, repeats: int = 200) -> dict[str, float]:
    """Leaderless consensus on a ring of ``n`` members: closed-loop member-steps per second over
    ``steps`` integration steps (control every step), and the mean wall time of one ``command``
    call for all ``n`` members over ``repeats`` calls [s] of each law: ``command_s`` (leaderless
    consensus), ``command_leader_follower_s`` and ``command_pose_s`` (:class:`PoseFormation`
    on a binary tree; at most 50 calls). Wall-clock numbers: machine-dependent."""
    n = as_int(n, "n", 3)
    steps = as_int(steps, "steps", 1)
    repeats = as_int(repeats, "repeats", 1)
    for name, v, cap in (
        ("n", n, 10_000),
        ("steps", steps, 100_000),
        ("repeats", repeats, 100_000),
    ):
        if v > cap:
            raise ValueError(f"{name}: must be <= {cap} (a measurement, not a campaign), got {v}")
    sc = FormationScenario("throughput", "", "consensus", CommunicationGraph.ring(n), 1.0)
    rng = np.random.default_rng(0)
    R0 = so3.exp(_ball(rng, n, 0.5))
    plant = Spacecraft(RigidBody(J_MEMBER), IdealTorqueActuator())
    ctrl = _controller(sc, J_MEMBER)
    ref = SpinReference(np.eye(3), np.zeros(3))
    t0 = time.perf_counter()
    simulate(
        plant, ctrl, ref, plant.initial_state(R0), t_final=steps * 0.1, dt=0.1, log_every=steps
    )
    wall = time.perf_counter() - t0
    state = AttitudeState(R0, np.zeros((n, 3)))
    r0 = ref(0.0)
    ctrl.reset(0.0, n)
    c0 = time.perf_counter()
    for _ in range(repeats):
        ctrl.command(0.0, state, r0)
    per_call = (time.perf_counter() - c0) / repeats
    # the leader–follower law and the SE(3) formation on a binary tree of the same size
    tree = _binary_tree(n)
    k_R, k_W = gains_from_bandwidth(J_MEMBER, 0.3, 1.0, error="log")
    lf = LeaderFollowerConsensus(tree, J_MEMBER, k_R, k_W)
    lf.reset(0.0, n)
    c0 = time.perf_counter()
    for _ in range(repeats):
        lf.command(0.0, state, r0)
    per_call_lf = (time.perf_counter() - c0) / repeats
    m, J = 100.0, np.diag([20.0, 25.0, 30.0])
    track = SE3TrackingController(m, J, **pose_gains_from_bandwidth(m, J, 0.1, 0.05))
    pose = PoseFormation(tree, np.stack([np.eye(4)] * n), track)
    pose.reset(0.0, n)
    g = se3.from_rt(R0, np.array([7.0e6, 0.0, 0.0]) + 10.0 * rng.normal(size=(n, 3)))
    ps = PoseState(g, np.zeros((n, 6)))
    pref = PoseReference.regulation(se3.from_rt(np.eye(3), np.array([7.0e6, 0.0, 0.0])))
    k_pose = min(repeats, 50)
    c0 = time.perf_counter()
    for _ in range(k_pose):
        pose.command(0.0, ps, pref)
    per_call_pose = (time.perf_counter() - c0) / k_pose
    return {
        "n": float(n),
        "member_steps_per_s": n * steps / wall,
        "command_s": per_call,
        "command_leader_follower_s": per_call_lf,
        "command_pose_s": per_call_pose,
    }


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m spacecraft.formation [--out DIR] [--only NAME ...] [--throughput]``."""
    p = argparse.ArgumentParser(
        prog="python -m spacecraft.formation",
        description="Run the formation scenarios (attitude consensus on SO(3), relative-pose "
        "formation on SE(3)) and print a table.",
    )
    p.add_argument("--out", type=Path, default=None, help="write one figure per scenario here")
    p.add_argument("--only", nargs="*", default=None, help="scenario names (default: all)")
    p.add_argument(
        "--throughput", action="store_true", help="also measure member-steps/s at N = 10 and 100"
    )
    a = p.parse_args(argv)
    names = list(FORMATION_SCENARIOS) if not a.only else a.only
    for nm in names:
        if nm not in FORMATION_SCENARIOS:
            p.error(f"--only: unknown scenario {nm!r}; known: {', '.join(FORMATION_SCENARIOS)}")
    # a short warm-up run first: imports and first-call costs would otherwise land in the first
    # scenario's throughput column
    run_formation(FormationScenario("warm-up", "", "consensus", CommunicationGraph.ring(3), 0.3))
    results = [run_formation(formation_scenario(nm)) for nm in names]
    print(formation_table(results))
    if a.out is not None:
        for r in results:
            print(f"wrote {plot_formation(r, a.out / f'formation_{r.scenario.name}.png')}")
    if a.throughput:
        print(
            "\n| N | member-steps/s (consensus) | command() [ms]: consensus | leader-follower "
            "| SE(3) formation |\n|---|---|---|---|---|"
        )
        for n in (10, 100):
            m = measure_throughput(n)
            print(
                f"| {n} | {m['member_steps_per_s']:,.0f} | {1e3 * m['command_s']:.3f} | "
                f"{1e3 * m['command_leader_follower_s']:.3f} | {1e3 * m['command_pose_s']:.3f} |"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
