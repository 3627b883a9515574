"""Chart-based adapters: wrap a control law written in chart coordinates as an SO(3) controller
.

A *chart law* is written in the coordinates of one chart — Euler angles of a given sequence,
modified Rodrigues parameters (MRP) or a unit quaternion — of the body **relative to a base
frame**. The adapter is an :class:`~liecontrol.control.base.AttitudeController`: at each sample
it converts the measured state ``(R, ω)`` and the reference ``(R_d, ω_d, ω̇_d)`` into the chart
(:class:`ChartState`), calls the law, checks its body torque and returns it. The adapter owns the
chart's singularities:

* Euler angles (:class:`EulerChartAdapter`): gimbal lock (|cos a2| < ``lock_tol`` for
  Tait–Bryan, |sin a2| < ``lock_tol`` for proper Euler sequences) of the state **or** of the
  reference raises :class:`~liecontrol.exceptions.ChartSingularityError` — no switch, no NaN.
  The wrap of a1, a3 at ±π is handled: ``y_d`` is unwrapped continuously in time and ``y`` is
  reported as ``y_d + wrap(y − y_d)``, so ``y − y_d`` is the short error in (−π, π].
* MRP (:class:`MrpChartAdapter`): shadow-set switching. The MRP is tracked continuously in time
  (of ``p`` and its shadow ``p_s = −p/|p|²`` the one closer to the previous sample) and switched
  to the shadow when ``|p| > threshold`` (1 = the classical switch, > 1 adds hysteresis). On a
  switch the law's ``on_shadow_switch(state_mask, desired_mask)`` hook is called **before** the
  law sees the new coordinates, so a stateful law (ESO, TD) can map its internal states with
  :func:`mrp_shadow_map` (p, ṗ, p̈ ↦ p_s, ṗ_s, p̈_s — exact, see there).
* Quaternion (:class:`QuaternionChartAdapter`): the sign (double cover). ``sign_mode``:
  ``"continuous"`` (q follows continuously from the start, the initial sign taken from
  ``q_hint``: unwinding-prone), ``"switched"`` (memoryless, w ≥ 0 — the short rotation, may
  chatter at 180° under noise), ``"hysteretic"`` (Mayhew, Sanfelice & Teel 2011: the sign is
  kept until w < −``hysteresis``, then flipped).

Base frames (``base=``): ``"reference"`` (default: the chart is the attitude *error*, body
relative to R_d(t); then y_d is the chart's identity and ẏ_d = ÿ_d = 0), ``"inertial"``
(identity frame), or any callable ``base(t)`` returning an object with attributes ``R_d``
(base → inertial, ``(3, 3)`` or ``(B, 3, 3)``), ``omega_d`` (the base frame's inertial angular
velocity in base axes) and ``omega_dot_d`` — e.g. ``spacecraft.orbit.EarthPointingReference``
for the orbit (LVLH) frame of Wu et al., or :class:`RotatingFrame`.

Kinematics used (R: body → inertial, R_b: base → inertial, ω_b its rate in base axes):

    R_rel = R_bᵀ R (body → base),  C_bo = R_relᵀ (base → body),
    ω_rel = ω − C_bo ω_b   (body rate relative to the base, body axes; Wu et al. eq. (8)),
    R_d,rel = R_bᵀ R_d,  ω_d,rel = ω_d − R_d,relᵀ ω_b,
    ω̇_d,rel = ω̇_d + ω_d × (R_d,relᵀ ω_b) − R_d,relᵀ ω̇_b,
    ẏ = B(y) ω_rel,   ÿ_d = B(y_d)(ω̇_d,rel − Ṁ(y_d, ẏ_d) ẏ_d)   with ω_rel = M(y) ẏ, B = M⁻¹.

Ṁ ẏ (the derivative of M along ẏ) is taken by a central difference along ẏ (step 1e-6 rad
in the chart; error ~1e-12 relative), which keeps one code path for every chart.

The chart-law protocol (what the wrapped ``law`` must provide)::

    class MyLaw:
        batched = True                     # optional; False → the simulator steps per spacecraft
        def reset(self, t0: float, batch_size: int) -> None: ...
        def __call__(self, t: float, s: ChartState) -> np.ndarray:   # body torque (B, 3) [N m]
            return -self.kp * (s.y - s.y_d) - self.kd * (s.y_dot - s.y_d_dot)  # e.g. a chart PD
        def diagnostics(self) -> dict[str, np.ndarray]: ...           # optional, (B, ...) arrays
        def on_shadow_switch(self, state_mask, desired_mask) -> None: ...  # optional, MRP only

**The array-law protocol** (the JAX route, :mod:`liecontrol.control.array_law`). Every adapter
has ``array_law()``: its chart conversion is written once as pure array functions
(:func:`chart_sample` with the adapter's chart and memory: :func:`quaternion_canonical`,
:func:`mrp_track`, :func:`quaternion_sign`, :func:`euler_unwrap`, the charts' rates), which the
NumPy route above calls on ``(B, ...)`` batches and the array law on one spacecraft's JAX arrays.
The chart memory — MRP: the previous σ, σ_d and a first-sample flag; quaternion: the previous q
(at the first sample the sign hint, or zeros in the switched mode) and q_d; Euler: the previous
y_d and the flag — is state carried by the scan, ahead of the law's own. The adapter composes
it with the law's pure form, which a chart law offers next to ``__call__``::

        def array_law(self) -> ChartArrayLaw:
            def step(k_R, k_Omega, state, s, T):   # s: one spacecraft's ChartState
                u = -k_R * (s.y - s.y_d) - k_Omega * (s.y_dot - s.y_d_dot)
                return u, state, {"my_diag": ...}   # torque (3,), state, diagnostics
            return ChartArrayLaw(self.kp, self.kd, (), step)   # gains, initial state, step

(:class:`ChartArrayLaw`; optional ``params`` — further differentiable parameters, passed to
``step`` as the keyword ``params`` — and, for MRP, ``on_shadow_switch(state, switched,
switched_desired) -> state``, the hook's pure form, called at every sample before ``step``).
Write the step with ``xp`` formulas (:mod:`liecontrol._array_api`) — ideally the very function
``__call__`` evaluates, as :class:`~liecontrol.control.chart_baselines.MrpPDLaw` does. In the
array law ``s.t`` and ``s.h`` are ``None``, the arrays have no batch axis, and the Euler chart
does not raise at gimbal lock: it reports ``chart_lock`` and the torque is NaN (the JAX route
flags the member diverged). A law without ``array_law``, one whose ``__call__`` overrides its
parent's ``array_law``, or a callable base frame is refused (``ValueError`` naming it).

Euler-angle laws (e.g. Liu, Tang & Yu's terminal sliding mode, sequence ``"ZYX"`` = 3-2-1,
y = (a1, a2, a3), R = Rz(a1) Ry(a2) Rx(a3)) are wrapped as::

    ctrl = EulerChartAdapter(law, seq="ZYX", base="inertial", lock_tol=1e-2)

and the law reads ``s.y`` (angles of the body relative to the base), ``s.y_dot`` (their rates,
``= B(y) ω_rel``), ``s.y_d``, ``s.y_d_dot``, ``s.y_d_ddot`` (desired), ``s.omega`` (inertial
body rate, body axes — what a gyro measures), ``s.omega_rel``, and the kinematic matrices
``s.chart.rates_matrix(y)`` (B = ∂ẏ/∂ω) and ``s.chart.rates_matrix_inv(y)`` (M). A law may
return a chart acceleration instead of a torque by calling
``s.torque_from_chart_acceleration(y_ddot, J)`` (exact inverse dynamics of the rigid body).

Sources: Schaub & Junkins, *Analytical Mechanics of Space Systems*, §3.8 (MRP shadow set) and
§8 (MRP feedback); Mayhew, Sanfelice & Teel, "Quaternion-based hybrid control for robust global
attitude tracking", IEEE TAC 56(11), 2011; Bhat & Bernstein, "A topological obstruction to
continuous global stabilization of rotational motion and the unwinding phenomenon", Systems &
Control Letters 39(1), 2000.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._array_api import cross as _xcross
from .._array_api import namespace
from .._linalg import cross as _cross
from .._linalg import matvec
from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_output_finite,
    check_positive,
    check_rotation_matrix,
    norm_last,
)
from ..charts import euler as _euler
from ..charts import mrp as _mrp
from ..charts import quaternion as _quat
from ..exceptions import ChartSingularityError
from .array_law import ArrayLaw, _owner
from .base import (
    AttitudeController,
    AttitudeReference,
    AttitudeState,
    check_state_batch,
    validated_rotation_and_rate,
)

__all__ = [
    "ChartArrayLaw",
    "ChartState",
    "EulerChart",
    "MrpChart",
    "QuaternionChart",
    "RotatingFrame",
    "ChartAdapter",
    "EulerChartAdapter",
    "MrpChartAdapter",
    "QuaternionChartAdapter",
    "mrp_shadow_jacobian",
    "mrp_shadow_map",
    "SIGN_MODES",
]

#: Quaternion sign modes of :class:`QuaternionChartAdapter`.
SIGN_MODES = ("continuous", "switched", "hysteretic")

# chart step of the central difference for Ṁ ẏ
_FD_STEP = 1e-6
_EYE3 = np.eye(3)
_EYE3.setflags(write=False)


def _mv(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched matrix–vector product ``M @ v``."""
    return matvec(M, v)


