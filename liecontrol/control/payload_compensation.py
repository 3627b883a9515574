"""Small-angle Euler PID with rotating-payload feed-forward compensation (Wang, Chu, Zhang & Yuan
2016).

Wang, Chu, Zhang & Yuan (2016, "On the influence of rotatable payload and control for
satellite attitude", *Aerospace Control and Application* 2016(5)) controls an Earth-pointing
satellite carrying a 90°/s rotating payload with a wheel PID plus a feed-forward sinusoid that
cancels the payload's imbalance torque.

**Chart.** Small Euler angles Δφ = (φ, θ, ψ) of the body relative to the reference (orbit) frame,
read through :class:`~liecontrol.control.adapters.EulerChartAdapter` (``base="reference"``): the
adapter gives the angles ``y`` of R_dᵀR and their exact rates ẏ = B(y) ω_rel with
ω_rel = ω − R_relᵀ ω_d. For the orbit frame (ω_d = (0, −n, 0)) and small angles this is the
paper's kinematics (its eq. (4), from Tu Shancheng's textbook)

    ω_x = φ̇ − nψ,   ω_y = θ̇ − n,   ω_z = ψ̇ + nφ,

to first order in the angles (checked in the tests). Any Tait–Bryan sequence may be used; the
small angles are mapped to body axes by their rotation axis (``seq="XYZ"``: y = (φ, θ, ψ)).

**PID** (the paper's eq. (17), sampled every Δt_c, held in between), per axis j:

    T_c,j = −(k_p,j Δφ_j + k_i,j ∫Δφ_j dt + k_d,j Δφ̇_j) + T_gyro,j,
    T_gyro = ω × (J ω + h_x)   [+ ω × h with ``gyro_momentum="controller"``].

The seed writes T_gyro = ω × (Jω + H) with H the wheel momentum because its command is the wheel
torque −ḣ. Our actuator seam (``spacecraft.actuators``: ḣ_cmd = −u − ω × h) already adds ω × h,
so by default (``gyro_momentum="actuator"``) the law adds only ω × Jω plus ω × h_x for momentum
the actuator does not know (``extra_momentum``, e.g. the payload rotor's nominal spin momentum).
Gains (*reconstructed*: the paper only gives the bandwidth 0.02 Hz; with ξ = 0.707 its bandwidth
equals ω_n, seed §1.3): the closed loop J_jj s³ + k_d s² + k_p s + k_i = J_jj (s + r ω_n)
(s² + 2ξ ω_n s + ω_n²), ω_n = 2π·bandwidth, r = ``integral_ratio`` (default 0.1: the integral
pole a decade below ω_n), i.e. k_p = J_jj (1 + 2ξr) ω_n², k_i = J_jj r ω_n³,
k_d = J_jj (2ξ + r) ω_n (:func:`pid_gains`).

**Feed-forward** (the paper's eqs. (15), (19)), refreshed every Δt_p < Δt_c:

    T_comp,j(t) = −Ŵ_j sin(ω_p t + β̂_j),   T = T_c (held over Δt_c) + T_comp (held over Δt_p).

With ``hold_correction`` (default) the value held over [t_k, t_k + Δt_p] is
−Ŵ_j/sinc(ω_pΔt_p/2) · sin(ω_p(t_k + Δt_p/2) + β̂_j): the fundamental of a centred hold equals the
continuous sinusoid exactly (a plain hold would lag by Δt_p/2 — 2 % of the harmonic here; the
paper notes that delays are removed "by adjusting the phase angle"). The paper's design rule for
Δt_p (eq. (18)): the rate error caused by the hold, ≈ T_w Δt_p / J_jj, must stay below the
requirement.

**Identification** (the paper's §2: "identified on line by a Kalman filter, or injected from ground
analysis"; *reconstructed*). The residual is the disturbance torque recovered from the rate
increments between two PID samples t_{k−1}, t_k (Δ = t_k − t_{k−1}):

    d̄_k = J (ω_k − ω_{k−1})/Δ + ½ (g_{k−1} + g_k) − (1/Δ) ∫ u dt,   g = ω × (J ω + h_g),

the interval average of T_d in J ω̇ = −ω × (Jω + h_g) + u + T_d (h_g = h_x, plus h with
``gyro_momentum="controller"``; ∫u dt is exact: the controller integrates the torques it held).
It does not depend on the compensation being on or off. :class:`HarmonicIdentifier` fits, per
axis, d̄_k ≈ a·s̄_k + b·c̄_k + c with the *interval averages* s̄_k, c̄_k of sin ω_p t, cos ω_p t over
[t_{k−1}, t_k] (exact for a torque that is a sinusoid plus a constant) by recursive least squares
with exponential forgetting (equivalently a Kalman filter on (a, b, c) with a random-walk
parameter model); Ŵ = √(a² + b²), β̂ = atan2(b, a), since W sin(ωt + β) = W cos β sin ωt +
W sin β cos ωt. The constant c absorbs slow torques (gyroscopic, gravity gradient).

Modes: ``"identify"`` (identifier runs from the start, its estimate is applied from
``compensation_start`` on), ``"inject"`` (``injected = (W, β)`` applied from
``compensation_start``), ``"off"`` (PID only).

Sampling contract: call :meth:`SmallAnglePIDWithFeedforward.command` at least every Δt_p (the
simulator's ``control_period = dt_p``); the PID part and the identifier are refreshed at the
first call at or after each Δt_c grid instant t0 + kΔt_c, the feed-forward at each Δt_p grid
instant. Calls further apart than Δt_p raise ``ValueError``.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import (
    as_array,
    as_scalar,
    check_inertia_3x3,
    check_nonnegative,
    check_positive,
)
from ..charts import euler as _euler
from .adapters import ChartState, EulerChartAdapter
from .base import AttitudeController, AttitudeReference, AttitudeState, finite_command
from .kernel import ControllerKernel

__all__ = [
    "MODES",
    "GYRO_MOMENTUM",
    "pid_gains",
    "HarmonicIdentifier",
    "SmallAnglePIDLaw",
    "SmallAnglePIDWithFeedforward",
]

#: Compensation modes of :class:`SmallAnglePIDWithFeedforward`.
MODES = ("identify", "inject", "off")
#: Who compensates ω × h of the actuator momentum: the actuator seam or the controller.
GYRO_MOMENTUM = ("actuator", "controller")

# slack on the sample-grid index (t − t0)/period: times built as t0 + k·dt carry round-off
_GRID_EPS = 1e-6


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def _scalar(x: object, name: str) -> float:
    a = as_array(x, name)
    if a.ndim != 0:
        raise ValueError(f"{name}: expected a scalar, got shape {a.shape}")
    return float(a)


def pid_gains(
    J: object, bandwidth_hz: float = 0.02, zeta: float = 0.707, integral_ratio: float = 0.1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-axis PID gains ``(k_p, k_i, k_d)``, each ``(3,)``, placing the closed loop of axis j at
    J_jj (s + r ω_n)(s² + 2ξω_n s + ω_n²), ω_n = 2π·``bandwidth_hz`` (module docstring):

        k_p = J_jj (1 + 2ξr) ω_n²,   k_i = J_jj r ω_n³,   k_d = J_jj (2ξ + r) ω_n.

    ``integral_ratio`` r = 0 gives a PD (k_i = 0). Units: N·m/rad, N·m/(rad·s), N·m·s/rad.
    """
    Jm = check_inertia_3x3(J, "J")
    wn = 2.0 * math.pi * _scalar(check_positive(bandwidth_hz, "bandwidth_hz"), "bandwidth_hz")
    z = _scalar(check_positive(zeta, "zeta"), "zeta")
    r = _scalar(check_nonnegative(integral_ratio, "integral_ratio"), "integral_ratio")
    Jd = np.diag(Jm).copy()
    # k_i ∝ ω_n³: check before it overflows (Python's float ** raises OverflowError)
    scale = float(Jd.max()) * max(1.0, 2.0 * z + r, 1.0 + 2.0 * z * r)
    if not math.isfinite(scale * wn * wn * max(1.0, wn)):  # float * gives inf, never raises
        raise ValueError(
            f"bandwidth_hz: the gains (∝ ω_n³) overflow float64 (bandwidth_hz = "
            f"{wn / (2.0 * math.pi):.3g})"
        )
    return Jd * (1.0 + 2.0 * z * r) * wn**2, Jd * r * wn**3, Jd * (2.0 * z + r) * wn


