"""Distributed attitude consensus on SO(3) for a formation of spacecraft.

The members of a formation talk over a *communication graph*: ``a_ij > 0`` means member ``i``
receives member ``j``'s attitude and rate (weight ``a_ij``). Its Laplacian ``L = D − A``
(``D = diag(Σ_j a_ij)``) has zero row sums; for an undirected graph the multiplicity of its
eigenvalue 0 is the number of connected components (Godsil & Royle, *Algebraic Graph Theory*,
Springer 2001, ch. 13), and the smallest non-zero eigenvalue ``λ₂`` (the algebraic connectivity)
sets the slowest consensus mode. On a directed graph consensus needs a rooted spanning tree (Ren &
Beard, "Consensus seeking in multiagent systems under dynamically changing interaction
topologies", *IEEE Trans. Automatic Control* 50(5), 2005).

Because the simulator's plant is batched, the batch axis **is** the formation: a controller here is
handed all ``B = N`` members at once and computes each member's torque from its own state and its
neighbours' states only (the other members' rows never enter member ``i``'s torque — tested).

Laws (``R_i`` body → inertial, ``Ω_i`` body rate, ``J_i`` inertia; ``φ_ij = log(R_iᵀR_j)^∨`` is the
rotation from ``i`` to ``j`` in ``i``'s body axes, which is also its value in ``j``'s axes, so
``φ_ji = −φ_ij``):

- :class:`AttitudeConsensus` (leaderless; the survey's "behaviour-based" family)::

      τ_i = Ω_i × J_iΩ_i + k_R Σ_j a_ij φ_ij − k_Ω Ω_i.

  Stability (undirected graph, all pairwise angles < π so every ``log`` is smooth): with
  ``V = ½ Σ_i Ω_iᵀJ_iΩ_i + ½ k_R Σ_{edges} a_ij ‖φ_ij‖²`` and ``d/dt ½‖φ_ij‖² = φ_ijᵀ(Ω_j − Ω_i)``
  (because ``φᵀ J_r(φ)⁻¹ = φᵀ`` and ``R_ij φ_ij = φ_ij``) one gets ``V̇ = −k_Ω Σ_i ‖Ω_i‖² ≤ 0``:
  the formation comes to rest at an equilibrium ``Σ_j a_ij φ_ij = 0``. Assumptions of this
  argument: an undirected graph, a **scalar** ``k_R`` (a vector or matrix ``k_R`` breaks the
  edge cancellation and the potential; the constructor warns with
  :class:`ConsensusAssumptionWarning`), any SPD ``k_Ω``, no communication delay, the members'
  inertias known exactly, pairwise angles below π. Consensus ``R_i = R_j`` from an open ball of
  radius π/2 is a result for the **first-order** (kinematic) model ``Ṙ_i = R_i ω_i`` with the
  rate as input (Sarlette, Sepulchre & Leonard, "Autonomous rigid body attitude
  synchronization", *Automatica* 45(2), 2009). For this torque-level (second-order) law it is
  claimed only for starts **at rest** inside the ball whose energy keeps them inside: initial
  rates carry the members out of the ball (a ring with initial rates of standard deviation
  1 rad/s ended at 180° disagreement in 2 of 40 runs). From arbitrary starts rings can also rest
  in "twisted" non-consensus equilibria, which are stable with open basins, so consensus is
  almost-global only on some graphs (trees). On a disconnected graph each component agrees on
  its own attitude and the formation as a whole does not (tested).

- :class:`LeaderFollowerConsensus` (the survey's leader–follower family): the members in
  ``graph.leaders`` track the reference ``R_d(t)`` with the geometric tracking law on the log
  error; every follower tracks the weighted geometric average of its neighbours::

      e_R,i = −(1/d_i) Σ_j a_ij φ_ij,   ω̄_i = (1/d_i) Σ_j a_ij R_iᵀR_j Ω_j,   e_Ω,i = Ω_i − ω̄_i,
      τ_i = −k_R e_R,i − k_Ω e_Ω,i + Ω_i × J_iΩ_i − J_i (Ω_i^ ω̄_i),

  ``d_i = Σ_j a_ij``. With one neighbour (a tree) this is the geometric PD of Lee (2012) /
  Jiang, Meng & Yang (2023, Lemma 4) tracking the parent with the parent's angular acceleration
  (not communicated) left out, so ``J ė_Ω = −k_R e_R − k_Ω e_Ω + J R̃ᵀΩ̇_j``: a cascade in which
  each follower converges once its parent does (and follows a constant-rate leader exactly).
  The leaders ignore their own neighbours. Every follower must be reachable from a leader along
  the direction information flows.

Both take an optional communication delay of ``delay`` control periods: the neighbours' states
used at a sample are the ones of ``delay`` samples earlier (a ring buffer in the controller; before
``delay`` samples exist the oldest one is held), while each member's own state is current — the
setting of Nazari, Butcher, Yucelen et al., "Decentralized consensus control of a rigid-body
spacecraft formation with communication delay", *J. Guidance, Control, and Dynamics* 39(4), 2016.
With ``predict=True`` a received state, time-stamped ``τ`` seconds ago, is propagated to the present
at its own constant body rate, ``R̂_j = R_j(t−τ) exp(τ Ω_j(t−τ)^)`` (on SE(3) to second order,
see :class:`PoseFormation`): exact for a neighbour turning at a constant body rate (a spin about a
principal axis), which removes the lag a delay otherwise causes.

The survey: Jiang, Meng & Yang, "A survey on spacecraft attitude and orbit control: differential
geometric control approaches" (in Chinese), *Control and Decision* 38(8), 2079–2092, 2023, §4.1
(eqs. 17–18 give the relative attitude dynamics these laws act on) and its references on
leader–follower and leaderless attitude consensus.

Units: ``J`` [kg·m²], ``k_R`` [N·m/rad], ``k_Omega`` [N·m·s/rad], torque [N·m].
"""