def _mtv(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched ``Mᵀ @ v``."""
    return matvec(np.swapaxes(M, -1, -2), v)


def _quat_outer_map() -> tuple[np.ndarray, np.ndarray]:
    """(L, c) with 4 q qᵀ = reshape(L vec(R) + c, (4, 4)) for the unit quaternion q of R."""
    L = np.zeros((16, 9))
    c = np.zeros(16)
    ix = {(i, j): 3 * i + j for i in range(3) for j in range(3)}

    def put(a: int, b: int, terms: dict[tuple[int, int], float], const: float = 0.0) -> None:
        for (i, j), v in terms.items():
            L[4 * a + b, ix[i, j]] += v
            if a != b:
                L[4 * b + a, ix[i, j]] += v
        c[4 * a + b] += const
        if a != b:
            c[4 * b + a] += const

    tr = {(0, 0): 1.0, (1, 1): 1.0, (2, 2): 1.0}
    put(0, 0, tr, 1.0)
    for k in range(3):
        put(k + 1, k + 1, {**{key: -v for key, v in tr.items()}, (k, k): 1.0}, 1.0)
    # 4 w x = R21 − R12, 4 w y = R02 − R20, 4 w z = R10 − R01
    put(0, 1, {(2, 1): 1.0, (1, 2): -1.0})
    put(0, 2, {(0, 2): 1.0, (2, 0): -1.0})
    put(0, 3, {(1, 0): 1.0, (0, 1): -1.0})
    # 4 x y = R01 + R10, 4 x z = R02 + R20, 4 y z = R12 + R21
    put(1, 2, {(0, 1): 1.0, (1, 0): 1.0})
    put(1, 3, {(0, 2): 1.0, (2, 0): 1.0})
    put(2, 3, {(1, 2): 1.0, (2, 1): 1.0})
    return L, c


_QL, _QC = _quat_outer_map()


def _quat_trusted(R: np.ndarray) -> np.ndarray:
    """Scalar-first quaternion (w ≥ 0) of rotation matrices the adapter has already validated.

    Shepperd's method as :func:`liecontrol.charts.quaternion.from_matrix` (same pivot: the
    largest of 1 + tr R, 1 + 2R_kk − tr R), written as one linear map to M = 4 q qᵀ so that the
    hot path of every chart adapter makes a handful of numpy calls; R is not re-checked.
    """
    xp = namespace(R)
    lead = R.shape[:-2]
    M = (R.reshape(lead + (9,)) @ _QL.T + _QC).reshape(lead + (4, 4))
    k = xp.argmax(xp.diagonal(M, axis1=-2, axis2=-1), axis=-1)
    q = xp.take_along_axis(M, k[..., None, None], axis=-2)[..., 0, :]
    q = q / xp.sqrt(xp.sum(q * q, axis=-1, keepdims=True))
    return quaternion_canonical(q)


def quaternion_canonical(q: Any) -> Any:
    """The canonical sign of scalar-first quaternions ``(..., 4)``: w > 0, or w = 0 and the first
    non-zero of x, y, z positive (:func:`liecontrol.charts.quaternion.canonicalize`'s rule, the
    compiled kernels' too). Pure (NumPy or JAX)."""
    xp = namespace(q)
    lead = q[..., 0]
    for j in (1, 2, 3):
        lead = xp.where(lead == 0.0, q[..., j], lead)
    return xp.where((lead < 0.0)[..., None], -q, q)


# ------------------------------------------------------------------ chart memory (pure steps)
# The adapters' memory — MRP continuity and shadow switch, quaternion sign, Euler unwrap — as pure
# functions of the memory before the sample: the NumPy route (batched, memory held by the
# adapter) and the array law (one spacecraft, memory carried by the scan) call the same ones.


def mrp_track(p_can: Any, prev: Any, has_prev: Any, threshold2: float) -> tuple[Any, Any]:
    """MRP continuity and shadow-set switch: of ``p_can`` and its shadow −p/|p|² the one nearer
    to ``prev`` (where ``has_prev``), then switched to its shadow where |p|² > ``threshold2``
    (never at the first sample). Returns ``(p, switched)``; ``(..., 3)`` arrays, pure."""
    xp = namespace(p_can, prev)
    n2 = xp.sum(p_can * p_can, axis=-1, keepdims=True)
    nz = n2[..., 0] > 0.0
    shadow = -p_can / xp.where(nz[..., None], n2, 1.0)
    d_can = xp.sum((p_can - prev) ** 2, axis=-1)
    d_sh = xp.sum((shadow - prev) ** 2, axis=-1)
    use_shadow = has_prev & nz & (d_sh < d_can)
    p = xp.where(use_shadow[..., None], shadow, p_can)
    n2c = xp.sum(p * p, axis=-1, keepdims=True)
    mask = has_prev & (n2c[..., 0] > threshold2)
    p = xp.where(mask[..., None], -p / xp.where(mask[..., None], n2c, 1.0), p)
    return p, mask


def quaternion_sign(q_can: Any, prev: Any, sign_mode: str, hysteresis: float) -> tuple[Any, Any]:
    """The quaternion adapter's sign (module docstring) of ``q_can`` (w ≥ 0) given the previous
    sample's quaternion ``prev`` (at the first sample the hint, or zeros in the switched mode).
    Returns ``(q, flipped)``: switched — q_can, flipped where it points against ``prev``;
    continuous — q continued from ``prev``; hysteretic — continued, then flipped where
    w < −``hysteresis``. Pure."""
    xp = namespace(q_can, prev)
    against = xp.sum(q_can * prev, axis=-1) < 0.0
    if sign_mode == "switched":
        return q_can, against
    q = xp.where(against[..., None], -q_can, q_can)
    if sign_mode == "hysteretic":
        flip = q[..., 0] < -hysteresis
        return xp.where(flip[..., None], -q, q), flip
    return q, xp.zeros(q.shape[:-1], dtype=bool)


def euler_unwrap(y: Any, y_d: Any, y_d_prev: Any, has_prev: Any) -> tuple[Any, Any]:
    """The Euler adapter's unwrap of a1, a3 (module docstring): ``y_d`` continued from
    ``y_d_prev`` (where ``has_prev``) by whole turns, ``y`` reported within π of ``y_d``.
    Returns ``(y, y_d)``; pure."""
    xp = namespace(y, y_d, y_d_prev)
    wrap = np.array([True, False, True])
    two_pi = 2.0 * np.pi
    k = xp.round((y_d_prev - y_d) / two_pi)
    y_d = y_d + xp.where(wrap & has_prev[..., None], k, 0.0) * two_pi
    e = y - y_d
    e_w = e - two_pi * xp.round(e / two_pi)
    return xp.where(wrap, y_d + e_w, y), y_d


# --------------------------------------------------------------------------- MRP shadow maps


def mrp_shadow_jacobian(p: object) -> np.ndarray:
    """D(p) = ∂p_s/∂p = (−I + 2 p̂ p̂ᵀ)/|p|² for the shadow p_s = −p/|p|², ``(..., 3, 3)``.

    Raises ``ValueError`` (naming ``p``) at p = 0, whose shadow is at infinity, and where
    1/|p|² overflows.
    """
    p = as_array(p, "p", (3,))
    n = norm_last(p)[..., None, None]  # no overflow/underflow of |p|²
    if np.any(n == 0.0):
        raise ValueError("p: the shadow of the zero MRP (identity rotation) is at infinity")
    with np.errstate(over="ignore", under="ignore"):
        D = _shadow_jacobian_unchecked(p, n)
    return check_output_finite(D, "p", "D(p) ∝ 1/|p|²")


def _shadow_jacobian_unchecked(p: Any, n: Any = None) -> Any:
    """:func:`mrp_shadow_jacobian` of non-zero MRPs (``n`` = |p| ``(..., 1, 1)``, default
    √(pᵀp)); pure."""
    xp = namespace(p)
    if n is None:
        n = xp.sqrt(xp.sum(p * p, axis=-1))[..., None, None]
    u = p / n[..., 0]  # p̂
    return (-np.eye(3) + 2.0 * u[..., :, None] * u[..., None, :]) / n / n


def mrp_shadow_map(
    p: object, p_dot: object | None = None, p_ddot: object | None = None
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Map an MRP and its first two time derivatives to the shadow set.

    With n² = pᵀp, p_s = −p/n², D = ∂p_s/∂p (:func:`mrp_shadow_jacobian`):

        ṗ_s = D ṗ,
        p̈_s = D p̈ + Ḋ ṗ,   Ḋ ṗ = [4 (pᵀṗ) ṗ + 2 (ṗᵀṗ) p]/n⁴ − 8 (pᵀṗ)² p / n⁶.

    Both follow from differentiating p_s(t) = −p(t)/|p(t)|² (chain rule; derived here, checked
    against finite differences in the tests). Because ω̇ enters p̈ only through G(p) ω̇ and
    G(p_s) = D G(p), the ESO's total disturbance f = p̈ − G J⁻¹ τ maps with the same formula
    (f_s = D f + Ḋ ṗ), independently of τ. Returns ``(p_s, ṗ_s, p̈_s)`` (``None`` where the
    input is ``None``; ``p_ddot`` needs ``p_dot``).
    """
    p = as_array(p, "p", (3,))
    D = mrp_shadow_jacobian(p)
    if p_dot is None:
        if p_ddot is not None:
            raise ValueError("p_dot: required when p_ddot is given")
        return -p / np.sum(p * p, axis=-1, keepdims=True), None, None
    pd = as_array(p_dot, "p_dot", (3,))
    pdd = None if p_ddot is None else as_array(p_ddot, "p_ddot", (3,))
    return mrp_shadow_map_unchecked(p, pd, pdd, D)[:3]


def mrp_shadow_map_unchecked(p: Any, p_dot: Any, p_ddot: Any = None, D: Any = None) -> tuple:
    """:func:`mrp_shadow_map` of non-zero MRPs without validation, pure (NumPy or JAX; the
    array laws' shadow-switch hooks select its result with ``where``): ``(p_s, ṗ_s, p̈_s or
    None, D)``, ``D`` the Jacobian (computed when not given)."""
    xp = namespace(p, p_dot)
    if D is None:
        D = _shadow_jacobian_unchecked(p)
    ps = -p / xp.sum(p * p, axis=-1, keepdims=True)
    pd_s = _mv(D, p_dot)
    if p_ddot is None:
        return ps, pd_s, None, D
    pd = p_dot
    n2 = xp.sum(p * p, axis=-1, keepdims=True)
    ppd = xp.sum(p * pd, axis=-1, keepdims=True)
    pdpd = xp.sum(pd * pd, axis=-1, keepdims=True)
    Ddot_pd = (4.0 * ppd * pd + 2.0 * pdpd * p) / n2**2 - 8.0 * ppd**2 * p / n2**3
    return ps, pd_s, _mv(D, p_ddot) + Ddot_pd, D


# --------------------------------------------------------------------------- charts


class _Chart3:
    """A 3-parameter chart: coordinates y, ω_rel = M(y) ẏ, ẏ = B(y) ω_rel."""

    name = ""
    dim = 3

    def from_matrix(self, R: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def rates_matrix(self, y: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def rates_matrix_inv(self, y: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def identity(self, batch: int) -> np.ndarray:
        return np.zeros((batch, 3))

    def rates(self, y: np.ndarray, omega_rel: np.ndarray) -> np.ndarray:
        """ẏ = B(y) ω_rel."""
        return _mv(self.rates_matrix(y), omega_rel)

    def M_dot_times(self, y: np.ndarray, y_dot: np.ndarray) -> np.ndarray:
        """Ṁ ẏ = (dM/dt along ẏ) ẏ, central difference along ẏ (module docstring); pure."""
        xp = namespace(y, y_dot)
        n = xp.sqrt(xp.sum(y_dot * y_dot, axis=-1, keepdims=True))
        safe = xp.where(n > 0.0, n, 1.0)
        d = y_dot / safe * _FD_STEP
        dM = self.rates_matrix_inv(y + d) - self.rates_matrix_inv(y - d)
        return _mv(dM, y_dot) * (n / (2.0 * _FD_STEP))

    def acceleration(
        self, y: np.ndarray, y_dot: np.ndarray, omega_dot_rel: np.ndarray
    ) -> np.ndarray:
        """ÿ = B(y)(ω̇_rel − Ṁ ẏ) (from ω_rel = M ẏ)."""
        return _mv(self.rates_matrix(y), omega_dot_rel - self.M_dot_times(y, y_dot))


class EulerChart(_Chart3):
    """Euler angles of sequence ``seq`` (scipy notation, :mod:`liecontrol.charts.euler`).

    ``rates_matrix`` raises :class:`ChartSingularityError` when |cos a2| (Tait–Bryan) or
    |sin a2| (proper Euler) < ``lock_tol``.
    """

    name = "euler"

    def __init__(self, seq: str = "ZYX", lock_tol: float = 1e-2) -> None:
        _euler.is_tait_bryan(seq)  # validates seq (ValueError naming seq)
        lock_tol = check_positive(lock_tol, "lock_tol")
        if not isinstance(lock_tol, float) or lock_tol >= 1.0:
            raise ValueError(f"lock_tol: must be a scalar in (0, 1), got {lock_tol}")
        self.seq = seq
        self.lock_tol = lock_tol
        self.tait_bryan = _euler.is_tait_bryan(seq)

    def __repr__(self) -> str:
        return f"EulerChart(seq={self.seq!r}, lock_tol={self.lock_tol!r})"

    def from_matrix(self, R: np.ndarray) -> np.ndarray:
        # gimbal lock is reported by check_lock with the adapter's tolerance, not as a warning
        if namespace(R) is np:
            return _euler.from_matrix(R, self.seq, warn=False)
        return _euler._from_matrix_unchecked(R, self.seq, _euler.FROM_MATRIX_LOCK_TOL)[0]

    from_matrix_trusted = from_matrix

    def near_lock(self, y: Any) -> Any:
        """|cos a2| (Tait–Bryan) or |sin a2| (proper Euler) < ``lock_tol``; pure."""
        xp = namespace(y)
        f = xp.cos if self.tait_bryan else xp.sin
        return xp.abs(f(y[..., 1])) < self.lock_tol

    def check_lock(self, y: np.ndarray, name: str) -> None:
        """Raise :class:`ChartSingularityError` naming ``name`` near gimbal lock."""
        lock = _euler.near_gimbal_lock(y, self.seq, self.lock_tol)
        if np.any(lock):
            f = np.cos if self.tait_bryan else np.sin
            fn = "cos" if self.tait_bryan else "sin"
            worst = float(np.abs(f(y[..., 1])).min())
            raise ChartSingularityError(
                f"{name}: gimbal lock of Euler sequence {self.seq!r} (|{fn} a2| = {worst:.2e} < "
                f"lock_tol = {self.lock_tol:.1e}, a2 = {np.degrees(y[lock][0, 1]):.3f}°); the "
                "Euler-angle law is undefined there — use a geometric controller or another "
                "sequence"
            )

    def rates_matrix(self, y: np.ndarray) -> np.ndarray:
        """B(y); NumPy: raises at gimbal lock; JAX: unchecked (the array law flags the lock)."""
        if namespace(y) is np:
            return _euler.rates_matrix(y, self.seq, self.lock_tol)
        return _euler._rates_matrix_unchecked(y, self.seq)

    def rates_matrix_inv(self, y: np.ndarray) -> np.ndarray:
        if namespace(y) is np:
            return _euler.rates_matrix_inv(y, self.seq)
        return _euler._rates_matrix_inv_unchecked(y, self.seq)

    def identity(self, batch: int) -> np.ndarray:
        return self.from_matrix(np.broadcast_to(np.eye(3), (batch, 3, 3)))

    def wrapped_components(self) -> np.ndarray:
        """Mask of the angles that wrap at ±π (a1, a3; a2 is bounded)."""
        return np.array([True, False, True])


class MrpChart(_Chart3):
    """Modified Rodrigues parameters (:mod:`liecontrol.charts.mrp`): M = G⁻¹, B = G(p)."""

    name = "mrp"

    def __repr__(self) -> str:
        return "MrpChart()"

    def from_matrix(self, R: np.ndarray) -> np.ndarray:
        return _mrp.from_matrix(R)

    def from_matrix_trusted(self, R: np.ndarray) -> np.ndarray:
        """As :meth:`from_matrix` for an already validated R (no re-check)."""
        q = _quat_trusted(R)
        return q[..., 1:] / (1.0 + q[..., :1])

    def rates(self, y: np.ndarray, omega_rel: np.ndarray) -> np.ndarray:
        """ṗ = G(p) ω = ½[(1 − pᵀp)/2 ω + p × ω + p (pᵀω)] (closed form of G(p) ω); pure."""
        xp = namespace(y, omega_rel)
        n2 = xp.sum(y * y, axis=-1, keepdims=True)
        pw = xp.sum(y * omega_rel, axis=-1, keepdims=True)
        return 0.5 * (0.5 * (1.0 - n2) * omega_rel + _xcross(y, omega_rel) + y * pw)

    def rates_matrix(self, y: np.ndarray) -> np.ndarray:
        if namespace(y) is np:
            return _mrp.kinematics_matrix(y)
        return _mrp._kinematics_matrix_unchecked(y)

    def rates_matrix_inv(self, y: np.ndarray) -> np.ndarray:
        if namespace(y) is np:
            return _mrp.kinematics_matrix_inv(y)
        return _mrp._kinematics_matrix_inv_unchecked(y)


class QuaternionChart:
    """Unit quaternion, scalar-first ``(w, x, y, z)``: q̇ = ½ q ⊗ (0, ω_rel) (4 coordinates, so
    no square M; :meth:`ChartState.torque_from_chart_acceleration` is not available)."""

    name = "quaternion"
    dim = 4

    def __repr__(self) -> str:
        return "QuaternionChart()"

    def from_matrix(self, R: np.ndarray) -> np.ndarray:
        return _quat.from_matrix(R)

    def from_matrix_trusted(self, R: np.ndarray) -> np.ndarray:
        """As :meth:`from_matrix` for an already validated R (no re-check)."""
        return _quat_trusted(R)

    def identity(self, batch: int) -> np.ndarray:
        return _quat.identity((batch,))

    def rates(self, y: np.ndarray, omega_rel: np.ndarray) -> np.ndarray:
        """q̇ = ½ q ⊗ (0, ω_rel); pure."""
        xp = namespace(y, omega_rel)
        zero = xp.zeros(omega_rel.shape[:-1] + (1,))
        return 0.5 * _quat._mul(y, xp.concatenate((zero, omega_rel), axis=-1))

    def acceleration(
        self, y: np.ndarray, y_dot: np.ndarray, omega_dot_rel: np.ndarray
    ) -> np.ndarray:
        """q̈ = ½ q̇ ⊗ (0, ω) + ½ q ⊗ (0, ω̇) with ω = 2 (q* ⊗ q̇)_v; pure."""
        xp = namespace(y, y_dot, omega_dot_rel)
        qc = y * np.array([1.0, -1.0, -1.0, -1.0])
        w = 2.0 * _quat._mul(qc, y_dot)[..., 1:]
        zero = xp.zeros(w.shape[:-1] + (1,))
        # the algebraic product: q̇ may be zero, which quaternion.kinematics would refuse
        return 0.5 * (
            _quat._mul(y_dot, xp.concatenate((zero, w), axis=-1))
            + _quat._mul(y, xp.concatenate((zero, omega_dot_rel), axis=-1))
        )


# --------------------------------------------------------------------------- base frames


@dataclass(frozen=True)
class RotatingFrame:
    """A frame turning at a constant rate: R_b(t) = R0 exp((t − t0) ω^) (base → inertial),
    ω_b = ``omega`` (base axes), ω̇_b = 0. Calling it returns an
    :class:`~liecontrol.control.base.AttitudeReference` (usable as ``base=`` of an adapter and
    as a reference trajectory)."""

    R0: np.ndarray
    omega: np.ndarray
    t0: float = 0.0

    def __post_init__(self) -> None:
        R0 = check_rotation_matrix(self.R0, "R0")
        if R0.shape != (3, 3):
            raise ValueError(f"R0: expected shape (3, 3), got {R0.shape}")
        w = as_array(self.omega, "omega")
        if w.shape != (3,):
            raise ValueError(f"omega: expected shape (3,), got {w.shape}")
        object.__setattr__(self, "R0", R0.copy())
        object.__setattr__(self, "omega", w.copy())
        object.__setattr__(self, "t0", as_scalar(self.t0, "t0"))

    def __call__(self, t: float) -> AttitudeReference:
        from ..lie import so3

        R = self.R0 @ so3.exp((as_scalar(t, "t") - self.t0) * self.omega)
        return AttitudeReference(R_d=R, omega_d=self.omega.copy(), omega_dot_d=np.zeros(3))

    def samples(self, times: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R_b, ω_b, ω̇_b)`` at every time of ``times`` ``(N,)``, shapes ``(N, 3, 3)``,
        ``(N, 3)``, ``(N, 3)``, in one vectorised call: the sampling protocol of
        :mod:`liecontrol.control.reference` (equal to ``self(times[k])`` sample by sample)."""
        from ..lie import so3

        t = as_array(times, "times")
        if t.ndim != 1:
            raise ValueError(f"times: expected shape (N,), got {t.shape}")
        R = self.R0 @ so3.exp((t - self.t0)[:, None] * self.omega)
        w = np.broadcast_to(self.omega, t.shape + (3,))
        return R, w, np.zeros(w.shape)


# --------------------------------------------------------------------------- chart state

_LAST_J: list[np.ndarray] = []


def _checked_inertia(J: object) -> np.ndarray:
    """Validated 3×3 inertia; a law passing the same array at every sample is checked once
    (the eigenvalue test would otherwise dominate the per-step cost)."""
    if _LAST_J and J is _LAST_J[0]:
        return J
    Jv = check_inertia_3x3(J, "J")
    # only an array that owns read-only data cannot change between samples
    if isinstance(J, np.ndarray) and not J.flags.writeable and J.base is None:
        _LAST_J[:] = [J]
    return Jv


@dataclass(frozen=True)
class ChartState:
    """Everything a chart law sees at one sample (``B`` spacecraft; arrays are ``(B, ...)``).

    Attributes:
        t: time [s].
        chart: the chart object (:class:`EulerChart`, :class:`MrpChart`, :class:`QuaternionChart`).
        y: chart coordinates of the body relative to the base frame, ``(B, n)`` (n = 3, or 4 for
            the quaternion).
        y_dot: their rates ``B(y) ω_rel``.
        y_d, y_d_dot, y_d_ddot: desired coordinates (the reference relative to the base frame)
            and their first two derivatives.
        R_rel: ``(B, 3, 3)`` body → base.  R_d_rel: desired body → base.
        omega: ``(B, 3)`` inertial body rate in body axes (the gyro's quantity) [rad/s].
        omega_rel: body rate relative to the base frame, body axes, ``ω − C_bo ω_b``.
        omega_base: the base frame's inertial rate in body axes, ``C_bo ω_b`` (Wu et al.'s
            ``C_bo ω_io``).
        omega_dot_base: ``C_bo ω̇_b`` (body axes).
        omega_d_rel, omega_dot_d_rel: desired rate relative to the base (desired-body axes) and
            its derivative.
        h: stored actuator momentum in body axes, or ``None``.
        switched: ``(B,)`` bool — MRP: the state switched to its shadow at this sample;
            quaternion: the sign of ``y`` was flipped by the sign mode; Euler: all False.
    """

    t: float
    chart: Any
    y: np.ndarray
    y_dot: np.ndarray
    y_d: np.ndarray
    y_d_dot: np.ndarray
    y_d_ddot: np.ndarray
    R_rel: np.ndarray
    R_d_rel: np.ndarray
    omega: np.ndarray
    omega_rel: np.ndarray
    omega_base: np.ndarray
    omega_dot_base: np.ndarray
    omega_d_rel: np.ndarray
    omega_dot_d_rel: np.ndarray
    h: np.ndarray | None
    switched: np.ndarray

    @property
    def batch_size(self) -> int:
        return int(self.y.shape[0])

    def torque_from_chart_acceleration(self, y_ddot: object, J: object) -> np.ndarray:
        """Body torque that produces the chart acceleration ``y_ddot`` on the rigid body
        ``J ω̇ + ω × Jω = u`` (exact inverse dynamics, 3-parameter charts only):

            ω̇_rel = M(y) ÿ + Ṁ ẏ,   ω̇ = ω̇_rel − ω_rel × (C_bo ω_b) + C_bo ω̇_b,
            u = J ω̇ + ω × J ω.

        (d/dt (C_bo ω_b) = −ω_rel × C_bo ω_b + C_bo ω̇_b since Ċ_bo = −ω^C_bo + C_bo ω_b^.)
        """
        if self.chart.dim != 3:
            raise ValueError(
                f"y_ddot: chart {self.chart.name!r} has no square kinematic matrix; "
                "torque_from_chart_acceleration needs a 3-parameter chart"
            )
        J = _checked_inertia(J)
        ydd = as_array(y_ddot, "y_ddot", (3,))
        M = self.chart.rates_matrix_inv(self.y)
        w_rel_dot = _mv(M, ydd) + self.chart.M_dot_times(self.y, self.y_dot)
        w_dot = w_rel_dot - _cross(self.omega_rel, self.omega_base) + self.omega_dot_base
        w = self.omega
        return w_dot @ J.T + _cross(w, w @ J.T)


def _replace_h(s: ChartState, h: Any) -> ChartState:
    return ChartState(**{**s.__dict__, "h": h})


def chart_sample(
    chart: Any, coords: Callable[..., tuple], mem: tuple, R: Any, omega: Any, R_d: Any,
    omega_d: Any, omega_dot_d: Any, frame: tuple | None = None, t: Any = None,
) -> tuple[ChartState, tuple, Any, Any, dict]:  # fmt: skip
    """The chart conversion of one sample (module docstring's kinematics), pure: NumPy batches
    ``(B, ...)`` (the adapter's :meth:`ChartAdapter.chart_state`) or one spacecraft's JAX arrays
    (:meth:`ChartAdapter.array_law`), same formulas.

    ``coords(mem, R_rel, R_d_rel)`` is the adapter's chart with its memory
    (``ChartAdapter._pure_coords``); ``frame`` is ``None`` when the base is the desired frame,
    else the base sample ``(R_b, ω_b, ω̇_b)``. Returns ``(state, memory, switched,
    switched_desired, extra)``; the state's ``h`` is ``None``."""
    xp = namespace(R, omega, R_d, omega_d, omega_dot_d)
    w, w_d, dw_d = omega, omega_d, omega_dot_d
    if frame is None:
        # the desired frame is the base: R_d,rel = I, ω_d,rel = ω̇_d,rel = 0 exactly
        R_rel = xp.swapaxes(R_d, -1, -2) @ R
        w_base = _mtv(R_rel, w_d)
        dw_base = _mtv(R_rel, dw_d)
        w_rel = w - w_base
        R_d_rel = xp.broadcast_to(_EYE3, R_rel.shape)
        w_d_rel = dw_d_rel = xp.zeros(w_rel.shape)
        y, y_d, sw, sw_d, mem, extra = coords(mem, R_rel, None)
        y_dot = chart.rates(y, w_rel)
        y_d_dot = y_d_ddot = xp.zeros(y_d.shape)
    else:
        R_b, w_b, dw_b = frame
        R_bT = xp.swapaxes(R_b, -1, -2)
        R_rel = R_bT @ R
        R_d_rel = xp.broadcast_to(R_bT @ R_d, R_rel.shape)
        w_base = _mtv(R_rel, w_b)  # C_bo ω_b
        dw_base = _mtv(R_rel, dw_b)
        w_rel = w - w_base
        wb_d = _mtv(R_d_rel, w_b)  # the base rate in desired-body axes
        w_d_rel = w_d - wb_d
        dw_d_rel = dw_d + _xcross(w_d, wb_d) - _mtv(R_d_rel, dw_b)
        y, y_d, sw, sw_d, mem, extra = coords(mem, R_rel, R_d_rel)
        y_dot = chart.rates(y, w_rel)
        y_d_dot = chart.rates(y_d, w_d_rel)
        y_d_ddot = chart.acceleration(y_d, y_d_dot, dw_d_rel)
    s = ChartState(
        t=t, chart=chart, y=y, y_dot=y_dot, y_d=y_d, y_d_dot=y_d_dot, y_d_ddot=y_d_ddot,
        R_rel=R_rel, R_d_rel=R_d_rel, omega=w, omega_rel=w_rel, omega_base=w_base,
        omega_dot_base=dw_base, omega_d_rel=w_d_rel, omega_dot_d_rel=dw_d_rel, h=None,
        switched=sw,
    )  # fmt: skip
    return s, mem, sw, sw_d, extra


@dataclass(frozen=True)
class ChartArrayLaw:
    """A chart law as a pure array function (the array-law protocol of the module docstring):
    what a chart law's ``array_law()`` returns, and what :meth:`ChartAdapter.array_law`
    composes with the adapter's pure chart conversion into an
    :class:`~liecontrol.control.array_law.ArrayLaw`.

    Attributes:
        k_R, k_Omega: the law's two differentiable gains (its attitude and rate gains: k_p and
            k_d, K and P…), the defaults of the differentiable loop's gain arguments.
        state0: one spacecraft's initial law state, a tuple of NumPy arrays (``()``).
        step: ``step(k_R, k_Omega, state, s, T[, params=...]) -> (u, state, diag)`` with ``s``
            the :class:`ChartState` of one spacecraft (arrays without the batch axis; ``t`` and
            ``h`` are ``None``), ``T`` the control period; pure (NumPy or JAX).
        params: further differentiable parameters (as :class:`ArrayLaw`'s): passed to ``step``
            as the keyword ``params``.
        on_shadow_switch: MRP only, optional: ``(state, switched, switched_desired) -> state``,
            the pure form of the law's ``on_shadow_switch`` hook, called before ``step`` at every
            sample with the two switch flags (select with ``where``).
        timed: ``step`` receives the sample's time as the keyword ``t`` (a law whose formula
            reads the clock, e.g. a prescribed-time shaping polynomial).
    """

    k_R: Any
    k_Omega: Any
    state0: tuple
    step: Callable[..., tuple[Any, tuple, dict[str, Any]]]
    params: Mapping[str, Any] = field(default_factory=dict)
    on_shadow_switch: Callable[..., tuple] | None = None
    timed: bool = False

    def __post_init__(self) -> None:
        if not callable(self.step):
            raise ValueError("step: must be callable as step(k_R, k_Omega, state, s, T)")
        if not isinstance(self.state0, tuple):
            raise ValueError(
                f"state0: expected a tuple of arrays, got {type(self.state0).__name__}"
            )
        if self.on_shadow_switch is not None and not callable(self.on_shadow_switch):
            raise ValueError("on_shadow_switch: must be callable or None")


# --------------------------------------------------------------------------- adapters


def _check_law(law: object) -> None:
    for name in ("reset", "__call__"):
        if not callable(getattr(law, name, None)):
            raise ValueError(
                f"law: has no method {name}() (chart-law protocol: reset(t0, batch_size), "
                "__call__(t, chart_state) -> (B, 3) torque)"
            )


def _check_base(base: object) -> object:
    if isinstance(base, str):
        if base not in ("reference", "inertial"):
            raise ValueError(
                f"base: expected 'reference', 'inertial' or a callable frame, got {base!r}"
            )
        return base
    if not callable(base):
        raise ValueError("base: expected 'reference', 'inertial' or a callable t -> frame sample")
    return base


def _as_batch(a: np.ndarray, B: int, tail: tuple[int, ...], name: str) -> np.ndarray:
    nd = len(tail)
    if a.ndim == nd:
        return a  # a single sample: broadcast by the batched products that use it
    if a.ndim == nd + 1 and a.shape[0] == B:
        return a
    raise ValueError(f"{name}: expected shape {tail} or {(B,) + tail}, got {a.shape}")


class ChartAdapter(AttitudeController):
    """Common machinery of the chart adapters (use the subclasses).

    Args:
        law: the chart law (module docstring protocol).
        chart: the chart object.
        base: ``"reference"`` (default), ``"inertial"`` or a callable frame (module docstring).
    """

    def __init__(self, law: Any, chart: Any, base: object = "reference") -> None:
        _check_law(law)
        self.law = law
        self.chart = chart
        self.base = _check_base(base)
        self.batched = bool(getattr(law, "batched", True))
        self._batch: int | None = None
        self._diag: dict[str, np.ndarray] = {}
        self._checked: tuple[np.ndarray, ...] = ()
        self._identity: np.ndarray | None = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}(law={self.law!r}, chart={self.chart!r}, base={self.base!r})"

    # -- hooks for the subclasses ---------------------------------------------------------------

    def _reset_memory(self) -> None:
        """Clear the chart memory (continuity, sign, unwrap)."""

    def _memory0(self, lead: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """The chart memory before the first sample, arrays of leading shape ``lead`` (``(B,)``
        for the NumPy route, ``()`` for one spacecraft of the array law)."""
        raise NotImplementedError  # pragma: no cover

    def _member_memory0(self) -> tuple[np.ndarray, ...] | None:
        """Each spacecraft's own memory before the first sample ``(B, ...)`` where it is not
        the same for all (a quaternion adapter's per-spacecraft sign hints), else ``None``."""
        return None

    def _memory(self, B: int) -> tuple[np.ndarray, ...]:
        """The NumPy route's chart memory (from the adapter's attributes)."""
        raise NotImplementedError  # pragma: no cover

    def _set_memory(self, mem: tuple, switched: np.ndarray) -> None:
        """Store the NumPy route's chart memory after a sample."""
        raise NotImplementedError  # pragma: no cover

    def _pure_coords(self, mem: tuple, R_rel: Any, R_d_rel: Any) -> tuple:
        """Chart coordinates ``(y, y_d, switched_state, switched_desired, memory, extra)`` of
        ``R_rel`` and ``R_d_rel`` (``None``: the base is the desired frame, y_d the identity)
        given the memory before the sample; pure (NumPy or JAX), ``extra`` a dict of further
        per-sample values (diagnostics)."""
        raise NotImplementedError  # pragma: no cover

    def _check_coords(self, s: ChartState, extra: dict) -> None:
        """The NumPy route's refusal of a sample (Euler: gimbal lock raises)."""

    def _identity_coords(self, B: int) -> np.ndarray:
        """The chart's coordinates of the identity (the desired point when base = reference)."""
        if self._identity is None or self._identity.shape[0] != B:
            self._identity = self.chart.identity(B)
        return self._identity.copy()

    def _before_law(self, switched: np.ndarray, switched_d: np.ndarray) -> None:
        """Called after the chart conversion, before the law (MRP shadow-switch hook)."""

    # -- controller interface -------------------------------------------------------------------

    def reset(self, t0: float, batch_size: int) -> None:
        """Clear the chart memory and reset the law."""
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)):
            raise ValueError(f"batch_size: expected a positive int, got {batch_size!r}")
        if batch_size < 1:
            raise ValueError(f"batch_size: must be >= 1, got {batch_size}")
        t0 = as_scalar(t0, "t0")
        self._batch = int(batch_size)
        self._diag = {}
        self._reset_memory()
        self.law.reset(t0, int(batch_size))

    def _rotation(self, R: object, name: str) -> np.ndarray:
        """Validated rotation; a read-only array owning its data (e.g. ConstantAttitude's R_d)
        cannot change between samples, so it is checked once (as GeometricPD does)."""
        if isinstance(R, np.ndarray) and any(R is c for c in self._checked):
            return R
        R = check_rotation_matrix(R, name)
        if isinstance(R, np.ndarray) and not R.flags.writeable and R.base is None:
            self._checked = (self._checked + (R,))[-4:]
        return R

    def _base_sample(
        self, t: float, reference: AttitudeReference, B: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.base == "inertial":
            return _EYE3, np.zeros((B, 3)), np.zeros((B, 3))
        ref = reference if self.base == "reference" else self.base(t)
        for attr in ("R_d", "omega_d", "omega_dot_d"):
            if not hasattr(ref, attr):
                raise ValueError(
                    f"base: the frame sample has no attribute {attr!r} (expected an "
                    "AttitudeReference-like object)"
                )
        name = "R_d" if self.base == "reference" else "base"
        R_b = _as_batch(self._rotation(ref.R_d, name), B, (3, 3), name)
        w_b = _as_batch(as_array(ref.omega_d, name), B, (3,), name)
        dw_b = _as_batch(as_array(ref.omega_dot_d, name), B, (3,), name)
        return R_b, w_b, dw_b

    def chart_state(
        self, t: float, state: AttitudeState, reference: AttitudeReference
    ) -> ChartState:
        """Convert ``(state, reference)`` into the chart (advances the chart memory)."""
        if self._batch is None:
            raise RuntimeError(f"{type(self).__name__}.command: call reset(t0, batch_size) first")
        t = as_scalar(t, "t")  # first: nothing (chart memory) changes for a bad call
        # the simulator's validated arrays pass the cheap checks; anything else in full
        R, w = validated_rotation_and_rate(state)
        B = check_state_batch(R, w, self._batch)
        R_d = _as_batch(self._rotation(reference.R_d, "R_d"), B, (3, 3), "R_d")
        w_d = _as_batch(as_array(reference.omega_d, "omega_d"), B, (3,), "omega_d")
        dw_d = _as_batch(as_array(reference.omega_dot_d, "omega_dot_d"), B, (3,), "omega_dot_d")
        frame = None if self.base == "reference" else self._base_sample(t, reference, B)
        s, mem, sw, sw_d, extra = chart_sample(
            self.chart, self._pure_coords, self._memory(B), R, w, R_d, w_d, dw_d, frame, t
        )
        self._check_coords(s, extra)  # before the memory moves on (a refused sample changes none)
        self._set_memory(mem, sw)
        self._before_law(sw, sw_d)
        if state.h is None:
            return s
        return _replace_h(s, as_array(state.h, "h", (3,)))

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m] from the chart law."""
        s = self.chart_state(t, state, reference)
        u = np.asarray(self.law(s.t, s), dtype=np.float64)
        B = s.batch_size
        if u.shape != (B, 3):
            raise ValueError(f"law: returned torque of shape {u.shape}, expected {(B, 3)}")
        if not np.all(np.isfinite(u)):
            raise ValueError(f"law: returned a non-finite torque at t = {t:.6g} s")
        law_diag = getattr(self.law, "diagnostics", None)
        diag = dict(law_diag()) if callable(law_diag) else {}
        diag.update({"chart_y": s.y, "chart_y_d": s.y_d, "chart_switched": s.switched})
        self._diag = diag
        return u

    def diagnostics(self) -> dict[str, np.ndarray]:
        """The law's diagnostics plus ``chart_y``, ``chart_y_d`` ``(B, n)`` and
        ``chart_switched`` ``(B,)`` of the last sample."""
        return dict(self._diag)

    #: whether the chart conversion (:meth:`_pure_coords`) is pure, so the adapter has an array law
    _array_chart = True

    def array_law(self) -> ArrayLaw:
        """The adapter as a pure array law (:mod:`liecontrol.control.array_law`): the pure chart
        conversion (:func:`chart_sample` with the adapter's chart and memory) composed with the
        law's own pure form (its ``array_law()``, a :class:`ChartArrayLaw`). The scan carries
        the chart memory (MRP: previous σ, σ_d and a first-sample flag; quaternion: previous q
        and q_d; Euler: previous y_d and the flag) ahead of the law's state; diagnostics: the
        law's plus ``chart_y``, ``chart_y_d`` and ``chart_switched``. Bases: the desired frame
        or the inertial frame (a callable frame is sampled in Python).

        ``ValueError`` names the part without an array form: ``controller.law`` (no
        ``array_law``, or a ``__call__`` its ``array_law`` does not describe),
        ``controller.base``, or the adapter's chart."""
        law = self.law
        lname = type(law).__name__
        fn = getattr(law, "array_law", None)
        if not callable(fn):
            raise ValueError(
                f"controller.law: {lname} has no array_law (the chart-law protocol's pure form, "
                "liecontrol.control.adapters); run spacecraft.simulate with backend='numba'"
            )
        law_owner, call_owner = _owner(type(law), "array_law"), _owner(type(law), "__call__")
        if (
            law_owner is not None
            and call_owner is not None
            and call_owner is not law_owner
            and issubclass(call_owner, law_owner)
        ):
            raise ValueError(
                f"controller.law: {lname} overrides __call__() but not array_law(): its parent's "
                f"law ({law_owner.__name__}) would not be its own"
            )
        if not isinstance(self.base, str):
            raise ValueError(
                "controller.base: the array law converts with the desired frame ('reference') "
                "or the inertial frame as base; a callable frame is sampled in Python (run "
                "spacecraft.simulate with backend='numba')"
            )
        if not self._array_chart:
            raise ValueError(
                f"controller: {type(self).__name__}'s chart conversion has no array form; run "
                "spacecraft.simulate with backend='numba'"
            )
        claw = fn()
        if not isinstance(claw, ChartArrayLaw):
            raise ValueError(
                f"controller.law: {lname}.array_law() returned {type(claw).__name__}, expected a "
                "ChartArrayLaw"
            )
        mem0 = tuple(self._memory0(()))
        n = len(mem0)
        chart, coords = self.chart, self._pure_coords
        frame = None if self.base == "reference" else (_EYE3, np.zeros(3), np.zeros(3))
        hook, law_step = claw.on_shadow_switch, claw.step

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T, **kw):  # noqa: ANN001, ANN003
            s, mem, sw, sw_d, extra = chart_sample(
                chart, coords, tuple(state[:n]), R, omega, R_d, omega_d, omega_dot_d, frame
            )
            ls = tuple(state[n:])
            if hook is not None:
                ls = tuple(hook(ls, sw, sw_d))
            u, ls, diag = law_step(k_R, k_Omega, ls, s, T, **kw)
            if "chart_lock" in extra:
                # the chart's singularity: no torque (NaN, so the run flags the member diverged)
                u = namespace(u, extra["chart_lock"]).where(extra["chart_lock"], np.nan, u)
            diag = {**diag, **extra, "chart_y": s.y, "chart_y_d": s.y_d, "chart_switched": sw}
            return u, tuple(mem) + tuple(ls), diag

        members = self._member_memory0()
        if members is not None:
            B = members[0].shape[0]
            members = tuple(members) + tuple(
                np.broadcast_to(np.asarray(a), (B, *np.shape(a))) for a in claw.state0
            )
        return ArrayLaw(
            claw.k_R, claw.k_Omega, mem0 + tuple(claw.state0), step, claw.params,
            timed=bool(claw.timed), member_state0=members,
        )  # fmt: skip