# --------------------------------------------------------------------------- identifier


class HarmonicIdentifier:
    """On-line amplitude/phase identification of a known-frequency harmonic, per axis, by
    recursive least squares with exponential forgetting (module docstring).

    Model of the residual averaged over [t0, t1] (``B`` spacecraft × 3 axes, shared regressor):

        ȳ = a s̄ + b c̄ (+ c),  s̄ = ⟨sin ω t⟩, c̄ = ⟨cos ω t⟩ over [t0, t1]
        (point values when t1 = t0), W = √(a² + b²), β = atan2(b, a),

    so that the harmonic is W sin(ω t + β). RLS (Ljung & Söderström, *Theory and Practice of
    Recursive Identification*, 1983, §2.6; Åström & Wittenmark, *Adaptive Control*, §2.2):

        K = P φ / (λ + φᵀ P φ),  θ ← θ + K (ȳ − θᵀφ),  P ← (P − K φᵀ P)/λ.

    P is shared by every axis and spacecraft (the regressor depends on time only). It is kept
    symmetric; if it loses positive definiteness (round-off) it is reset to ``initial_covariance``
    · I, and its trace is capped at ``max_covariance`` · p (no wind-up without excitation).

    Args:
        frequency: ω [rad/s] (> 0).
        forgetting: λ ∈ (0, 1] (memory ≈ 1/(1 − λ) updates).
        include_bias: fit the constant c too (recommended: the residual has slow torques).
        initial_covariance: P₀ = p₀ I (> 0), in (residual units)²; large = weak prior.
        max_covariance: cap on trace(P)/p (> p₀).
        batch_size: ``B``.
    """

    def __init__(
        self,
        frequency: float,
        forgetting: float = 0.999,
        include_bias: bool = True,
        initial_covariance: float = 1.0e3,
        max_covariance: float = 1.0e6,
        batch_size: int = 1,
    ) -> None:
        self.frequency = _scalar(check_positive(frequency, "frequency"), "frequency")
        lam = _scalar(check_positive(forgetting, "forgetting"), "forgetting")
        if lam > 1.0:
            raise ValueError(f"forgetting: must lie in (0, 1], got {lam}")
        self.forgetting = lam
        self.include_bias = bool(include_bias)
        self.initial_covariance = _scalar(
            check_positive(initial_covariance, "initial_covariance"), "initial_covariance"
        )
        self.max_covariance = _scalar(
            check_positive(max_covariance, "max_covariance"), "max_covariance"
        )
        if self.max_covariance <= self.initial_covariance:
            raise ValueError("max_covariance: must exceed initial_covariance")
        self.n_params = 3 if self.include_bias else 2
        if batch_size is None:  # reset(None) keeps the current size: there is none yet
            raise ValueError("batch_size: expected a positive int, got None")
        self.reset(batch_size)

    def __repr__(self) -> str:
        return (
            f"HarmonicIdentifier(frequency={self.frequency!r}, forgetting={self.forgetting!r}, "
            f"include_bias={self.include_bias!r})"
        )

    def reset(self, batch_size: int | None = None) -> None:
        """Clear the estimate (θ = 0, P = P₀ I); optionally change the batch size."""
        if batch_size is not None:
            if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)):
                raise ValueError(f"batch_size: expected a positive int, got {batch_size!r}")
            if batch_size < 1:
                raise ValueError(f"batch_size: must be >= 1, got {batch_size}")
            if batch_size > 2**31:
                raise ValueError(f"batch_size: {batch_size} is larger than any feasible batch")
            self.batch_size = int(batch_size)
        p = self.n_params
        self._theta = np.zeros((self.batch_size, 3, p))
        self._P = self.initial_covariance * np.eye(p)
        self.n_updates = 0
        self.n_repairs = 0

    def regressor(self, t0: float, t1: float) -> np.ndarray:
        """φ ``(p,)``: interval averages of (sin ωt, cos ωt[, 1]) over [t0, t1] (t1 ≥ t0)."""
        t0 = _scalar(t0, "t0")
        t1 = _scalar(t1, "t1")
        if t1 < t0:
            raise ValueError(f"t1: must be >= t0 = {t0}, got {t1}")
        w = self.frequency
        span = w * (t1 - t0)
        if span < 1e-6:
            # point sample (a vanishing interval: the averages → the values at the midpoint)
            tm = 0.5 * (t0 + t1)
            s, c = math.sin(w * tm), math.cos(w * tm)
        else:
            s = (math.cos(w * t0) - math.cos(w * t1)) / span
            c = (math.sin(w * t1) - math.sin(w * t0)) / span
        return np.array((s, c, 1.0) if self.include_bias else (s, c))

    def update(self, t0: float, t1: float, residual: object) -> None:
        """One RLS step with the residual ``(B, 3)`` averaged over [t0, t1]."""
        y = as_array(residual, "residual", (3,))
        if y.shape != (self.batch_size, 3):
            raise ValueError(f"residual: expected shape ({self.batch_size}, 3), got {y.shape}")
        phi = self.regressor(t0, t1)
        P = self._P
        Pphi = P @ phi
        K = Pphi / (self.forgetting + phi @ Pphi)
        err = y - self._theta @ phi  # (B, 3)
        self._theta = self._theta + err[..., None] * K
        P = (P - np.outer(K, Pphi)) / self.forgetting
        P = 0.5 * (P + P.T)
        p = self.n_params
        if not np.all(np.isfinite(P)) or np.linalg.eigvalsh(P)[0] <= 0.0:
            P = self.initial_covariance * np.eye(p)
            self.n_repairs += 1
        tr = float(np.trace(P))
        if tr > self.max_covariance * p:
            P = P * (self.max_covariance * p / tr)
        self._P = P
        self.n_updates += 1

    @property
    def coefficients(self) -> np.ndarray:
        """θ ``(B, 3, p)``: (a, b[, c]) per spacecraft and axis (a copy)."""
        return self._theta.copy()

    @property
    def covariance(self) -> np.ndarray:
        """P ``(p, p)`` (a copy)."""
        return self._P.copy()

    @property
    def amplitude(self) -> np.ndarray:
        """Ŵ = √(a² + b²) ``(B, 3)``."""
        return np.hypot(self._theta[..., 0], self._theta[..., 1])

    @property
    def phase(self) -> np.ndarray:
        """β̂ = atan2(b, a) ``(B, 3)`` [rad] ∈ (−π, π]."""
        return np.arctan2(self._theta[..., 1], self._theta[..., 0])

    @property
    def bias(self) -> np.ndarray:
        """ĉ ``(B, 3)`` (zeros without ``include_bias``)."""
        if not self.include_bias:
            return np.zeros((self.batch_size, 3))
        return self._theta[..., 2].copy()

    def predict(self, t: float) -> np.ndarray:
        """The identified harmonic Ŵ sin(ω t + β̂) at ``t``, ``(B, 3)`` (without the bias)."""
        t = _scalar(t, "t")
        wt = self.frequency * t
        return self._theta[..., 0] * math.sin(wt) + self._theta[..., 1] * math.cos(wt)