from __future__ import annotations

import warnings
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .._linalg import cross as _cross
from .._linalg import matvec as _mv
from .._validation import as_array, as_int, as_scalar, check_bool, check_inertia
from ..lie import se3, so3
from .base import AttitudeController, AttitudeReference, AttitudeState, finite_command
from .geometric_pd import check_gain
from .se3_control import (
    PoseController,
    PoseReference,
    PoseState,
    coriolis_wrench_unchecked,
)

__all__ = [
    "CommunicationGraph",
    "AttitudeConsensus",
    "LeaderFollowerConsensus",
    "PoseFormation",
    "ConsensusGraphWarning",
    "ConsensusAssumptionWarning",
    "consensus_error",
    "pairwise_angles",
]


class ConsensusGraphWarning(UserWarning):
    """The graph lacks the connectivity a consensus law needs (the law still runs: the members
    of each part agree among themselves, the formation as a whole does not)."""


class ConsensusAssumptionWarning(UserWarning):
    """A consensus law was configured outside the assumptions of its stability argument (e.g. a
    vector or matrix ``k_R``: the Lyapunov cancellation needs a scalar coupling gain). The law
    still runs; its convergence is then not covered by the argument."""


def _scalar_coupling_gain(K: float | np.ndarray) -> float | np.ndarray:
    """A scalar ``k_R`` as ``float``; a multiple of the identity is folded to its scalar; any
    other vector/matrix gain is kept with a :class:`ConsensusAssumptionWarning`."""
    if isinstance(K, float):
        return K
    k = float(K[0, 0])
    if np.array_equal(K, k * np.eye(3)):
        return k
    warnings.warn(
        "k_R: a vector or matrix coupling gain breaks the Lyapunov argument of the consensus "
        "laws — the cancellation φ_jiᵀ(k_R φ_ji) = φ_ijᵀ(k_R φ_ij) across an edge and the "
        "potential ½k_R‖φ‖² of the log error need a scalar k_R (φ_ij and φ_ji are expressed in "
        "different body axes); the law runs, but neither rest nor consensus is covered. Use a "
        "scalar k_R (k_Omega may be any SPD gain)",
        ConsensusAssumptionWarning,
        stacklevel=4,
    )
    return K


#: the longest communication delay accepted [control periods] (a ring buffer of this many states)
MAX_DELAY = 100_000


def _delay(d: object) -> int:
    d = as_int(d, "delay", 0)
    if d > MAX_DELAY:
        raise ValueError(f"delay: must be <= {MAX_DELAY} control periods, got {d}")
    return d


def _adjacency(a: object) -> np.ndarray:
    A = as_array(a, "adjacency")
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"adjacency: expected a square (N, N) matrix, got shape {A.shape}")
    if A.shape[0] < 2:
        raise ValueError(f"adjacency: a formation needs at least 2 members, got {A.shape[0]}")
    if np.any(A < 0.0):
        raise ValueError(f"adjacency: weights must be >= 0, got min {float(A.min())!r}")
    if np.any(np.diag(A) != 0.0):
        raise ValueError("adjacency: the diagonal must be zero (no self-loops)")
    A = A.copy()  # never alias the caller's array
    A.setflags(write=False)
    return A


