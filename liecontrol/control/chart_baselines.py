"""Chart-based baseline controllers: quaternion PD and MRP PD.

Both are chart laws wrapped by the adapters of :mod:`liecontrol.control.adapters` with
``base="reference"``, so the chart coordinates are those of the attitude error R̃ = R_dᵀR and
``ω_rel = e_Ω = ω − RᵀR_d ω_d``. They share the tracking feed-forward of the geometric PD
: ``ff = ω × Jω − J(ω × (RᵀR_d ω_d) − RᵀR_d ω̇_d)``.

* :class:`QuaternionPD` (Wie & Barba 1985; Wie, *Space Vehicle Dynamics and Control*, §7.3):

      u = −k_p q_v − k_d e_Ω + ff,   q = (w, q_v) the error quaternion,

  whose sign is owned by the adapter's ``sign_mode``: ``"continuous"`` (the quaternion followed
  continuously from the initial sign — a −q start drives the body the long way round, the
  *unwinding* of Bhat & Bernstein 2000), ``"switched"`` (w ≥ 0 at every sample: the short way,
  u = −k_p sign(w) q_v …, discontinuous at 180°) or ``"hysteretic"`` (Mayhew, Sanfelice &
  Teel 2011: the sign is kept until w < −δ).
* :class:`MrpPD` — the classical MRP feedback law (Schaub & Junkins, *Analytical Mechanics of
  Space Systems*, §8.3–8.4, u = −Kσ − [P]δω + feed-forward):

      u = −K σ − P e_Ω + ff,   σ = error MRP with shadow-set switching (|σ| ≤ 1).

  With the switch at |σ| = 1, σ is the short-way error, so the law does not unwind; the torque
  is discontinuous at 180° (where σ and its shadow both have norm 1 and opposite sign).

  ``feedforward`` picks the nonlinear terms added to −Kσ − P e_Ω (ω_r = RᵀR_d ω_d, the
  reference rate in body axes):

  - ``"gyroscopic"`` (default): ff above, ω × Jω − J(ω × ω_r − ω̇_r) — Basilisk's
    ``mrpFeedback`` with ``controlLawType = 1``;
  - ``"reference"``: ω_r × Jω − J(ω × ω_r − ω̇_r) — Basilisk's default ``mrpFeedback`` law
    (``controlLawType = 0``, no integral term, no wheels, no known torque), which avoids the
    term quadratic in ω (Schaub & Junkins, §8.4; the Basilisk module documentation states both
    forms); when regulating (ω_r = 0) it is the plain PD u = −Kσ − Pω;
  - ``"none"``: u = −Kσ − P e_Ω, no feed-forward at all.

  With a scalar K, V = ½ e_Ωᵀ J e_Ω + 2K ln(1 + σᵀσ) has V̇ = −e_Ωᵀ P e_Ω for "gyroscopic"
  and "reference" (tracking), and for "none" when ω_r = 0 (ω × Jω ⊥ ω); the cross terms that
  remain are orthogonal to e_Ω.

Gains are positive scalars, positive 3-vectors (diagonal) or SPD 3×3 matrices
(:func:`liecontrol.control.geometric_pd.check_gain`); units N·m per unit of q_v/σ and
N·m·s/rad.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._array_api import cross as _cross
from .._kernels.mrp_pd import FEEDFORWARD_CODES, mrp_pd_batch, mrp_pd_law
from .._kernels.quaternion_pd import SIGN_CODES, quaternion_pd_batch, quaternion_pd_law
from .._validation import (
    as_scalar,
    check_inertia_3x3,
)
from .adapters import ChartArrayLaw, ChartState, MrpChartAdapter, QuaternionChartAdapter
from .array_law import ArrayLaw
from .base import AttitudeReference, AttitudeState, check_state_batch, finite_command
from .geometric_pd import (
    _apply_gain,
    _as_matrix,
    _batch,
    check_gain,
    validated_reference,
    validated_rotation_and_rate,
)
from .kernel import ControllerKernel

__all__ = ["QuaternionPD", "MrpPD", "QuaternionPDLaw", "MrpPDLaw", "MRP_FEEDFORWARDS"]


def _quaternion_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The quaternion PD's diagnostics from its kernel rows ``(..., 5) = (q, flipped)``."""
    return {
        "q_w": rows[..., 0].copy(),
        "chart_y": rows[..., 0:4].copy(),
        "chart_y_d": np.broadcast_to([1.0, 0.0, 0.0, 0.0], rows.shape[:-1] + (4,)).copy(),
        "chart_switched": rows[..., 4] != 0.0,
    }