# --------------------------------------------------------------------------- PID chart law


class SmallAnglePIDLaw:
    """The rotating-payload paper's PID of Euler small angles as a chart law for
    :class:`~liecontrol.control.adapters.EulerChartAdapter` (module docstring):

        T = −(k_p Δφ + k_i ∫Δφ dt + k_d Δφ̇) + ω × (J ω + h_g).

    Δφ_j = (y − y_d) of the angle about body axis j, Δφ̇_j = (ẏ − ẏ_d) likewise; the integral is
    the rectangle rule I_k = I_{k−1} + (t_k − t_{k−1}) Δφ_k (clamped to ±``integral_limit``
    if given). Every call is one PID sample.

    Args:
        J: the controller's inertia model ``(3, 3)`` [kg·m²].
        kp, ki, kd: per-axis gains ``(3,)`` (≥ 0), e.g. from :func:`pid_gains`.
        seq: the adapter's Tait–Bryan sequence (maps angles to axes).
        extra_momentum: h_x ``(3,)`` body momentum not handled by the actuator [N·m·s].
        gyro_momentum: ``"actuator"`` (ω × h added by the actuator seam, default) or
            ``"controller"`` (the law adds ω × h with h = ``ChartState.h``; None counts as 0).
        integral_limit: clamp of |∫Δφ_j dt| [rad·s] (> 0), or None.
    """

    batched = True

    def __init__(
        self,
        J: object,
        kp: object,
        ki: object,
        kd: object,
        seq: str = "XYZ",
        extra_momentum: object = None,
        gyro_momentum: str = "actuator",
        integral_limit: float | None = None,
    ) -> None:
        Jm = check_inertia_3x3(J, "J")
        self.J = Jm.copy()
        for name, g in (("kp", kp), ("ki", ki), ("kd", kd)):
            a = np.array(check_nonnegative(g, name), dtype=np.float64)
            if a.shape not in ((), (3,)):
                raise ValueError(f"{name}: expected a scalar or shape (3,), got {a.shape}")
            setattr(self, name, np.broadcast_to(a, (3,)).copy())
        if not _euler.is_tait_bryan(seq):
            raise ValueError(f"seq: small angles need a Tait–Bryan sequence (3 axes), got {seq!r}")
        self.seq = seq
        self.perm = np.array([seq.lower().index(c) for c in "xyz"])
        hx = np.zeros(3) if extra_momentum is None else as_array(extra_momentum, "extra_momentum")
        if hx.shape != (3,):
            raise ValueError(f"extra_momentum: expected shape (3,), got {hx.shape}")
        self.extra_momentum = hx.copy()
        if gyro_momentum not in GYRO_MOMENTUM:
            raise ValueError(
                f"gyro_momentum: expected one of {GYRO_MOMENTUM}, got {gyro_momentum!r}"
            )
        self.gyro_momentum = gyro_momentum
        if integral_limit is not None:
            integral_limit = _scalar(
                check_positive(integral_limit, "integral_limit"), "integral_limit"
            )
        self.integral_limit = integral_limit
        self._integral: np.ndarray | None = None
        self._t_last: float | None = None
        self._diag: dict[str, np.ndarray] = {}

    def __repr__(self) -> str:
        return (
            f"SmallAnglePIDLaw(kp={self.kp.tolist()}, ki={self.ki.tolist()}, "
            f"kd={self.kd.tolist()}, seq={self.seq!r})"
        )

    def reset(self, t0: float, batch_size: int) -> None:
        self._integral = np.zeros((int(batch_size), 3))
        self._t_last = None
        self._diag = {}

    def gyro_momentum_of(self, h: np.ndarray | None, B: int) -> np.ndarray:
        """h_g ``(B, 3)``: the momentum in the gyroscopic term (module docstring)."""
        hg = np.broadcast_to(self.extra_momentum, (B, 3))
        if self.gyro_momentum == "controller" and h is not None:
            hg = hg + h
        return hg

    def __call__(self, t: float, s: ChartState) -> np.ndarray:
        if self._integral is None:
            raise RuntimeError("SmallAnglePIDLaw: call reset(t0, batch_size) first")
        e = (s.y - s.y_d)[:, self.perm]
        e_dot = (s.y_dot - s.y_d_dot)[:, self.perm]
        dt = 0.0 if self._t_last is None else float(t) - self._t_last
        self._t_last = float(t)
        self._integral = self._integral + dt * e
        if self.integral_limit is not None:
            np.clip(self._integral, -self.integral_limit, self.integral_limit, out=self._integral)
        pid = -(self.kp * e + self.ki * self._integral + self.kd * e_dot)
        w = s.omega
        hg = self.gyro_momentum_of(s.h, w.shape[0])
        gyro = _cross(w, w @ self.J.T + hg)
        self._diag = {
            "att_error": e,
            "rate_error": e_dot,
            "integral": self._integral.copy(),
            "pid_torque": pid,
            "gyro_torque": gyro,
        }
        return pid + gyro

    def diagnostics(self) -> dict[str, np.ndarray]:
        """``att_error``, ``rate_error``, ``integral``, ``pid_torque``, ``gyro_torque``
        ``(B, 3)`` of the last sample."""
        return dict(self._diag)