@dataclass(frozen=True)
class CommunicationGraph:
    """Weighted (possibly directed) communication graph of an ``N``-member formation.

    Args:
        adjacency: ``(N, N)`` non-negative weights, zero diagonal; ``a_ij > 0`` means member
            ``i`` receives member ``j``'s state. Copied (the caller's array is never aliased).
        leaders: members that see the reference attitude (the leader set of a leader–follower
            law); empty for leaderless consensus.

    Build common topologies with :meth:`ring`, :meth:`complete`, :meth:`path`, :meth:`tree`
    and :meth:`from_edges`.
    """

    adjacency: np.ndarray
    leaders: tuple[int, ...] = ()
    _edges: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        A = _adjacency(self.adjacency)
        object.__setattr__(self, "adjacency", A)
        if isinstance(self.leaders, (str, bytes)) or not isinstance(self.leaders, Iterable):
            raise TypeError(f"leaders: expected a sequence of member indices, got {self.leaders!r}")
        lead = tuple(as_int(k, "leaders", 0) for k in self.leaders)
        n = A.shape[0]
        for k in lead:
            if k >= n:
                raise ValueError(f"leaders: member {k} does not exist (the graph has {n} members)")
        if len(set(lead)) != len(lead):
            raise ValueError(f"leaders: repeated member in {lead}")
        object.__setattr__(self, "leaders", lead)
        i, j = np.nonzero(A)
        object.__setattr__(self, "_edges", (i, j, A[i, j]))

    # ---------------------------------------------------------------- constructors
    @classmethod
    def from_edges(
        cls,
        n: int,
        edges: Sequence[tuple[int, int]],
        weight: float = 1.0,
        undirected: bool = True,
        leaders: Sequence[int] = (),
    ) -> CommunicationGraph:
        """Graph of ``n`` members from ``(i, j)`` pairs: ``i`` receives ``j`` (and, if
        ``undirected``, ``j`` receives ``i``), every edge with weight ``weight`` > 0."""
        n = as_int(n, "n", 2)
        w = as_scalar(weight, "weight")
        if not w > 0.0:
            raise ValueError(f"weight: must be > 0, got {w}")
        undirected = check_bool(undirected, "undirected")
        A = np.zeros((n, n))
        for e in edges:
            if not isinstance(e, (tuple, list)) or len(e) != 2:
                raise ValueError(f"edges: each edge must be a pair (i, j), got {e!r}")
            a, b = as_int(e[0], "edges", 0), as_int(e[1], "edges", 0)
            if a >= n or b >= n:
                raise ValueError(f"edges: edge {e!r} names a member outside 0..{n - 1}")
            if a == b:
                raise ValueError(f"edges: self-loop {e!r}")
            A[a, b] = w
            if undirected:
                A[b, a] = w
        return cls(A, tuple(leaders))

    @classmethod
    def ring(cls, n: int, weight: float = 1.0, leaders: Sequence[int] = ()) -> CommunicationGraph:
        """Undirected ring (cycle) of ``n >= 3`` members: member ``i`` talks to ``i ± 1``."""
        n = as_int(n, "n", 3)
        return cls.from_edges(n, [(i, (i + 1) % n) for i in range(n)], weight, True, leaders)

    @classmethod
    def path(cls, n: int, weight: float = 1.0, leaders: Sequence[int] = ()) -> CommunicationGraph:
        """Undirected path (chain) ``0 – 1 – … – n−1``."""
        n = as_int(n, "n", 2)
        return cls.from_edges(n, [(i, i + 1) for i in range(n - 1)], weight, True, leaders)

    @classmethod
    def complete(
        cls, n: int, weight: float = 1.0, leaders: Sequence[int] = ()
    ) -> CommunicationGraph:
        """Every member talks to every other one."""
        n = as_int(n, "n", 2)
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        return cls.from_edges(n, pairs, weight, True, leaders)

    @classmethod
    def tree(cls, parents: Sequence[int], weight: float = 1.0) -> CommunicationGraph:
        """Directed leader–follower tree: ``parents[i]`` is the member ``i`` listens to, ``-1``
        for the root, which becomes the (only) leader. Exactly one root; no cycles."""
        if isinstance(parents, (str, bytes)) or not isinstance(parents, Iterable):
            raise TypeError(f"parents: expected a sequence of member indices, got {parents!r}")
        par = [as_int(p, "parents", -1) for p in parents]
        n = len(par)
        if n < 2:
            raise ValueError(f"parents: a formation needs at least 2 members, got {n}")
        roots = [i for i, p in enumerate(par) if p == -1]
        if len(roots) != 1:
            raise ValueError(f"parents: expected exactly one root (-1), got {len(roots)}")
        for i, p in enumerate(par):
            if p >= n or p == i:
                raise ValueError(f"parents: member {i} has invalid parent {p}")
        for i in range(n):  # every member must reach the root without revisiting a member
            seen, k = set(), i
            while par[k] != -1:
                if k in seen:
                    raise ValueError(f"parents: member {i} is on a cycle, not a tree")
                seen.add(k)
                k = par[k]
        w = as_scalar(weight, "weight")
        if not w > 0.0:
            raise ValueError(f"weight: must be > 0, got {w}")
        A = np.zeros((n, n))
        for i, p in enumerate(par):
            if p >= 0:
                A[i, p] = w
        return cls(A, (roots[0],))

    # ---------------------------------------------------------------- properties
    @property
    def n(self) -> int:
        """Number of members ``N``."""
        return int(self.adjacency.shape[0])

    @property
    def degree(self) -> np.ndarray:
        """In-degrees ``d_i = Σ_j a_ij`` ``(N,)``."""
        return self.adjacency.sum(axis=1)

    @property
    def laplacian(self) -> np.ndarray:
        """``L = D − A`` ``(N, N)``: rows sum to zero."""
        return np.diag(self.degree) - self.adjacency

    @property
    def is_undirected(self) -> bool:
        """``A == Aᵀ``."""
        return bool(np.array_equal(self.adjacency, self.adjacency.T))

    @property
    def n_components(self) -> int:
        """Number of (weakly) connected components, edge directions ignored."""
        return int(csgraph.connected_components(self.adjacency, directed=False)[0])

    @property
    def is_connected(self) -> bool:
        """One (weakly) connected component."""
        return self.n_components == 1

    @property
    def algebraic_connectivity(self) -> float:
        """``λ₂`` of the Laplacian of the symmetrised graph ``(A + Aᵀ)/2`` (0 when
        disconnected)."""
        S = 0.5 * (self.adjacency + self.adjacency.T)
        ev = np.linalg.eigvalsh(np.diag(S.sum(axis=1)) - S)
        return float(max(ev[1], 0.0))

    def informed_by(self, sources: Iterable[int]) -> np.ndarray:
        """``(N,)`` bool: the members whose state depends on ``sources`` — reachable from them
        along the direction information flows (``j → i`` when ``a_ij > 0``)."""
        out = np.zeros(self.n, dtype=bool)
        flow = sparse.csr_matrix(self.adjacency.T)  # row j lists the members j informs
        for s in sources:
            k = as_int(s, "sources", 0)
            if k >= self.n:
                raise ValueError(f"sources: member {k} does not exist (the graph has {self.n})")
            out[csgraph.breadth_first_order(flow, k, directed=True, return_predecessors=False)] = (
                True
            )
        return out

    @property
    def has_spanning_tree(self) -> bool:
        """Some member informs every member (a rooted spanning tree exists): the condition for
        leaderless consensus on a directed graph; for an undirected one it is connectedness."""
        return any(self.informed_by([k]).all() for k in range(self.n))

    def check_batch(self, batch_size: object, name: str = "batch_size") -> int:
        """Raise ``ValueError`` naming ``name`` unless the batch has exactly ``N`` members."""
        B = as_int(batch_size, name, 1)
        if B != self.n:
            raise ValueError(
                f"{name}: the formation has {B} spacecraft but graph has {self.n} members; "
                "the batch axis is the formation, so they must be equal"
            )
        return B


