"""Geometric PID attitude controllers on SO(3) (Jiang, Meng & Yang 2023, Lemma 5).

Both controllers are the geometric PD of :mod:`liecontrol.control.geometric_pd` plus an integral
term ``−K_I z`` whose state ``z`` (``(B, 3)``) is integrated inside the controller:

    M = −K_R e_R − K_Ω e_Ω + Ω × JΩ − J (Ω^ RᵀR_d Ω_d − RᵀR_d Ω̇_d) − K_I z.

:class:`IntrinsicPID` — the intrinsic PID of Maithripala & Berg (Automatica 54, 2015; survey
Lemma 5). The integral state ``z = ω_I`` obeys

    ω̇_I = Γ(e_Ω, ω_I) + e_R,
    Γ(ω, η) = ½ (ω × η − J⁻¹(Jη × ω + Jω × η))                        (connection="survey")

as printed in the survey (Jiang, Meng & Yang 2023, Lemma 5), with ``e_R`` the gradient of the
chosen error function (``log(R_dᵀR)^∨`` by default, Lemma 5's ``log(R)``). *Reconstructed* parts:

- the survey prints ``τ = J⁻¹(ω × Jω − d_ω − K_p log R − K_I ω_I − K_d ω)``, which is not
  dimensionally a torque for the model ``J ω̇ = −ω × Jω + τ + d_ω`` it states; the law used here is
  the torque ``τ = ω × Jω − K_p log(R̃)^∨ − K_I ω_I − K_d e_Ω`` (+ the tracking feed-forward of the
  PD), and the unknown disturbance ``d_ω`` is *not* fed forward: rejecting it is the integral's job;
- tracking: ``log(R)`` becomes the body-frame error ``log(R_dᵀR)^∨`` and ``ω`` the rate error
  ``e_Ω = ω − RᵀR_dω_d`` (the survey's error model, eq. (13)); for regulation ``e_Ω = ω``;
- the sign of the connection term. The Levi-Civita connection of the kinetic-energy metric ``J``
  for left-invariant (body) velocities, ``∇_ω η = η̇ + ½ ω × η − ½ J⁻¹(Jη × ω + Jω × η)``, has
  geodesics ``J ω̇ = Jω × ω`` (Euler's free rigid body) and torsion ``∇_ω η − ∇_η ω = ω × η``;
  the survey's ``Γ`` is its negative (a right-invariant/bracket sign convention), so its ω_I is not
  ``∇_ω ω_I = e_R`` in this package's convention. ``connection="levi_civita"`` integrates
  ``∇_{e_Ω} ω_I = e_R``, i.e. ``ω̇_I = −Γ(e_Ω, ω_I) + e_R``. The two differ by terms quadratic in
  (e_Ω, ω_I), so both have the same linearisation and both reject constant disturbances
  (tests); the default follows the survey.

:class:`IntegralPD` — the integral-of-error variant (Goodarzi, Lee & Lee, "Geometric nonlinear
PID control of a quadrotor UAV on SE(3)", ECC 2013): ``ż = e_Ω + c e_R`` with ``c > 0`` [1/s] and
the chosen error function (large-angle by default).

Linear design (:func:`integral_gain`). Near ``R = R_d`` with matrix gains ``∝ J`` from
:func:`~liecontrol.control.geometric_pd.gains_from_bandwidth` (``K_R S = ω_n² J``,
``K_Ω = 2ζω_n J``), ``K_I = ω_i K_R`` (intrinsic) or ``K_I = ω_i K_R / c`` (integral PD) gives the
per-axis characteristic polynomial ``s³ + 2ζω_n s² + ω_n²(1 [+ ω_i/c]) s + ω_i ω_n²`` (the bracket
for the integral PD only): the PD pair plus an integral pole near ``−ω_i``; Routh-stable for
``ω_i < 2ζω_n``.

Sampling (zero-order hold). Each ``command(t, ...)`` first advances ``z`` over the time elapsed
since the previous call with the integrand held from the previous sample (the exact integral of
the sampled-and-held integrand, i.e. explicit Euler), then computes the torque with the new ``z``
and stores the new integrand. Batched over B: one state row per spacecraft.

Anti-windup (both optional, both per spacecraft):

- ``integral_limit`` [N·m]: clamp. After each update ``z`` is scaled back along its own direction
  so that ``‖K_I z‖ ≤ integral_limit``: the integral torque never exceeds the limit.
- ``torque_limit`` [N·m] (scalar or per axis): the output is clipped to the box
  ``|M_i| ≤ torque_limit_i`` and, with ``conditional=True`` (default), *conditional integration*
  (Åström & Hägglund's "clamping"): the step of a spacecraft whose held command was saturated is
  skipped when it would push a saturated axis further into saturation; steps that unwind are kept.

Units: ``J`` [kg·m²], ``k_R`` [N·m per unit e_R], ``k_Omega`` [N·m·s/rad]; ``k_I`` [N·m per unit
of z]: ``z = ∫ e_R dt`` (intrinsic, log error: rad·s) or ``∫(e_Ω + c e_R) dt`` (rad).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._array_api import namespace, safe_sqrt
from .._kernels.geometric_pid import INTEGRAND_CODES, N_DIAG, N_STATE, geometric_pid_law
from .._validation import (
    as_array,
    as_scalar,
    check_positive,
    check_positive_scalar,
)
from .array_law import ArrayLaw
from .base import AttitudeController, AttitudeReference, AttitudeState, finite_command
from .geometric_pd import GeometricPD, _apply_gain, _as_matrix, _cross, check_gain
from .kernel import ControllerKernel

__all__ = [
    "IntrinsicPID",
    "IntegralPD",
    "integral_gain",
    "connection_term",
]

CONNECTIONS = ("survey", "levi_civita")


def connection_term(
    J: np.ndarray, omega: np.ndarray, eta: np.ndarray, connection: str = "survey"
) -> np.ndarray:
    """The velocity-dependent part of the intrinsic integrator, ``(B, 3)``.

    ``connection="survey"``: ``Γ(ω, η) = ½(ω × η − J⁻¹(Jη × ω + Jω × η))``;
    ``"levi_civita"``: ``−Γ(ω, η)``, so that ``η̇ = connection_term(...) + e`` is
    ``∇_ω η = e`` for the Levi-Civita connection of the metric ``J`` (module docstring).

    Args:
        J: ``(3, 3)`` inertia (validated by the caller); omega, eta: ``(B, 3)``.
    """
    if connection not in CONNECTIONS:
        raise ValueError(f"connection: expected one of {CONNECTIONS}, got {connection!r}")
    return _gamma(J, np.linalg.inv(J), omega, eta, connection == "survey")


def _gamma(
    J: np.ndarray, J_inv: np.ndarray, omega: np.ndarray, eta: np.ndarray, survey: bool
) -> np.ndarray:
    g = 0.5 * (_cross(omega, eta) - (_cross(eta @ J.T, omega) + _cross(omega @ J.T, eta)) @ J_inv.T)
    return g if survey else -g


def integral_gain(k_R: object, omega_i: float, c: float | None = None) -> float | np.ndarray:
    """Integral gain from the proportional gain and the integral corner ``omega_i`` [rad/s].

    ``K_I = ω_i K_R`` for :class:`IntrinsicPID` (``c=None``), ``K_I = ω_i K_R / c`` for
    :class:`IntegralPD` with its ``c`` (see the module docstring for the resulting linear loop;
    choose ``ω_i`` well below ``2ζω_n``, e.g. ``ω_n / 5``).
    """
    K = check_gain(k_R, "k_R")
    omega_i = check_positive_scalar(omega_i, "omega_i")
    scale = omega_i if c is None else omega_i / check_positive_scalar(c, "c")
    with np.errstate(over="ignore"):
        out = scale * K
    if not np.all(np.isfinite(out)):
        raise ValueError("omega_i: k_I = ω_i k_R overflows float64 for this input (too large)")
    return out


def integral_update(
    z: Any, f_prev: Any, u_raw_prev: Any, sat_prev: Any, dt: Any, k_I: Any,
    integral_limit: float | None, torque_limit: Any, conditional: bool,
) -> tuple[Any, Any, Any]:  # fmt: skip
    """One zero-order-hold update of the integral state with anti-windup (module docstring);
    pure, NumPy or JAX, batched over leading axes: ``z ← z + dt·f_prev``, the step skipped for
    a spacecraft whose held command was saturated on an axis the step would drive further
    (``conditional`` with a ``torque_limit``), then ``z`` scaled back so that
    ``‖K_I z‖ ≤ integral_limit``. Returns ``(z, frozen, clamped)``. At the first sample
    ``f_prev = 0`` (and nothing saturated), so the update is the identity there."""
    xp = namespace(z, f_prev, u_raw_prev, dt)
    step = dt * f_prev
    frozen = xp.zeros(z.shape[:-1], dtype=bool)
    if torque_limit is not None and conditional:
        du = -_apply_gain(k_I, step)
        frozen = xp.any(sat_prev & (du * u_raw_prev > 0.0), axis=-1)
        step = xp.where(frozen[..., None], 0.0, step)
    z = z + step
    clamped = xp.zeros(z.shape[:-1], dtype=bool)
    if integral_limit is not None:
        v = _apply_gain(k_I, z)
        n = np.linalg.norm(v, axis=-1) if xp is np else safe_sqrt((v * v).sum(-1), xp)
        clamped = n > integral_limit
        z = z * xp.where(clamped, integral_limit / xp.where(clamped, n, 1.0), 1.0)[..., None]
    return z, frozen, clamped


def integral_output(u_pd: Any, z: Any, k_I: Any, torque_limit: Any) -> tuple[Any, Any, Any, Any]:
    """``(u, u_raw, u_I, saturated)``: the PD torque plus ``u_I = −K_I z``, clipped to the box
    ``|u_i| ≤ torque_limit_i`` when there is one (``saturated`` per axis); pure, NumPy or JAX."""
    xp = namespace(u_pd, z)
    u_I = -_apply_gain(k_I, z)
    u_raw = u_pd + u_I
    if torque_limit is None:
        return u_raw, u_raw, u_I, xp.zeros(u_raw.shape, dtype=bool)
    return xp.clip(u_raw, -torque_limit, torque_limit), u_raw, u_I, xp.abs(u_raw) > torque_limit


def _check_torque_limit(x: object) -> np.ndarray | None:
    if x is None:
        return None
    a = as_array(x, "torque_limit")
    if a.shape not in ((), (3,)):
        raise ValueError(f"torque_limit: expected a scalar or shape (3,), got {a.shape}")
    check_positive(a, "torque_limit")
    out = np.broadcast_to(a, (3,)).copy()
    out.setflags(write=False)
    return out


def _pid_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """The integral controllers' diagnostics from their kernel rows ``(..., 16)``."""
    return {
        "Psi": rows[..., 0].copy(),
        "e_R": rows[..., 1:4].copy(),
        "e_Omega": rows[..., 4:7].copy(),
        "integral": rows[..., 7:10].copy(),
        "u_integral": rows[..., 10:13].copy(),
        "saturated": rows[..., 13] != 0.0,
        "integration_frozen": rows[..., 14] != 0.0,
        "integral_clamped": rows[..., 15] != 0.0,
    }