def _mrp_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The MRP PD's diagnostics from its kernel rows ``(..., 4) = (σ, switched)``."""
    return {
        "chart_y": rows[..., 0:3].copy(),
        "chart_y_d": np.zeros(rows.shape[:-1] + (3,)),
        "chart_switched": rows[..., 3] != 0.0,
    }


def _kernel_inputs(
    ctrl: Any, t: object, state: AttitudeState, reference: AttitudeReference
) -> tuple[np.ndarray, ...]:
    """The validated, contiguous ``(R, ω, R_d, ω_d, ω̇_d)`` batch arrays of a chart adapter's
    compiled route. The simulator's own (validated) arrays pass the cheap checks; anything else
    is validated in full, with the adapter's messages."""
    if ctrl._batch is None:
        raise RuntimeError(f"{type(ctrl).__name__}.command: call reset(t0, batch_size) first")
    as_scalar(t, "t")
    R, w = validated_rotation_and_rate(state)
    B = check_state_batch(R, w, ctrl._batch)
    R_d, w_d, dw_d = validated_reference(ctrl, reference, B)
    return (
        np.ascontiguousarray(R, dtype=np.float64),
        np.ascontiguousarray(w, dtype=np.float64),
        _batch(R_d, (B, 3, 3)),
        _batch(w_d, (B, 3)),
        _batch(dw_d, (B, 3)),
    )


def _inertia(J: object) -> np.ndarray:
    J = check_inertia_3x3(J, "J")
    J = J.copy()
    J.setflags(write=False)
    return J


def _feed_forward(J: np.ndarray, s: ChartState) -> np.ndarray:
    """ω × Jω − J(ω × (RᵀR_d ω_d) − RᵀR_d ω̇_d); with base = reference, ``s.omega_base`` is
    RᵀR_d ω_d and ``s.omega_dot_base`` is RᵀR_d ω̇_d (body axes). Pure (NumPy or JAX)."""
    w = s.omega
    return _cross(w, w @ J.T) - (_cross(w, s.omega_base) - s.omega_dot_base) @ J.T


def quaternion_pd_torque(s: ChartState, J: Any, k_p: Any, k_d: Any) -> Any:
    """u = −k_p q_v − k_d e_Ω + ff of :class:`QuaternionPDLaw` on the chart state ``s`` (batched
    or one spacecraft), pure (NumPy or JAX): the one formula of its NumPy and array routes."""
    u = -_apply_gain(k_p, s.y[..., 1:]) - _apply_gain(k_d, s.omega_rel)
    return u + _feed_forward(J, s)


def mrp_pd_torque(s: ChartState, J: Any, K: Any, P: Any, feedforward: str) -> Any:
    """u = −K σ − P e_Ω + ff of :class:`MrpPDLaw` (``feedforward`` as there) on the chart state
    ``s``, pure (NumPy or JAX): the one formula of its NumPy and array routes."""
    u = -_apply_gain(K, s.y) - _apply_gain(P, s.omega_rel)
    if feedforward == "gyroscopic":
        return u + _feed_forward(J, s)
    if feedforward == "reference":
        # Basilisk's default: ω_r × Jω in place of ω × Jω (no term quadratic in ω)
        w = s.omega
        return (
            u + _cross(s.omega_base, w @ J.T) - (_cross(w, s.omega_base) - s.omega_dot_base) @ J.T
        )
    return u