# ------------------------------------------------------------------------------- metrics
def pairwise_angles(R: object) -> np.ndarray:
    """``(..., N, N)`` angles ``‖log(R_iᵀR_j)‖`` [rad] between all members of ``(..., N, 3, 3)``
    (the accurate ``atan2`` form of :func:`liecontrol.lie.so3.angle`; memory ∝ ``N²``)."""
    R = so3.validate(R, "R", atol=1e-6)
    if R.ndim < 3:
        raise ValueError(f"R: expected shape (..., N, 3, 3), got {R.shape}")
    return so3.angle_unchecked(np.swapaxes(R, -1, -2)[..., :, None, :, :] @ R[..., None, :, :, :])


def _approx_angles(F: np.ndarray) -> np.ndarray:
    """Angles from ``cos θ_ij = (tr(R_iᵀR_j) − 1)/2`` for flattened ``(…, N, 9)`` rotations: one
    matrix product for all pairs, but ``arccos`` loses accuracy below ~1e-7 rad."""
    c = 0.5 * (F @ np.swapaxes(F, -1, -2) - 1.0)
    return np.arccos(np.clip(c, -1.0, 1.0))


def consensus_error(R: object) -> np.ndarray:
    """Consensus error ``max_ij ‖log(R_iᵀR_j)‖`` [rad] of ``(..., N, 3, 3)`` attitudes → ``(...)``.

    The maximising pair is found with the trace identity ``tr(R_iᵀR_j) = Σ R_i ⊙ R_j`` (one
    matrix product for all pairs) and its angle recomputed with the accurate ``atan2`` form of
    :func:`liecontrol.lie.so3.angle`; samples whose pairs all look closer than 1e-6 rad (where
    ``arccos`` cannot rank them) are evaluated pair by pair with :func:`pairwise_angles`.
    """
    R = so3.validate(R, "R", atol=1e-6)
    if R.ndim < 3 or R.shape[-3] < 2:
        raise ValueError(f"R: expected shape (..., N, 3, 3) with N >= 2, got {R.shape}")
    N = R.shape[-3]
    Rf = R.reshape(-1, N, 3, 3)
    ang = _approx_angles(Rf.reshape(-1, N, 9))
    flat = ang.reshape(-1, N * N)
    k = np.argmax(flat, axis=-1)
    i, j = np.divmod(k, N)
    rows = np.arange(Rf.shape[0])
    out = so3.angle_unchecked(np.swapaxes(Rf[rows, i], -1, -2) @ Rf[rows, j])
    for r in np.flatnonzero(flat.max(axis=-1) < 1e-6):
        out[r] = pairwise_angles(Rf[r]).max()
    return out.reshape(R.shape[:-3])