class _IntegralController(AttitudeController):
    """Geometric PD + integral state with ZOH integration and anti-windup (shared machinery)."""

    batched = True

    def __init__(
        self,
        J: object,
        k_R: object,
        k_Omega: object,
        k_I: object,
        error: str,
        G: object,
        integral_limit: float | None,
        torque_limit: object,
        conditional: bool,
    ) -> None:
        # the PD validates J, k_R, k_Omega, error and G and computes e_R, e_Ω and the PD torque
        self._pd = GeometricPD(J, k_R, k_Omega, error=error, G=G)
        self.J = self._pd.J
        self.error = self._pd.error
        self.k_I = check_gain(k_I, "k_I")
        self.integral_limit = (
            None if integral_limit is None else check_positive(integral_limit, "integral_limit")
        )
        if self.integral_limit is not None and not isinstance(self.integral_limit, float):
            raise ValueError("integral_limit: must be a scalar [N·m]")
        self.torque_limit = _check_torque_limit(torque_limit)
        if not isinstance(conditional, bool):
            raise ValueError(f"conditional: expected a bool, got {conditional!r}")
        self.conditional = conditional
        self._batch: int | None = None

    @property
    def k_R(self) -> float | np.ndarray:
        return self._pd.k_R

    @property
    def k_Omega(self) -> float | np.ndarray:
        return self._pd.k_Omega

    def reset(self, t0: float, batch_size: int) -> None:
        """Zero the integral states of ``batch_size`` spacecraft; the run starts at ``t0``."""
        self._pd.reset(t0, batch_size)
        B = int(batch_size)
        self._batch = B
        self._t_prev: float | None = None
        self.z = np.zeros((B, 3))
        self._f_prev = np.zeros((B, 3))
        self._u_raw_prev = np.zeros((B, 3))
        self._sat_prev = np.zeros((B, 3), dtype=bool)
        self._diag: dict[str, np.ndarray] = {}

    def _integrand(self, z: np.ndarray, e_R: np.ndarray, e_W: np.ndarray) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover - implemented by the subclasses

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]; advances the integral state to ``t`` first (ZOH)."""
        if self._batch is None:
            raise RuntimeError(f"{type(self).__name__}.command: call reset(t0, batch_size) first")
        t = as_scalar(t, "t")
        u_pd = self._pd.command(t, state, reference)
        d = self._pd.diagnostics()
        e_R, e_W = d["e_R"], d["e_Omega"]
        B = self._batch
        frozen = np.zeros(B, dtype=bool)
        clamped = np.zeros(B, dtype=bool)
        if self._t_prev is not None:
            dt = t - self._t_prev
            if dt < 0.0:
                raise ValueError(
                    f"t: {t!r} is earlier than the previous control sample {self._t_prev!r}"
                )
            self.z, frozen, clamped = integral_update(
                self.z, self._f_prev, self._u_raw_prev, self._sat_prev, dt, self.k_I,
                self.integral_limit, self.torque_limit, self.conditional,
            )  # fmt: skip
        self._t_prev = t
        u, u_raw, u_I, sat = integral_output(u_pd, self.z, self.k_I, self.torque_limit)
        self._u_raw_prev = u_raw
        self._sat_prev = sat
        self._f_prev = self._integrand(self.z, e_R, e_W)
        d.update(
            integral=self.z.copy(),
            u_integral=u_I,
            saturated=sat.any(axis=-1),
            integration_frozen=frozen,
            integral_clamped=clamped,
        )
        self._diag = d
        return finite_command(u, state.omega)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.geometric_pid.geometric_pid_law`) for
        the simulator's fused loop (:mod:`liecontrol.control.kernel`), carrying the integral
        state; ``None`` for a subclass with its own integrand."""
        kind = getattr(self, "connection", "integral_pd")
        own = type(self)._integrand
        if own is not IntrinsicPID._integrand and own is not IntegralPD._integrand:
            return None
        B = int(batch_size)
        tl = self.torque_limit
        J = np.ascontiguousarray(self.J, dtype=np.float64)
        params = np.concatenate(
            [
                self._pd.fused_kernel(B).params,
                _as_matrix(self.k_I).ravel(),
                [
                    -1.0 if self.integral_limit is None else float(self.integral_limit),
                    0.0 if tl is None else 1.0,
                ],
                np.zeros(3) if tl is None else tl,
                [float(self.conditional), float(INTEGRAND_CODES[kind]), getattr(self, "c", 0.0)],
                np.linalg.inv(J).ravel(),
                J.ravel(),
            ]
        )
        state = np.zeros((B, N_STATE))
        if getattr(self, "_t_prev", None) is not None and self._batch == B:
            state[:, 0] = 1.0
            state[:, 1] = self._t_prev
            state[:, 2:5] = self.z
            state[:, 5:8] = self._f_prev
            state[:, 8:11] = self._u_raw_prev
            state[:, 11:14] = self._sat_prev
        return ControllerKernel(geometric_pid_law, params, state, N_DIAG, _pid_rows, self._finish)

    def _kernel_reason(self) -> str:
        return "a subclass with its own integrand"

    def array_law(self) -> ArrayLaw:
        """The law as a pure array function for the differentiable loop
        (:mod:`liecontrol.control.array_law`): the PD's (:meth:`GeometricPD.array_law`), then
        :func:`integral_update` and :func:`integral_output` — the functions :meth:`command`
        calls — with the state (z, held integrand, raw torque, saturated axes) carried from
        one sample to the next. ``ValueError`` for a subclass with its own integrand (its
        formula must be pure to fly: define ``array_law``)."""
        own = type(self)._integrand
        if own is not IntrinsicPID._integrand and own is not IntegralPD._integrand:
            raise ValueError(
                f"controller: {type(self).__name__} has its own integrand; define array_law"
            )
        pd = self._pd.array_law()
        k_I, limit, box, cond = self.k_I, self.integral_limit, self.torque_limit, self.conditional
        integrand = self._integrand

        def step(k_R, k_Omega, state, R, omega, R_d, omega_d, omega_dot_d, T):  # noqa: ANN001
            u_pd, _, d = pd.step(k_R, k_Omega, (), R, omega, R_d, omega_d, omega_dot_d, T)
            z, frozen, clamped = integral_update(*state, T, k_I, limit, box, cond)
            u, u_raw, u_I, sat = integral_output(u_pd, z, k_I, box)
            d = {**d, "integral": z, "u_integral": u_I, "saturated": sat.any(-1),
                 "integration_frozen": frozen, "integral_clamped": clamped}  # fmt: skip
            return u, (z, integrand(z, d["e_R"], d["e_Omega"]), u_raw, sat), d

        zero = np.zeros(3)
        return ArrayLaw(self.k_R, self.k_Omega, (zero, zero, zero, np.zeros(3, bool)), step)

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """The integral state and diagnostics after a compiled run (as the Python loop)."""
        self._t_prev = float(state[0, 1]) if state[0, 0] != 0.0 else None
        self.z = state[:, 2:5].copy()
        self._f_prev = state[:, 5:8].copy()
        self._u_raw_prev = state[:, 8:11].copy()
        self._sat_prev = state[:, 11:14] != 0.0
        self._pd._set_diagnostics(diag[:, :7].copy())
        self._diag = _pid_rows(diag)

    def diagnostics(self) -> dict[str, np.ndarray]:
        """Last ``Psi`` ``(B,)``, ``e_R``, ``e_Omega``, ``integral`` (the state z),
        ``u_integral`` (``−K_I z``) ``(B, 3)`` and the anti-windup flags ``saturated``,
        ``integration_frozen``, ``integral_clamped`` ``(B,)`` (empty before the first command)."""
        return dict(self._diag)