class QuaternionPDLaw:
    """u = −k_p q_v − k_d e_Ω + ff on the error quaternion ``s.y`` (module docstring)."""

    batched = True

    def __init__(self, J: object, k_p: object, k_d: object) -> None:
        self.J = _inertia(J)
        self.k_p = check_gain(k_p, "k_p")
        self.k_d = check_gain(k_d, "k_d")
        self._diag: dict[str, np.ndarray] = {}

    def reset(self, t0: float, batch_size: int) -> None:
        self._diag = {}

    def __call__(self, t: float, s: ChartState) -> np.ndarray:
        self._diag = {"q_w": s.y[:, 0].copy()}
        return quaternion_pd_torque(s, self.J, self.k_p, self.k_d)

    def array_law(self) -> ChartArrayLaw:
        """The law's pure form (:class:`~liecontrol.control.adapters.ChartArrayLaw`):
        :func:`quaternion_pd_torque` with the gains (k_p, k_d) differentiable; memoryless."""
        J = np.array(self.J)

        def step(k_p, k_d, state, s, T):  # noqa: ANN001
            return quaternion_pd_torque(s, J, k_p, k_d), state, {"q_w": s.y[..., 0]}

        return ChartArrayLaw(self.k_p, self.k_d, (), step)

    def diagnostics(self) -> dict[str, np.ndarray]:
        return dict(self._diag)


#: The ``feedforward`` options of :class:`MrpPD` (module docstring).
MRP_FEEDFORWARDS: tuple[str, ...] = ("gyroscopic", "reference", "none")


def _check_feedforward(feedforward: object) -> str:
    if not isinstance(feedforward, str) or feedforward not in MRP_FEEDFORWARDS:
        raise ValueError(
            f"feedforward: expected one of {', '.join(map(repr, MRP_FEEDFORWARDS))}, got "
            f"{feedforward!r}"
        )
    return feedforward


class MrpPDLaw:
    """u = −K σ − P e_Ω + ff on the (shadow-switched) error MRP ``s.y``; ``feedforward``
    selects ff (module docstring)."""

    batched = True

    def __init__(
        self, J: object, K: object, P: object, feedforward: str = "gyroscopic"
    ) -> None:
        self.J = _inertia(J)
        self.K = check_gain(K, "K")
        self.P = check_gain(P, "P")
        self.feedforward = _check_feedforward(feedforward)

    def reset(self, t0: float, batch_size: int) -> None:
        """Stateless."""

    def __call__(self, t: float, s: ChartState) -> np.ndarray:
        return mrp_pd_torque(s, self.J, self.K, self.P, self.feedforward)

    def array_law(self) -> ChartArrayLaw:
        """The law's pure form (:class:`~liecontrol.control.adapters.ChartArrayLaw`):
        :func:`mrp_pd_torque` with the gains (K, P) differentiable; memoryless."""
        J, ff = np.array(self.J), self.feedforward

        def step(K, P, state, s, T):  # noqa: ANN001
            return mrp_pd_torque(s, J, K, P, ff), state, {}

        return ChartArrayLaw(self.K, self.P, (), step)