# ------------------------------------------------------------------------------- laws
class _ConsensusBase(AttitudeController):
    """Shared validation, gains, delay buffer and neighbour sums."""

    def __init__(
        self,
        graph: CommunicationGraph,
        J: object,
        k_R: object,
        k_Omega: object,
        delay: int = 0,
        require_connected: bool = False,
        predict: bool = False,
    ) -> None:
        if not isinstance(graph, CommunicationGraph):
            raise TypeError(f"graph: expected a CommunicationGraph, got {type(graph).__name__}")
        self.graph = graph
        J = check_inertia(J, "J")
        if J.shape not in ((3, 3), (graph.n, 3, 3)):
            raise ValueError(
                f"J: expected shape (3, 3) or ({graph.n}, 3, 3) (one per member), got {J.shape}"
            )
        self.J = J.copy()
        self.J.setflags(write=False)
        self.k_R = _scalar_coupling_gain(check_gain(k_R, "k_R"))
        self.k_Omega = check_gain(k_Omega, "k_Omega")
        self.delay = _delay(delay)
        self.require_connected = check_bool(require_connected, "require_connected")
        self.predict = check_bool(predict, "predict")
        i, j, w = graph._edges
        self._ei, self._ej = i, j
        # member i's sum over its edges: S (N × E) with S[i, e] = a_ij
        self._S = sparse.csr_matrix((w, (i, np.arange(i.size))), shape=(graph.n, i.size))
        self._buf: deque[tuple[float, np.ndarray, np.ndarray]] = deque(maxlen=self.delay + 1)
        self._diag: dict[str, np.ndarray] = {}
        self._B: int | None = None

    def _graph_problem(self, message: str) -> None:
        if self.require_connected:
            raise ValueError(f"graph: {message}")
        warnings.warn(f"graph: {message}", ConsensusGraphWarning, stacklevel=3)

    def reset(self, t0: float, batch_size: int) -> None:
        as_scalar(t0, "t0")
        self._B = self.graph.check_batch(batch_size)
        self._buf.clear()
        self._diag = {}

    def _state(self, state: AttitudeState) -> tuple[np.ndarray, np.ndarray]:
        if not isinstance(state, AttitudeState):
            raise TypeError(f"state: expected an AttitudeState, got {type(state).__name__}")
        if self._B is None:
            raise RuntimeError("reset: call reset(t0, batch_size) before command")
        R = so3.validate(state.R, "state.R", atol=1e-6)
        w = as_array(state.omega, "state.omega", (3,))
        if R.ndim != 3 or w.shape != (R.shape[0], 3):
            raise ValueError(
                f"state: expected R (B, 3, 3) and omega (B, 3), got {R.shape}, {w.shape}"
            )
        self.graph.check_batch(R.shape[0], "state")
        return R, w

    def _neighbours(self, t: float, R: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Push the current states; return the (possibly delayed) ones neighbours see, propagated
        to ``t`` at constant body rate when ``predict``."""
        self._buf.append((t, R, w))
        t_s, Rn, wn = self._buf[0]  # the oldest kept: `delay` samples ago once the buffer is full
        tau = t - t_s
        if self.predict and tau > 0.0:
            Rn = Rn @ so3.exp(tau * wn)
        return Rn, wn

    def _edge_terms(self, R: np.ndarray, Rn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``R_iᵀR̂_j`` and ``φ_ij = log(R_iᵀR̂_j)`` for every edge ``(i, j)``."""
        Rij = np.swapaxes(R[self._ei], -1, -2) @ Rn[self._ej]
        return Rij, so3.log_unchecked(Rij)

    def _J_times(self, x: np.ndarray) -> np.ndarray:
        return _mv(self.J, x) if self.J.ndim == 3 else x @ self.J.T

    def diagnostics(self) -> dict[str, np.ndarray]:
        return dict(self._diag)


def _gain(K: float | np.ndarray, x: np.ndarray) -> np.ndarray:
    return K * x if isinstance(K, float) else x @ K.T


class AttitudeConsensus(_ConsensusBase):
    """Leaderless attitude consensus on SO(3) (module docstring)::

        τ_i = Ω_i × J_iΩ_i + k_R Σ_j a_ij log(R_iᵀR̂_j)^∨ − k_Ω Ω_i,

    ``R̂_j`` member ``j``'s attitude as received (``delay`` control periods old). The reference
    passed to :meth:`command` is ignored: the members agree on an attitude they choose together.
    With an undirected graph, a scalar ``k_R`` and no delay the Lyapunov function of the module
    docstring proves the formation comes to rest (at some equilibrium, possibly a twisted one on
    a ring). Consensus from a ball of radius π/2 is the first-order (kinematic) result of
    Sarlette, Sepulchre & Leonard (2009); for this torque law it is assumed only for starts at
    rest inside the ball (initial rates can carry members out of it; module docstring).

    Args:
        graph: :class:`CommunicationGraph` of the ``N`` members (the batch size must be ``N``).
        J: inertia ``(3, 3)`` shared or ``(N, 3, 3)`` per member [kg·m²].
        k_R: coupling gain [N·m/rad]: a positive scalar (the stability argument needs one); a
            3-vector or SPD 3×3 is accepted with a :class:`ConsensusAssumptionWarning` (a
            multiple of the identity is folded to its scalar without one).
        k_Omega: rate damping gain: positive scalar, 3-vector or SPD 3×3 [N·m·s/rad].
        delay: communication delay in control periods (integer >= 0).
        predict: propagate each received state to the present at its constant body rate
            (module docstring); no effect without a delay.
        require_connected: without a rooted spanning tree consensus is impossible:
            ``True`` raises ``ValueError``, ``False`` (default) issues a
            :class:`ConsensusGraphWarning` and runs (each part agrees on its own attitude).

    ``diagnostics()``: ``e_R`` ``(N, 3)`` the coupling ``−Σ_j a_ij φ_ij`` and ``consensus``
    ``(N,)`` each member's largest angle to a neighbour (as received).
    """

    def __init__(
        self,
        graph: CommunicationGraph,
        J: object,
        k_R: object,
        k_Omega: object,
        delay: int = 0,
        require_connected: bool = False,
        predict: bool = False,
    ) -> None:
        super().__init__(graph, J, k_R, k_Omega, delay, require_connected, predict)
        if not graph.has_spanning_tree:
            self._graph_problem(
                f"no member informs all others ({graph.n_components} component(s)): the "
                "members cannot reach consensus, only each part among itself"
            )

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        t = as_scalar(t, "t")
        R, w = self._state(state)
        Rn, _ = self._neighbours(t, R, w)
        _, phi = self._edge_terms(R, Rn)
        coupling = self._S @ phi  # Σ_j a_ij φ_ij  (N, 3)
        u = _cross(w, self._J_times(w)) + _gain(self.k_R, coupling) - _gain(self.k_Omega, w)
        ang = np.zeros(R.shape[0])
        np.maximum.at(ang, self._ei, np.linalg.norm(phi, axis=-1))
        self._diag = {"e_R": -coupling, "consensus": ang}
        return finite_command(u, w)


class LeaderFollowerConsensus(_ConsensusBase):
    """Leader–follower attitude consensus on SO(3) (module docstring).

    Leaders (``graph.leaders``): geometric tracking of the reference on the log error,
    ``τ = −k_R log(R_dᵀR)^∨ − k_Ω e_Ω + Ω × JΩ − J(Ω^ RᵀR_dΩ_d − RᵀR_dΩ̇_d)``,
    ``e_Ω = Ω − RᵀR_dΩ_d``. Followers: the same law with ``R_d, Ω_d`` replaced by the
    weighted geometric average of their neighbours (``e_R,i = −(1/d_i) Σ_j a_ij φ_ij``,
    ``ω̄_i = (1/d_i) Σ_j a_ij R_iᵀR̂_jΩ̂_j``) and no acceleration feed-forward (not
    communicated).

    Assumptions of the convergence argument (module docstring): a tree (each follower with one
    neighbour: the cascade of geometric PD loops), a scalar ``k_R`` (a vector or matrix one
    warns: :class:`ConsensusAssumptionWarning`), no delay, exact inertias; a follower tracks a
    constant-rate parent exactly and a maneuvering one with an error driven by the parent's
    acceleration (not communicated). On other graphs convergence is not proved here.

    Args: as :class:`AttitudeConsensus`; ``graph.leaders`` must be non-empty. A follower that
    no leader informs (``graph.informed_by(graph.leaders)``), or one without neighbours, never
    learns the reference: ``require_connected=True`` raises ``ValueError``, otherwise a
    :class:`ConsensusGraphWarning` (such a member with no neighbours gets a pure rate damper).

    ``diagnostics()``: ``e_R``, ``e_Omega`` ``(N, 3)`` and ``attitude_error`` ``(N,)`` =
    ``‖e_R‖`` (to the reference for leaders, to the neighbour average for followers).
    """

    def __init__(
        self,
        graph: CommunicationGraph,
        J: object,
        k_R: object,
        k_Omega: object,
        delay: int = 0,
        require_connected: bool = False,
        predict: bool = False,
    ) -> None:
        super().__init__(graph, J, k_R, k_Omega, delay, require_connected, predict)
        if not graph.leaders:
            raise ValueError("graph: a leader–follower law needs graph.leaders (none given)")
        informed = graph.informed_by(graph.leaders)
        if not informed.all():
            lost = np.flatnonzero(~informed).tolist()
            self._graph_problem(f"members {lost} are not informed by any leader {graph.leaders}")
        lead = np.zeros(graph.n, dtype=bool)
        lead[list(graph.leaders)] = True
        self._lead = lead
        # followers' edges only, weights normalised by the in-degree (leaders ignore neighbours)
        i, j, wgt = graph._edges
        keep = ~lead[i]
        d = graph.degree
        self._fi, self._fj = i[keep], j[keep]
        wn = wgt[keep] / d[i[keep]]
        self._Sf = sparse.csr_matrix(
            (wn, (self._fi, np.arange(self._fi.size))), shape=(graph.n, self._fi.size)
        )
        self._lead_idx = np.flatnonzero(lead)

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        t = as_scalar(t, "t")
        if not isinstance(reference, AttitudeReference):
            raise TypeError(
                f"reference: expected an AttitudeReference, got {type(reference).__name__}"
            )
        R, w = self._state(state)
        Rn, wn = self._neighbours(t, R, w)
        N = R.shape[0]
        # followers: geometric average of the neighbours as received
        Rij = np.swapaxes(R[self._fi], -1, -2) @ Rn[self._fj]
        phi = so3.log_unchecked(Rij)
        e_R = -(self._Sf @ phi)
        w_bar = self._Sf @ _mv(Rij, wn[self._fj])
        ff = np.zeros((N, 3))
        # leaders: the reference (broadcast to the leaders)
        L = self._lead_idx
        try:
            Rd = np.broadcast_to(np.asarray(reference.R_d, dtype=np.float64), (N, 3, 3))[L]
            wd = np.broadcast_to(np.asarray(reference.omega_d, dtype=np.float64), (N, 3))[L]
            dwd = np.broadcast_to(np.asarray(reference.omega_dot_d, dtype=np.float64), (N, 3))[L]
        except ValueError:
            raise ValueError(
                f"reference: one sample or one per member ({N}) expected, got R_d "
                f"{np.shape(reference.R_d)}, omega_d {np.shape(reference.omega_d)}"
            ) from None
        RtRd = np.swapaxes(R[L], -1, -2) @ Rd
        e_R[L] = so3.log_unchecked(np.swapaxes(RtRd, -1, -2))
        w_bar[L] = _mv(RtRd, wd)
        ff[L] = _mv(RtRd, dwd)
        e_W = w - w_bar
        # J(Ω^ ω̄ − a_d): the tracking feed-forward (a_d = RᵀR_dΩ̇_d for leaders, 0 for followers)
        u = (
            -_gain(self.k_R, e_R)
            - _gain(self.k_Omega, e_W)
            + _cross(w, self._J_times(w))
            - self._J_times(_cross(w, w_bar) - ff)
        )
        self._diag = {
            "e_R": e_R,
            "e_Omega": e_W,
            "attitude_error": np.linalg.norm(e_R, axis=-1),
        }
        return finite_command(u, w)


# ------------------------------------------------------------------------------- SE(3)
class PoseFormation(PoseController):
    """Leader–follower relative-pose formation keeping on SE(3).

    Each follower ``i`` of a leader–follower tree keeps the pose ``g_rel,i`` relative to its
    parent ``p(i)`` (``g_rel,i`` is ``i``'s desired pose in ``p``'s body frame); the leaders keep
    ``g_rel,i`` relative to the reference (a virtual leader: use the identity for a leader that
    flies the reference itself). Rigid attachment gives the desired pose, twist and its rate::

        g_d,i = ĝ_p g_rel,i,   ξ_d,i = Ad_{g_rel,i⁻¹} ξ̂_p,   ξ̇_d,i = Ad_{g_rel,i⁻¹} ξ̂̇_p

    (``ġ_d = ĝ_p ξ̂_p^ g_rel = g_d (g_rel⁻¹ ξ̂_p^ g_rel)``), with ``ĝ_p, ξ̂_p`` the parent's state
    as received (``delay`` control periods old). The parent also broadcasts its wrench command
    ``u_p``, from which the follower predicts the parent's acceleration with the model of the
    plant (Jiang, Meng & Yang 2023 eqs. 5–6)::

        ξ̂̇_p = I⁻¹ (ad_ξ̂pᵀ I ξ̂_p + u_p + w_g(ĝ_p)),   I = diag(J, m I₃).

    In orbit this term is essential: a body-frame velocity of ~7.6 km/s turns with the parent's
    attitude, so any attitude motion of the parent is a large translational acceleration of the
    attached pose. Members are commanded level by level down the tree (leaders first), so with no
    delay a follower uses its parent's command of the same sample. The prediction is exact when
    the parent's actuator delivers its command and the model (``m``, ``J``, gravity of
    ``tracking``) is the plant's.

    ``tracking`` — an :class:`~liecontrol.control.se3_control.SE3TrackingController` or
    :class:`~liecontrol.control.se3_control.BulloMurrayPD` (anything with ``m``, ``J`` and
    ``gravity`` attributes) — turns those references into each member's wrench. With the tracking
    controller's exact error dynamics ``I ξ̃̇ = −P − K_d ξ̃`` (Jiang, Meng & Yang 2023, eqs.
    15–16) the tree is a cascade: each member converges once its parent does.

    This is the relative-pose objective ``g_ij → g_ij^d``, ``ξ_ij → 0`` of the survey's §4.2 in
    its leader–follower / virtual-leader form (Lee, Sanyal & Butcher, "Asymptotic tracking control
    for spacecraft formation flying with decentralized collision avoidance", *J. Guidance,
    Control, and Dynamics* 38(4), 2015; Verginis, Nikou & Dimarogonas, "Robust formation control
    in SE(3) for tree-graph structures with prescribed transient and steady state performance",
    *Automatica* 103, 2019).

    Args:
        graph: a :class:`CommunicationGraph` in which every non-leader receives exactly one
            member (its parent) — e.g. :meth:`CommunicationGraph.tree`.
        relative_poses: ``(N, 4, 4)`` desired pose of each member relative to its parent (to the
            reference for leaders).
        tracking: the per-member pose controller.
        delay: communication delay in control periods (integer >= 0).
        predict: propagate the parent's received state to the present, to second order in the
            delay ``τ``: ``ξ̂_p = ξ_p + τ ξ̇_p``, ``ĝ_p = g_p exp(τ ξ_p + ½ τ² ξ̇_p)`` with ``ξ̇_p``
            from its broadcast wrench (exact for a constant twist); no effect without a delay.
            Without it, in orbit a follower aims where its parent was ``τ`` ago: ~7.6 km/s × τ
            behind.

    ``diagnostics()``: the tracking controller's (``attitude_error``, ``position_error``
    relative to each member's desired pose, …) for all members, plus ``g_d`` ``(N, 4, 4)``.
    """

    def __init__(
        self,
        graph: CommunicationGraph,
        relative_poses: object,
        tracking: PoseController,
        delay: int = 0,
        predict: bool = False,
    ) -> None:
        if not isinstance(graph, CommunicationGraph):
            raise TypeError(f"graph: expected a CommunicationGraph, got {type(graph).__name__}")
        if not graph.leaders:
            raise ValueError("graph: a leader–follower formation needs graph.leaders (none given)")
        lead = np.zeros(graph.n, dtype=bool)
        lead[list(graph.leaders)] = True
        A = graph.adjacency
        parent = np.full(graph.n, -1)
        for i in np.flatnonzero(~lead):
            nb = np.flatnonzero(A[i])
            if nb.size != 1:
                raise ValueError(
                    f"graph: follower {int(i)} receives {nb.size} members; a relative-pose "
                    "formation needs exactly one parent per follower (a leader–follower tree)"
                )
            parent[i] = nb[0]
        if not graph.informed_by(graph.leaders).all():
            raise ValueError("graph: some followers are not informed by any leader (a cycle)")
        g_rel = se3.validate(relative_poses, "relative_poses")
        if g_rel.shape != (graph.n, 4, 4):
            raise ValueError(
                f"relative_poses: expected shape ({graph.n}, 4, 4) (one per member), "
                f"got {g_rel.shape}"
            )
        if not isinstance(tracking, PoseController):
            raise TypeError(f"tracking: expected a PoseController, got {type(tracking).__name__}")
        for attr in ("m", "J", "gravity"):
            if not hasattr(tracking, attr):
                raise TypeError(
                    f"tracking: needs the model attributes m, J and gravity (to predict a "
                    f"parent's acceleration); {type(tracking).__name__} has no {attr!r}"
                )
        self.graph = graph
        self.g_rel = g_rel.copy()
        self.g_rel.setflags(write=False)
        self.tracking = tracking
        self.delay = _delay(delay)
        self.predict = check_bool(predict, "predict")
        self.parent = parent
        # levels: leaders, then their children, … (the graph is a tree rooted at the leaders)
        depth = np.where(lead, 0, -1)
        while (depth < 0).any():
            for i in np.flatnonzero(depth < 0):
                if depth[parent[i]] >= 0:
                    depth[i] = depth[parent[i]] + 1
        self._levels = [np.flatnonzero(depth == k) for k in range(int(depth.max()) + 1)]
        self._Ad_inv = se3.adjoint_unchecked(se3.inverse_unchecked(self.g_rel))
        self._buf: deque[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = deque(
            maxlen=max(self.delay, 1)
        )
        self._diag: dict[str, np.ndarray] = {}
        self._B: int | None = None

    def reset(self, t0: float, batch_size: int) -> None:
        as_scalar(t0, "t0")
        self._B = self.graph.check_batch(batch_size)
        self._buf.clear()
        self._diag = {}
        self.tracking.reset(t0, batch_size)

    def _acceleration(self, g: np.ndarray, xi: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``I⁻¹(ad_ξᵀIξ + u + w_g(g))`` with the tracking controller's model."""
        trk = self.tracking
        m, J = float(trk.m), np.asarray(trk.J)  # type: ignore[attr-defined]
        w = coriolis_wrench_unchecked(xi, m, J) + u
        grav = trk.gravity  # type: ignore[attr-defined]
        if grav is not None:
            w = w + np.asarray(grav(g), dtype=np.float64)
        return np.concatenate((np.linalg.solve(J, w[..., :3, None])[..., 0], w[..., 3:] / m), -1)

    def command(self, t: float, state: PoseState, reference: PoseReference) -> np.ndarray:
        t = as_scalar(t, "t")
        if not isinstance(state, PoseState):
            raise TypeError(f"state: expected a PoseState, got {type(state).__name__}")
        if not isinstance(reference, PoseReference):
            raise TypeError(f"reference: expected a PoseReference, got {type(reference).__name__}")
        if self._B is None:
            raise RuntimeError("reset: call reset(t0, batch_size) before command")
        g = se3.validate(state.g, "state.g", atol=1e-6)
        xi = as_array(state.xi, "state.xi", (6,))
        if g.ndim != 3 or xi.shape != (g.shape[0], 6):
            raise ValueError(
                f"state: expected g (B, 4, 4) and xi (B, 6), got {g.shape}, {xi.shape}"
            )
        N = self.graph.check_batch(g.shape[0], "state")
        u = np.zeros((N, 6))
        # what the parents broadcast: `delay` samples old, or this sample's (u filled per level)
        if self.delay > 0 and self._buf:
            t_s, gs, xis, us = self._buf[0]
            if self.predict and t > t_s:
                # second order in τ: the body twist changes by τ ξ̇ (ξ̇ from the broadcast wrench;
                # in orbit a turning body frame turns a ~7.6 km/s body velocity), and the pose
                # moves by exp(τ ξ + ½ τ² ξ̇) to that order
                tau = t - t_s
                acc = self._acceleration(gs, xis, us)
                gs = gs @ se3.exp(tau * xis + 0.5 * tau * tau * acc)
                xis = xis + tau * acc
        else:
            gs, xis, us = g, xi, u
        g_ref = se3.validate(reference.g_d, "reference.g_d")
        xi_ref = as_array(reference.xi_d, "reference.xi_d", (6,))
        dxi_ref = as_array(reference.xi_dot_d, "reference.xi_dot_d", (6,))
        try:
            g_ref = np.broadcast_to(g_ref, (N, 4, 4))
            xi_ref = np.broadcast_to(xi_ref, (N, 6))
            dxi_ref = np.broadcast_to(dxi_ref, (N, 6))
        except ValueError:
            raise ValueError(
                f"reference: one sample or one per member ({N}) expected, got g_d "
                f"{g_ref.shape}, xi_d {xi_ref.shape}, xi_dot_d {dxi_ref.shape}"
            ) from None
        g_d = np.empty((N, 4, 4))
        diag: dict[str, np.ndarray] = {}
        for k, M in enumerate(self._levels):
            if k == 0:
                src_g, src_xi, src_dxi = g_ref[M], xi_ref[M], dxi_ref[M]
            else:
                P = self.parent[M]
                src_g, src_xi = gs[P], xis[P]
                src_dxi = self._acceleration(src_g, src_xi, us[P])
            Ad = self._Ad_inv[M]
            g_d[M] = src_g @ self.g_rel[M]
            ref = PoseReference(g_d=g_d[M], xi_d=_mv(Ad, src_xi), xi_dot_d=_mv(Ad, src_dxi))
            u[M] = self.tracking.command(t, PoseState.unchecked(g[M], xi[M]), ref)
            for key, val in self.tracking.diagnostics().items():
                val = np.asarray(val)
                if key not in diag:
                    diag[key] = np.zeros((N,) + val.shape[1:], dtype=val.dtype)
                diag[key][M] = val
        if self.delay > 0:
            self._buf.append((t, g, xi, u.copy()))
        diag["g_d"] = g_d
        self._diag = diag
        return u

    def diagnostics(self) -> dict[str, np.ndarray]:
        return dict(self._diag)