class IntrinsicPID(_IntegralController):
    """Intrinsic PID of Maithripala & Berg on SO(3) (Jiang, Meng & Yang 2023, Lemma 5).

    ``M = PD(e_R, e_Ω) − K_I ω_I`` with ``ω̇_I = connection_term(J, e_Ω, ω_I) + e_R``
    (module docstring for the law, its reconstruction and the anti-windup).

    Args:
        J: 3×3 inertia the controller assumes [kg·m²] (also used by the connection term).
        k_R, k_Omega, k_I: proportional, derivative and integral gains: positive scalar, positive
            3-vector (diagonal) or SPD 3×3 matrix.
        error: error function whose gradient is integrated: ``"log"`` (default, Lemma 5),
            ``"large_angle"`` or ``"trace"``; G: trace-error weight.
        connection: ``"survey"`` (default, the survey's formula) or ``"levi_civita"``.
        integral_limit: clamp of ``‖K_I ω_I‖`` [N·m], or ``None``.
        torque_limit: output box [N·m] (scalar or (3,)), or ``None``.
        conditional: conditional integration while saturated (only with ``torque_limit``).
    """

    def __init__(
        self,
        J: object,
        k_R: object,
        k_Omega: object,
        k_I: object,
        *,
        error: str = "log",
        G: object = None,
        connection: str = "survey",
        integral_limit: float | None = None,
        torque_limit: object = None,
        conditional: bool = True,
    ) -> None:
        super().__init__(J, k_R, k_Omega, k_I, error, G, integral_limit, torque_limit, conditional)
        if connection not in CONNECTIONS:
            raise ValueError(f"connection: expected one of {CONNECTIONS}, got {connection!r}")
        self.connection = connection
        self._J_inv = np.linalg.inv(self.J)

    def __repr__(self) -> str:
        return (
            f"IntrinsicPID(error={self.error!r}, connection={self.connection!r}, "
            f"k_R={self.k_R!r}, k_Omega={self.k_Omega!r}, k_I={self.k_I!r})"
        )

    def _integrand(self, z: np.ndarray, e_R: np.ndarray, e_W: np.ndarray) -> np.ndarray:
        return _gamma(self.J, self._J_inv, e_W, z, self.connection == "survey") + e_R