# --------------------------------------------------------------------------- the controller


class SmallAnglePIDWithFeedforward(AttitudeController):
    """Composite controller of Wang, Chu, Zhang & Yuan (2016): Euler small-angle PID at Δt_c +
    payload feed-forward at Δt_p with on-line (or injected) amplitude/phase (module docstring).

    Args:
        J: controller inertia model ``(3, 3)`` [kg·m²].
        payload_frequency: ω_p of the compensated harmonic [rad/s] (> 0, ω_p Δt_c < π so the
            identifier's samples resolve it).
        bandwidth_hz, zeta, integral_ratio: PID design (:func:`pid_gains`); ignored if
            ``gains = (kp, ki, kd)`` is given.
        dt_c: PID (and identification) period Δt_c [s].
        dt_p: feed-forward period Δt_p [s]; Δt_c must be an integer multiple of it.
        mode: ``"identify"``, ``"inject"`` or ``"off"``.
        injected: ``(W, β)`` for ``"inject"``: amplitudes ``(3,)`` or ``(B, 3)`` [N·m] (≥ 0) and
            phases [rad]; the payload torque model is W_j sin(ω_p t + β_j).
        compensation_start: time the feed-forward is switched on [s].
        forgetting, include_bias, initial_covariance, max_covariance: :class:`HarmonicIdentifier`
            settings (``max_covariance`` ``None``: 1e6, or 1e3 × ``initial_covariance`` when that
            is larger, so any prior has room above it).
        seq, base, lock_tol: the :class:`EulerChartAdapter` (``base="reference"``: angles of the
            body relative to the reference, which for Wang et al. 2016 is the orbit frame).
        extra_momentum, gyro_momentum, integral_limit: :class:`SmallAnglePIDLaw` settings.
        hold_correction: centre the Δt_p hold and correct its sinc gain (module docstring).
    """

    batched = True

    def __init__(
        self,
        J: object,
        payload_frequency: float,
        bandwidth_hz: float = 0.02,
        zeta: float = 0.707,
        integral_ratio: float = 0.1,
        dt_c: float = 0.25,
        dt_p: float = 0.025,
        mode: str = "identify",
        injected: tuple[object, object] | None = None,
        compensation_start: float = 5500.0,
        forgetting: float = 0.999,
        include_bias: bool = True,
        initial_covariance: float = 1.0e3,
        max_covariance: float | None = None,
        seq: str = "XYZ",
        base: object = "reference",
        lock_tol: float = 1e-2,
        gains: tuple[object, object, object] | None = None,
        extra_momentum: object = None,
        gyro_momentum: str = "actuator",
        integral_limit: float | None = None,
        hold_correction: bool = True,
    ) -> None:
        Jm = check_inertia_3x3(J, "J")
        self.J = Jm.copy()
        self.omega_p = _scalar(
            check_positive(payload_frequency, "payload_frequency"), "payload_frequency"
        )
        self.dt_c = _scalar(check_positive(dt_c, "dt_c"), "dt_c")
        self.dt_p = _scalar(check_positive(dt_p, "dt_p"), "dt_p")
        ratio = self.dt_c / self.dt_p
        if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(
                f"dt_c: must be a positive integer multiple of dt_p = {self.dt_p} "
                f"(got ratio {ratio!r})"
            )
        if self.omega_p * self.dt_c >= math.pi:
            raise ValueError(
                f"payload_frequency: ω_p Δt_c = {self.omega_p * self.dt_c:.3g} ≥ π — the harmonic "
                "is above the Nyquist frequency of the PID/identification samples"
            )
        if mode not in MODES:
            raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
        self.mode = mode
        self.injected: tuple[np.ndarray, np.ndarray] | None = None
        if mode == "inject":
            if injected is None or not isinstance(injected, (tuple, list)) or len(injected) != 2:
                raise ValueError("injected: mode 'inject' needs injected = (W, beta)")
        if injected is not None:
            if not isinstance(injected, (tuple, list)) or len(injected) != 2:
                raise ValueError("injected: expected a pair (W, beta)")
            W = as_array(injected[0], "injected", (3,))
            beta = as_array(injected[1], "injected", (3,))
            if W.ndim > 2 or beta.ndim > 2:
                raise ValueError("injected: W and beta must have shape (3,) or (B, 3)")
            if np.any(W < 0):
                raise ValueError("injected: amplitudes W must be >= 0 (put the sign in beta)")
            self.injected = (W.copy(), beta.copy())
        self.compensation_start = _scalar(compensation_start, "compensation_start")
        if gains is None:
            kp, ki, kd = pid_gains(self.J, bandwidth_hz, zeta, integral_ratio)
        else:
            if not isinstance(gains, (tuple, list)) or len(gains) != 3:
                raise ValueError("gains: expected (kp, ki, kd)")
            kp, ki, kd = gains
        self.law = SmallAnglePIDLaw(
            self.J,
            kp,
            ki,
            kd,
            seq=seq,
            extra_momentum=extra_momentum,
            gyro_momentum=gyro_momentum,
            integral_limit=integral_limit,
        )
        self.adapter = EulerChartAdapter(self.law, seq=seq, base=base, lock_tol=lock_tol)
        self.identifier = HarmonicIdentifier(
            self.omega_p,
            forgetting=forgetting,
            include_bias=include_bias,
            initial_covariance=initial_covariance,
            max_covariance=_max_covariance(initial_covariance, max_covariance),
        )
        self.hold_correction = bool(hold_correction)
        x = 0.5 * self.omega_p * self.dt_p
        self._hold_gain = x / math.sin(x) if self.hold_correction else 1.0
        self._hold_shift = 0.5 * self.dt_p if self.hold_correction else 0.0
        self._B: int | None = None

    def __repr__(self) -> str:
        return (
            f"SmallAnglePIDWithFeedforward(omega_p={self.omega_p!r}, dt_c={self.dt_c!r}, "
            f"dt_p={self.dt_p!r}, mode={self.mode!r}, "
            f"compensation_start={self.compensation_start!r})"
        )

    @property
    def gains(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(k_p, k_i, k_d)`` per axis."""
        return self.law.kp.copy(), self.law.ki.copy(), self.law.kd.copy()

    def reset(self, t0: float, batch_size: int) -> None:
        self.adapter.reset(t0, batch_size)  # validates batch_size
        B = int(batch_size)
        if self.injected is not None:
            for a in self.injected:
                if a.ndim == 2 and a.shape[0] != B:
                    raise ValueError(f"injected: has {a.shape[0]} rows, the batch has {B}")
        self._B = B
        self._t0 = as_scalar(t0, "t0")
        self.identifier.reset(B)
        self._k_c = None  # index of the last PID sample
        self._k_p = None  # index of the last feed-forward refresh
        self._t_call: float | None = None
        self._u_last = np.zeros((B, 3))
        self._u_pid = np.zeros((B, 3))
        self._u_comp = np.zeros((B, 3))
        self._u_int = np.zeros((B, 3))  # ∫u dt since the last PID sample
        self._t_pid: float | None = None
        self._w_pid = np.zeros((B, 3))
        self._g_pid = np.zeros((B, 3))
        self._residual = np.full((B, 3), np.nan)
        self._diag: dict[str, np.ndarray] = {}

    def _amplitude_phase(self) -> tuple[np.ndarray, np.ndarray]:
        B = self._B
        if self.mode == "inject":
            W, beta = self.injected
            return np.broadcast_to(W, (B, 3)), np.broadcast_to(beta, (B, 3))
        if self.mode == "identify":
            return self.identifier.amplitude, self.identifier.phase
        return np.zeros((B, 3)), np.zeros((B, 3))

    def compensation_torque(self, t: float) -> np.ndarray:
        """T_comp held from ``t`` for Δt_p, ``(B, 3)`` (zero before ``compensation_start`` or in
        mode ``"off"``)."""
        if self._B is None:
            raise RuntimeError("SmallAnglePIDWithFeedforward: call reset(t0, batch_size) first")
        if self.mode == "off" or t < self.compensation_start:
            return np.zeros((self._B, 3))
        W, beta = self._amplitude_phase()
        arg = self.omega_p * (t + self._hold_shift) + beta
        return -self._hold_gain * W * np.sin(arg)

    def command(self, t: float, state: AttitudeState, reference: AttitudeReference) -> np.ndarray:
        """Body torque ``(B, 3)`` [N·m]: the held PID part + the feed-forward. ``state`` and
        ``reference`` are read (and validated) only at PID samples (module docstring)."""
        if self._B is None:
            raise RuntimeError("SmallAnglePIDWithFeedforward: call reset(t0, batch_size) first")
        t = _scalar(t, "t")
        if self._t_call is not None:
            gap = t - self._t_call
            if gap < 0.0:
                raise ValueError(f"t: {t} is before the previous call at {self._t_call}")
            if gap > self.dt_p * (1.0 + _GRID_EPS) + 1e-12:
                raise ValueError(
                    f"t: {gap:.6g} s since the previous call exceeds dt_p = {self.dt_p} "
                    "(sample the controller every dt_p: control_period = dt_p)"
                )
            self._u_int += self._u_last * gap
        k_c = math.floor((t - self._t0) / self.dt_c + _GRID_EPS)
        if k_c != self._k_c:
            self._k_c = k_c
            self._pid_sample(t, state, reference)
        k_p = math.floor((t - self._t0) / self.dt_p + _GRID_EPS)
        if k_p != self._k_p:
            self._k_p = k_p
            self._u_comp = self.compensation_torque(t)
        u = self._u_pid + self._u_comp
        self._u_last = u
        self._t_call = t
        return finite_command(u.copy(), state.omega)

    def _pid_sample(self, t: float, state: AttitudeState, reference: AttitudeReference) -> None:
        self._u_pid = self.adapter.command(t, state, reference)
        w = as_array(state.omega, "omega", (3,))
        h = None if state.h is None else as_array(state.h, "h", (3,))
        g = _cross(w, w @ self.J.T + self.law.gyro_momentum_of(h, w.shape[0]))
        if self.mode == "identify" and self._t_pid is not None and t > self._t_pid:
            span = t - self._t_pid
            d = (w - self._w_pid) @ self.J.T / span + 0.5 * (self._g_pid + g) - self._u_int / span
            self.identifier.update(self._t_pid, t, d)
            self._residual = d
        self._t_pid = t
        self._w_pid = w.copy()
        self._g_pid = g
        self._u_int = np.zeros_like(self._u_int)

    def fused_kernel(
        self, batch_size: int, control_period: float | None = None
    ) -> ControllerKernel | None:
        """The compiled law (:func:`liecontrol._kernels.payload_pid.payload_pid_ff_law`) for the
        simulator's fused loop (:mod:`liecontrol.control.kernel`): the PID, the identifier and
        the feed-forward with their memory carried per spacecraft. ``None`` (the Python loop
        runs, and the log line says why: :meth:`_kernel_reason`) for a base other than the
        reference frame, ``gyro_momentum="controller"`` (the seam's law does not see the
        actuator momentum), a control period longer than Δt_p (the Python loop refuses it) or a
        swapped law, adapter or identifier."""
        from .._kernels import payload_pid as K

        B = int(batch_size)
        law, ad, idf = self.law, self.adapter, self.identifier
        if (
            self._B != B
            or type(law) is not SmallAnglePIDLaw
            or type(ad) is not EulerChartAdapter
            or type(idf) is not HarmonicIdentifier
            or ad.law is not law
            or ad.base != "reference"
            or law.gyro_momentum != "actuator"
            or ad.chart.seq != law.seq
            or idf.batch_size != B
            or any(
                getattr(type(self), m) is not getattr(SmallAnglePIDWithFeedforward, m)
                for m in ("_pid_sample", "compensation_torque", "_amplitude_phase")
            )
        ):
            return None
        if control_period is not None and control_period > self.dt_p * (1.0 + _GRID_EPS) + 1e-12:
            return None
        i, j, k, ext = _euler.kernel_axes(law.seq)
        yd = ad._identity_coords(1)[0] + 0.0
        mode = {"identify": K.MODE_IDENTIFY, "inject": K.MODE_INJECT, "off": K.MODE_OFF}
        params = np.concatenate(
            [
                [self._t0, self.dt_c, self.dt_p, self.omega_p, self._hold_gain, self._hold_shift],
                [self.compensation_start, mode[self.mode], float(idf.n_params)],
                [idf.forgetting, idf.initial_covariance, idf.max_covariance],
                [-1.0 if law.integral_limit is None else law.integral_limit],
                [ad.chart.lock_tol, float(ad.unwrap), _euler.FROM_MATRIX_LOCK_TOL],
                law.J.ravel(), law.kp, law.ki, law.kd, law.extra_momentum,
                law.perm.astype(np.float64), yd, [float(i), float(j), float(k), float(ext)],
            ]
        )  # fmt: skip
        st = np.zeros((B, K.N_STATE))
        for flag, at, value in (
            (K.S_HKC, K.S_KC, self._k_c),
            (K.S_HKP, K.S_KP, self._k_p),
            (K.S_HTCALL, K.S_TCALL, self._t_call),
            (K.S_HTPID, K.S_TPID, self._t_pid),
            (K.S_HTLAST, K.S_TLAST, law._t_last),
        ):
            if value is not None:
                st[:, flag] = 1.0
                st[:, at] = float(value)
        if ad._y_d_prev is not None:
            st[:, K.S_HASYD] = 1.0
            st[:, K.S_YD : K.S_YD + 3] = ad._y_d_prev
        if np.all(np.isfinite(self._residual)):
            st[:, K.S_HRES] = 1.0
            st[:, K.S_RES : K.S_RES + 3] = self._residual
        for at, a in (
            (K.S_INT, law._integral), (K.S_ULAST, self._u_last), (K.S_UPID, self._u_pid),
            (K.S_UCOMP, self._u_comp), (K.S_UINT, self._u_int), (K.S_WPID, self._w_pid),
            (K.S_GPID, self._g_pid),
        ):  # fmt: skip
            st[:, at : at + 3] = a
        p = idf.n_params
        theta = np.zeros((B, 3, 3))
        theta[:, :, :p] = idf._theta
        st[:, K.S_THETA : K.S_THETA + 9] = theta.reshape(B, 9)
        P = np.zeros((3, 3))
        P[:p, :p] = idf._P
        st[:, K.S_P : K.S_P + 9] = P.ravel()
        st[:, K.S_NUPD] = idf.n_updates
        st[:, K.S_NREP] = idf.n_repairs
        if self.injected is not None:
            W, beta = self.injected
            st[:, K.S_W : K.S_W + 3] = W
            st[:, K.S_BETA : K.S_BETA + 3] = beta
        if ad._diag:
            d = ad._diag
            names = ("att_error", "rate_error", "integral", "pid_torque", "gyro_torque")
            for n, key in enumerate(names + ("chart_y", "chart_y_d")):
                st[:, K.S_DIAG + 3 * n : K.S_DIAG + 3 * n + 3] = d[key]
        if not np.all(np.isfinite(st)):
            return None
        return ControllerKernel(K.payload_pid_ff_law, params, st, K.N_DIAG, _pff_rows, self._finish)

    def _kernel_reason(self) -> str:
        return (
            "a base other than the reference frame, gyro_momentum='controller', a control "
            "period longer than dt_p, or a swapped law, adapter or identifier"
        )

    def _finish(self, state: np.ndarray, diag: np.ndarray) -> None:
        """The controller, its law, adapter and identifier as the Python loop leaves them."""
        from .._kernels import payload_pid as K

        law, ad, idf = self.law, self.adapter, self.identifier
        s0 = state[0]

        def opt(flag: int, at: int) -> float | None:
            return float(s0[at]) if s0[flag] != 0.0 else None

        kc, kp = opt(K.S_HKC, K.S_KC), opt(K.S_HKP, K.S_KP)
        self._k_c = None if kc is None else int(kc)
        self._k_p = None if kp is None else int(kp)
        self._t_call = opt(K.S_HTCALL, K.S_TCALL)
        self._t_pid = opt(K.S_HTPID, K.S_TPID)
        law._t_last = opt(K.S_HTLAST, K.S_TLAST)
        for name, at in (
            ("_u_last", K.S_ULAST), ("_u_pid", K.S_UPID), ("_u_comp", K.S_UCOMP),
            ("_u_int", K.S_UINT), ("_w_pid", K.S_WPID), ("_g_pid", K.S_GPID),
        ):  # fmt: skip
            setattr(self, name, state[:, at : at + 3].copy())
        law._integral = state[:, K.S_INT : K.S_INT + 3].copy()
        if s0[K.S_HRES] != 0.0:
            self._residual = state[:, K.S_RES : K.S_RES + 3].copy()
        if s0[K.S_HASYD] != 0.0:
            ad._y_d_prev = state[:, K.S_YD : K.S_YD + 3].copy()
        p = idf.n_params
        idf._theta = state[:, K.S_THETA : K.S_THETA + 9].reshape(-1, 3, 3)[:, :, :p].copy()
        idf._P = s0[K.S_P : K.S_P + 9].reshape(3, 3)[:p, :p].copy()
        idf.n_updates = int(s0[K.S_NUPD])
        idf.n_repairs = int(s0[K.S_NREP])
        rows = _pff_rows(diag)
        if s0[K.S_HKC] != 0.0:
            law_keys = ("att_error", "rate_error", "integral", "pid_torque", "gyro_torque")
            law._diag = {k: rows[k] for k in law_keys}
            ad._diag = {k: rows[k] for k in law_keys + ("chart_y", "chart_y_d", "chart_switched")}

    def diagnostics(self) -> dict[str, np.ndarray]:
        """The adapter/law diagnostics of the last PID sample (``att_error``, ``rate_error``,
        ``integral``, ``pid_torque``, ``gyro_torque``, ``chart_y``, ...) plus ``comp_torque``,
        ``W_hat``, ``beta_hat`` (the amplitude/phase in use or identified) and ``residual``
        (the last identification residual d̄, NaN before the first), all ``(B, 3)``."""
        if self._B is None:
            return {}
        d = dict(self.adapter.diagnostics())
        W, beta = self._amplitude_phase()
        d.update(
            {
                "comp_torque": self._u_comp.copy(),
                "W_hat": np.array(W),
                "beta_hat": np.array(beta),
                "residual": self._residual.copy(),
            }
        )
        return d


def _max_covariance(initial: object, given: object) -> object:
    """The identifier's trace cap: ``given``, else 1e6 or 1e3 × ``initial`` if larger (a
    non-number ``initial`` is passed on for the identifier to name)."""
    if given is not None:
        return given
    try:
        p0 = float(initial)
    except (TypeError, ValueError):
        return 1.0e6
    if not math.isfinite(p0) or p0 <= 0.0:
        return 1.0e6  # the identifier names initial_covariance
    cap = max(1.0e6, 1.0e3 * p0)
    if not math.isfinite(cap):
        cap = float(np.finfo(np.float64).max)
    if cap <= p0:
        raise ValueError(
            f"initial_covariance: {p0:g} leaves no room for the covariance cap above it "
            "(pass a smaller prior)"
        )
    return cap


def _pff_rows(rows: np.ndarray) -> dict[str, np.ndarray]:
    """:meth:`SmallAnglePIDWithFeedforward.diagnostics` from the kernel rows ``(..., 33)``."""
    names = ("att_error", "rate_error", "integral", "pid_torque", "gyro_torque", "chart_y",
             "chart_y_d")  # fmt: skip
    out = {k: rows[..., 3 * i : 3 * i + 3].copy() for i, k in enumerate(names)}
    out["chart_switched"] = np.zeros(rows.shape[:-1], dtype=bool)
    for i, k in enumerate(("comp_torque", "W_hat", "beta_hat", "residual")):
        out[k] = rows[..., 21 + 3 * i : 24 + 3 * i].copy()
    return out