class QuaternionPD(QuaternionChartAdapter):
    """Quaternion PD on the error quaternion (module docstring) as an SO(3) controller.

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        k_p: attitude gain [N·m per unit of q_v].  k_d: rate gain [N·m·s/rad].
        sign_mode: ``"continuous"`` (default; unwinding-prone), ``"switched"`` or
            ``"hysteretic"``.
        hysteresis: δ ∈ (0, 1) of the hysteretic mode.
        q_hint: quaternion whose sign picks the initial sign of q (``−q₀`` for a −q start).
    """

    def __init__(
        self,
        J: object,
        k_p: object,
        k_d: object,
        sign_mode: str = "continuous",
        hysteresis: float = 0.2,
        q_hint: object = None,
    ) -> None:
        super().__init__(
            QuaternionPDLaw(J, k_p, k_d),
            base="reference",
            sign_mode=sign_mode,
            hysteresis=hysteresis,
            q_hint=q_hint,
        )
        law = self.law
        # the compiled kernel's arguments (liecontrol._kernels.quaternion_pd)
        self._kargs = (
            SIGN_CODES[self.sign_mode],
            float(self.hysteresis),
            np.ascontiguousarray(law.J, dtype=np.float64),
            _as_matrix(law.k_p),
            _as_matrix(law.k_d),
        )
        self._checked_R_d = None

    def _kernel_applies(self) -> bool:
        """The compiled route: this law, the desired frame as base (not a subclass)."""
        return (
            type(self) is QuaternionPD
            and type(self.law) is QuaternionPDLaw
            and self.base == "reference"
        )

    def _first_hint(self, B: int) -> np.ndarray:
        """``(B, 4)`` quaternions whose signs pick the first sample's (identity by default;
        zeros in the switched mode, which takes w ≥ 0 and reports no flip at the first sample)."""
        if self.sign_mode == "switched":
            return np.zeros((B, 4))
        if self.q_hint is None:
            return np.tile([1.0, 0.0, 0.0, 0.0], (B, 1))
        return np.array(np.broadcast_to(self.q_hint, (B, 4)), dtype=np.float64)  # own copy

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]: the chart conversion, its sign handling and the law in
        one compiled kernel per spacecraft (the adapter's numpy route for subclasses)."""
        if not self._kernel_applies():
            return super().command(t, state, reference)
        R, w, R_d, w_d, dw_d = _kernel_inputs(self, t, state, reference)
        B = R.shape[0]
        q = self._first_hint(B) if self._q_prev is None else self._q_prev.copy()
        u = np.empty((B, 3))
        diag = np.empty((B, 11))
        mode, hyst, J, Kp, Kd = self._kargs
        quaternion_pd_batch(mode, hyst, J, Kp, Kd, R, w, R_d, w_d, dw_d, q, u, diag)
        self._set_kernel_state(diag, q)
        return finite_command(u, w)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.quaternion_pd.quaternion_pd_law`) for
        the simulator's fused loop (:mod:`liecontrol.control.kernel`), ``None`` where the
        adapter's numpy route runs (:meth:`_kernel_applies`)."""
        if not self._kernel_applies():
            return None
        mode, hyst, J, Kp, Kd = self._kargs
        params = np.concatenate([[float(mode), hyst], J.ravel(), Kp.ravel(), Kd.ravel()])
        q = self._first_hint(batch_size) if self._q_prev is None else self._q_prev.copy()
        return ControllerKernel(
            quaternion_pd_law, params, np.array(q, dtype=np.float64), 5,
            diagnostics=_quaternion_rows,
            finish=lambda state, diag: self._set_kernel_state(diag, state.copy()),
        )  # fmt: skip

    def _kernel_reason(self) -> str:
        return "a subclass, a swapped law or a base other than the reference frame"

    def array_law(self) -> ArrayLaw:
        """The pure law of the differentiable loop (:mod:`liecontrol.control.array_law`): the
        adapter's pure chart conversion with its sign memory carried by the scan (the previous
        quaternion, the hint at the first sample) and :func:`quaternion_pd_torque`; gains
        ``(k_p, k_d)``. (Declared here because :meth:`command` is: the compiled route computes
        the same law.)"""
        return super().array_law()

    def _set_kernel_state(self, diag: np.ndarray, q: np.ndarray) -> None:
        """Chart memory and diagnostics from the kernel's quaternions ``q (B, 4)`` and rows."""
        B = q.shape[0]
        self._q_prev = q.copy()
        self._qd_prev = np.tile([1.0, 0.0, 0.0, 0.0], (B, 1))
        self._diag = {
            "q_w": q[:, 0].copy(),
            "chart_y": q.copy(),
            "chart_y_d": self._qd_prev.copy(),
            "chart_switched": diag[:, 4] != 0.0,
        }


class MrpPD(MrpChartAdapter):
    """Classical MRP feedback u = −Kσ − P e_Ω + ff with shadow-set switching (module docstring).

    Args:
        J: 3×3 inertia the controller assumes [kg·m²].
        K: attitude gain [N·m per unit of σ] (σ ≈ θ/4 near the target).
        P: rate gain [N·m·s/rad].
        threshold: shadow-switch threshold (≥ 1; 1 = classical).
        feedforward: ``"gyroscopic"`` (default, ω × Jω + tracking terms), ``"reference"``
            (Basilisk's default ``mrpFeedback``: ω_r × Jω + tracking terms) or ``"none"``.
    """

    def __init__(
        self,
        J: object,
        K: object,
        P: object,
        threshold: float = 1.0,
        feedforward: str = "gyroscopic",
    ) -> None:
        super().__init__(
            MrpPDLaw(J, K, P, feedforward=feedforward), base="reference", threshold=threshold
        )
        law = self.law
        # the compiled kernel's arguments (liecontrol._kernels.mrp_pd)
        self._kargs = (
            FEEDFORWARD_CODES[law.feedforward],
            # |σ|² ≤ 1e300 always in practice: a huge threshold (never switch) stays finite
            min(float(self.threshold), 1e150) ** 2,
            np.ascontiguousarray(law.J, dtype=np.float64),
            _as_matrix(law.K),
            _as_matrix(law.P),
        )
        self._checked_R_d = None

    def _kernel_applies(self) -> bool:
        """The compiled route: this law, the desired frame as base (not a subclass, nor a law
        or base swapped in after construction)."""
        return type(self) is MrpPD and type(self.law) is MrpPDLaw and self.base == "reference"

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]: the chart conversion and the law in one compiled kernel
        per spacecraft (same arithmetic as the adapter's numpy route, which subclasses use)."""
        if not self._kernel_applies():
            return super().command(t, state, reference)
        R, w, R_d, w_d, dw_d = _kernel_inputs(self, t, state, reference)
        B = R.shape[0]
        has_prev = self._p_prev is not None
        p = self._p_prev if has_prev else np.zeros((B, 3))
        p = np.ascontiguousarray(p, dtype=np.float64).copy()
        u = np.empty((B, 3))
        diag = np.empty((B, 11))
        ff, thr2, J, K, P = self._kargs
        self.n_switches += mrp_pd_batch(
            ff, thr2, J, K, P, R, w, R_d, w_d, dw_d, has_prev, p, u, diag
        )
        self._set_kernel_state(diag, p)
        return finite_command(u, w)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.mrp_pd.mrp_pd_law`) for the simulator's
        fused loop (:mod:`liecontrol.control.kernel`), ``None`` where the adapter's numpy route
        runs (:meth:`_kernel_applies`). State: previous σ, has-previous flag, switch count."""
        if not self._kernel_applies():
            return None
        ff, thr2, J, K, P = self._kargs
        params = np.concatenate([[float(ff), thr2], J.ravel(), K.ravel(), P.ravel()])
        state = np.zeros((batch_size, 5))
        if self._p_prev is not None:
            state[:, :3] = self._p_prev
            state[:, 3] = 1.0

        def finish(state: np.ndarray, diag: np.ndarray) -> None:
            self.n_switches += int(state[:, 4].sum())
            self._set_kernel_state(diag, state[:, :3].copy())

        return ControllerKernel(mrp_pd_law, params, state, 4, _mrp_rows, finish)

    def _kernel_reason(self) -> str:
        return "a subclass, a swapped law or a base other than the reference frame"

    def array_law(self) -> ArrayLaw:
        """The pure law of the differentiable loop (:mod:`liecontrol.control.array_law`): the
        adapter's pure chart conversion with its shadow-set memory carried by the scan (the
        previous σ and a first-sample flag) and :func:`mrp_pd_torque`; gains ``(K, P)``.
        (Declared here because :meth:`command` is: the compiled route computes the same law.)"""
        return super().array_law()

    def _set_kernel_state(self, diag: np.ndarray, p: np.ndarray) -> None:
        """Chart memory and diagnostics from the kernel's σ ``p (B, 3)`` and ``(B, 7)`` rows."""
        B = p.shape[0]
        self._p_prev = p.copy()
        self._pd_prev = np.zeros((B, 3))
        self._diag = {
            "chart_y": p.copy(),
            "chart_y_d": np.zeros((B, 3)),
            "chart_switched": diag[:, 3] != 0.0,
        }