class EulerChartAdapter(ChartAdapter):
    """Wrap an Euler-angle law (module docstring) as an SO(3) controller.

    Args:
        law: chart law; receives ``s.y = (a1, a2, a3)`` of the body relative to ``base``.
        seq: Euler sequence, scipy notation (``"ZYX"`` = aerospace 3-2-1, the default).
        base: ``"inertial"`` (default here, as in Liu, Tang & Yu 2008), ``"reference"`` or a
            callable frame.
        lock_tol: gimbal-lock tolerance on |cos a2| (Tait–Bryan) or |sin a2| (proper Euler);
            below it (state or reference) :class:`ChartSingularityError` is raised. Default
            1e-2, i.e. |a2| > 89.43° for ``"ZYX"``.
        unwrap: keep a1, a3 continuous across ±π (``y_d`` unwrapped in time, ``y`` reported
            within π of ``y_d``).
    """

    def __init__(
        self,
        law: Any,
        seq: str = "ZYX",
        base: object = "inertial",
        lock_tol: float = 1e-2,
        unwrap: bool = True,
    ) -> None:
        super().__init__(law, EulerChart(seq, lock_tol), base)
        self.unwrap = bool(unwrap)
        self._y_d_prev: np.ndarray | None = None

    def _reset_memory(self) -> None:
        self._y_d_prev = None

    def _memory0(self, lead: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """(previous y_d, has a previous sample)."""
        return np.zeros(lead + (3,)), np.zeros(lead, dtype=bool)

    def _memory(self, B: int) -> tuple[np.ndarray, ...]:
        if self._y_d_prev is None:
            return self._memory0((B,))
        return self._y_d_prev, np.ones(B, dtype=bool)

    def _set_memory(self, mem: tuple, switched: np.ndarray) -> None:
        self._y_d_prev = np.array(mem[0], copy=True)

    def _pure_coords(self, mem: tuple, R_rel: Any, R_d_rel: Any) -> tuple:
        ch = self.chart
        xp = namespace(R_rel)
        y = ch.from_matrix(R_rel)
        if R_d_rel is None:
            y_d = xp.zeros(y.shape) + ch.identity(1)[0]
        else:
            y_d = ch.from_matrix(R_d_rel)
        extra = {}
        if xp is np:  # the NumPy route refuses the sample
            ch.check_lock(y, "R")
            ch.check_lock(y_d, "R_d")
        else:  # the array law reports the lock (and poisons the torque: ChartAdapter.array_law)
            extra["chart_lock"] = ch.near_lock(y) | ch.near_lock(y_d)
        y_d_prev, has = mem
        if self.unwrap:
            y, y_d = euler_unwrap(y, y_d, y_d_prev, has)
        no = xp.zeros(y.shape[:-1], dtype=bool)
        return y, y_d, no, no, (y_d, xp.ones(y.shape[:-1], dtype=bool)), extra


class MrpChartAdapter(ChartAdapter):
    """Wrap an MRP law (module docstring) as an SO(3) controller, with shadow-set switching.

    Args:
        law: chart law; may implement ``on_shadow_switch(state_mask, desired_mask)``.
        base: ``"reference"`` (default: p is the attitude-error MRP, p_d = 0), ``"inertial"``
            or a callable frame (Wu et al.: the orbit frame).
        threshold: switch to the shadow when |p| > threshold (≥ 1; 1 = classical switch).
    """

    def __init__(self, law: Any, base: object = "reference", threshold: float = 1.0) -> None:
        super().__init__(law, MrpChart(), base)
        thr = as_scalar(threshold, "threshold")
        if thr < 1.0:
            raise ValueError(f"threshold: must be >= 1 (got {thr}); below 1 the switch chatters")
        self.threshold = thr
        self._p_prev: np.ndarray | None = None
        self._pd_prev: np.ndarray | None = None
        self.n_switches = 0

    def _reset_memory(self) -> None:
        self._p_prev = None
        self._pd_prev = None
        self.n_switches = 0

    def _memory0(self, lead: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """(previous σ, previous σ_d, has a previous sample)."""
        return np.zeros(lead + (3,)), np.zeros(lead + (3,)), np.zeros(lead, dtype=bool)

    def _memory(self, B: int) -> tuple[np.ndarray, ...]:
        if self._p_prev is None:
            return self._memory0((B,))
        pd = np.zeros((B, 3)) if self._pd_prev is None else self._pd_prev
        return self._p_prev, pd, np.ones(B, dtype=bool)

    def _set_memory(self, mem: tuple, switched: np.ndarray) -> None:
        self._p_prev, self._pd_prev = np.array(mem[0], copy=True), np.array(mem[1], copy=True)
        self.n_switches += int(np.count_nonzero(switched))

    def _pure_coords(self, mem: tuple, R_rel: Any, R_d_rel: Any) -> tuple:
        xp = namespace(R_rel)
        p_prev, pd_prev, has = mem
        thr2 = self.threshold**2
        p, sw = mrp_track(self.chart.from_matrix_trusted(R_rel), p_prev, has, thr2)
        if R_d_rel is None:
            p_d, sw_d = xp.zeros(p.shape), xp.zeros(p.shape[:-1], dtype=bool)
        else:
            p_d, sw_d = mrp_track(self.chart.from_matrix_trusted(R_d_rel), pd_prev, has, thr2)
        return p, p_d, sw, sw_d, (p, p_d, xp.ones(p.shape[:-1], dtype=bool)), {}

    def _before_law(self, switched: np.ndarray, switched_d: np.ndarray) -> None:
        hook = getattr(self.law, "on_shadow_switch", None)
        if callable(hook) and (np.any(switched) or np.any(switched_d)):
            hook(switched.copy(), switched_d.copy())


class QuaternionChartAdapter(ChartAdapter):
    """Wrap a quaternion law (module docstring) as an SO(3) controller, owning the sign.

    Args:
        law: chart law; receives ``s.y = q`` (scalar-first) of the body relative to ``base``.
        base: ``"reference"`` (default: q is the error quaternion of R_dᵀR), ``"inertial"`` or a
            callable frame.
        sign_mode: ``"continuous"`` (q continuous in time from the start; unwinding-prone),
            ``"switched"`` (w ≥ 0 always) or ``"hysteretic"`` (flip when w < −hysteresis).
        hysteresis: δ ∈ (0, 1) of the hysteretic mode.
        q_hint: ``(4,)`` or ``(B, 4)`` quaternion whose sign picks the sign of the first sample
            (``+q`` if q·q_hint ≥ 0, else ``−q``); default identity (w ≥ 0). A −q start of the
            unwinding benchmark is ``q_hint = −q₀``.

    The desired quaternion ``y_d`` is tracked continuously (identity with ``base="reference"``).
    """

    def __init__(
        self,
        law: Any,
        base: object = "reference",
        sign_mode: str = "continuous",
        hysteresis: float = 0.2,
        q_hint: object = None,
    ) -> None:
        super().__init__(law, QuaternionChart(), base)
        if sign_mode not in SIGN_MODES:
            raise ValueError(f"sign_mode: expected one of {SIGN_MODES}, got {sign_mode!r}")
        self.sign_mode = sign_mode
        hyst = check_positive(hysteresis, "hysteresis")
        if not isinstance(hyst, float) or hyst >= 1.0:
            raise ValueError(f"hysteresis: must be a scalar in (0, 1), got {hysteresis}")
        self.hysteresis = hyst
        if q_hint is None:
            self.q_hint = None
        else:
            qh = _quat.normalize(as_array(q_hint, "q_hint", (4,)))
            if qh.ndim not in (1, 2):
                raise ValueError(f"q_hint: expected shape (4,) or (B, 4), got {qh.shape}")
            self.q_hint = qh
        self._q_prev: np.ndarray | None = None
        self._qd_prev: np.ndarray | None = None

    def _reset_memory(self) -> None:
        self._q_prev = None
        self._qd_prev = None

    def _hint(self, lead: tuple[int, ...]) -> np.ndarray:
        """The first sample's sign reference: zeros (switched: no flip at the first sample), the
        identity, or ``q_hint``."""
        if self.sign_mode == "switched":
            return np.zeros(lead + (4,))
        if self.q_hint is None:
            return np.array(np.broadcast_to([1.0, 0.0, 0.0, 0.0], lead + (4,)))
        h = self.q_hint
        if lead == () and h.ndim == 2:
            # one spacecraft's default (the array law carries each spacecraft's own hint as its
            # per-member initial memory: _member_memory0)
            h = h[0]
        return np.array(np.broadcast_to(h, lead + (4,)), dtype=np.float64)

    def _member_memory0(self) -> tuple[np.ndarray, ...] | None:
        """Per-spacecraft hints differ: each spacecraft's first-sample memory ``(B, ...)``."""
        h = self.q_hint
        if self.sign_mode == "switched" or h is None or h.ndim != 2 or (h == h[:1]).all():
            return None
        return self._memory0((h.shape[0],))

    def _memory0(self, lead: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """(previous q — at the first sample the hint —, previous q_d — zeros: no sign yet)."""
        return self._hint(lead), np.zeros(lead + (4,))

    def _memory(self, B: int) -> tuple[np.ndarray, ...]:
        if self._q_prev is None:
            return self._memory0((B,))
        qd = np.zeros((B, 4)) if self._qd_prev is None else self._qd_prev
        return self._q_prev, qd

    def _set_memory(self, mem: tuple, switched: np.ndarray) -> None:
        self._q_prev, self._qd_prev = np.array(mem[0], copy=True), np.array(mem[1], copy=True)

    def _pure_coords(self, mem: tuple, R_rel: Any, R_d_rel: Any) -> tuple:
        xp = namespace(R_rel)
        q_prev, qd_prev = mem
        q, flip = quaternion_sign(
            self.chart.from_matrix_trusted(R_rel), q_prev, self.sign_mode, self.hysteresis
        )
        if R_d_rel is None:
            q_d = xp.zeros(q.shape) + np.array([1.0, 0.0, 0.0, 0.0])
        else:
            # the desired quaternion continuous in time (its first sample: w ≥ 0)
            q_d, _ = quaternion_sign(self.chart.from_matrix_trusted(R_d_rel), qd_prev,
                                     "continuous", 0.0)  # fmt: skip
        return q, q_d, flip, xp.zeros(q.shape[:-1], dtype=bool), (q, q_d), {}