class IntegralPD(_IntegralController):
    """Geometric PD plus the integral of ``e_Ω + c e_R`` (integral variant).

    ``M = PD(e_R, e_Ω) − K_I e_I``, ``ė_I = e_Ω + c e_R`` (Goodarzi, Lee & Lee 2013).

    Args:
        J, k_R, k_Omega, k_I, G, integral_limit, torque_limit, conditional: as
            :class:`IntrinsicPID`.
        c: weight of ``e_R`` in the integrand [1/s], > 0.
        error: ``"large_angle"`` (default), ``"log"`` or ``"trace"``.
    """

    def __init__(
        self,
        J: object,
        k_R: object,
        k_Omega: object,
        k_I: object,
        *,
        c: float = 0.03,
        error: str = "large_angle",
        G: object = None,
        integral_limit: float | None = None,
        torque_limit: object = None,
        conditional: bool = True,
    ) -> None:
        super().__init__(J, k_R, k_Omega, k_I, error, G, integral_limit, torque_limit, conditional)
        c = check_positive(c, "c")
        if not isinstance(c, float) or not math.isfinite(c):
            raise ValueError("c: must be a finite scalar [1/s]")
        self.c = c

    def __repr__(self) -> str:
        return (
            f"IntegralPD(error={self.error!r}, c={self.c!r}, k_R={self.k_R!r}, "
            f"k_Omega={self.k_Omega!r}, k_I={self.k_I!r})"
        )

    def _integrand(self, z: np.ndarray, e_R: np.ndarray, e_W: np.ndarray) -> np.ndarray:
        return e_W + self.c * e_R
