"""Actuator fault detection and isolation from residuals: a per-unit CUSUM on commanded vs
measured unit rates, with a stated false-alarm rate and detection delay.

**Residual.** For each unit ``i`` (a CMG gimbal, a wheel) the actuator electronics report the
commanded rate ``cᵢ`` (the gimbal rate the steering asked for, or a wheel's commanded torque
over its inertia) and the measured one ``yᵢ`` (gimbal-rate tachometer, wheel-speed derivative),
with measurement noise of standard deviation ``σ``. A healthy unit gives ``rᵢ = yᵢ − cᵢ ~
N(0, σ²)``; a loss of effectiveness ``e`` (:class:`spacecraft.faults.EfficiencyLoss`) gives
``yᵢ = e cᵢ``, i.e. a mean ``−(1 − e) cᵢ``; a bias ``b`` (:class:`~spacecraft.faults.
ActuatorBias`) a mean ``b``.

**Test** (Page's CUSUM on log-likelihood ratios; Basseville & Nikiforov, *Detection of Abrupt
Changes: Theory and Application*, Prentice Hall, 1993, ch. 2). Per unit and per hypothesis —
an effectiveness loss of at least ``Δ = min_loss`` (``y = (1 − Δ) c``) and, with ``min_bias``
``b``, a bias of ``±b`` — the increments are the exact Gaussian LLRs::

    s_loss = (−Δ cᵢ rᵢ − ½ Δ² cᵢ²) / σ²,     s_±b = (± b rᵢ − ½ b²) / σ²,
    gₖ = max(0, gₖ₋₁ + sₖ),  alarm when gₖ ≥ h.

The unit whose statistic crosses first is isolated (each residual depends on its own unit only,
so a fault does not move the other units' statistics in mean).

**False alarms.** Under no fault ``exp(Σ s)`` is a mean-one martingale for every command
sequence (each increment is an LLR of independent samples), so by Lorden's argument (Lorden,
"Procedures for reacting to a change in distribution", Ann. Math. Statist. 42(6), 1971) the mean
time to a false alarm of one statistic is at least ``e^h`` samples, whatever the commands; with
``n`` statistics (units × hypotheses) the alarm rate is at most ``n e^{−h}`` per sample.
``threshold`` defaults to ``h = ln(n · false_alarm_samples)``: at most one false alarm per
``false_alarm_samples`` samples and spacecraft (a bound; the measured rate is lower).

**Detection delay.** After a loss ``Δ_a`` with commands of mean square ``c̄²`` the loss statistic
drifts at ``E[s] = (Δ Δ_a − ½Δ²) c̄²/σ²`` per sample, so the mean delay is about ``h/E[s]``
samples plus the overshoot (Wald's approximation; :meth:`ResidualCusum.expected_delay`). The
delay grows as the commands shrink: a unit that is not commanded cannot be diagnosed (fine
pointing with tiny gimbal rates detects slowly — stated, not hidden). Assumptions: white
Gaussian measurement noise of known ``σ``, the commanded rate known exactly (no unmodelled
servo lag: with a lagging servo, compare against the servo model's output instead), faults
constant after onset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from liecontrol._validation import as_array, as_int, as_scalar

__all__ = ["ResidualCusum"]


def _positive(v: object, name: str) -> float:
    x = as_scalar(v, name)
    if not (x > 0.0 and math.isfinite(x)):
        raise ValueError(f"{name}: must be finite and > 0, got {v!r}")
    return x


@dataclass
class ResidualCusum:
    """Per-unit CUSUM fault detector on commanded vs measured unit rates (module docstring).

    Args:
        n_units: number of actuator units (4 for the SGCMG pyramid).
        noise_std: ``σ`` > 0, standard deviation of the measured unit rate [rad/s].
        min_loss: ``Δ`` ∈ (0, 1], the smallest effectiveness loss to detect (default 0.5; 0.7
            is the benchmark family's 30 % unit).
        min_bias: ``b`` > 0, the smallest rate bias to detect [rad/s], or ``None`` (no bias
            test).
        false_alarm_samples: at most one false alarm per this many samples and spacecraft
            (> 1; default 1e6); sets ``threshold`` when that is not given.
        threshold: ``h`` > 0, overriding ``false_alarm_samples``.

    Use: ``reset(B)``, then ``update(command, measured)`` once per sample with ``(B, n_units)``
    arrays; it returns the ``(B, n_units)`` alarm flags of this sample (latched: a unit stays
    flagged). ``alarm_sample`` ``(B, n_units)`` holds the first alarm sample (−1: none),
    ``alarm_hypothesis`` ``(B, n_units)`` which test raised it (0: the loss test, 1/2: the
    +/− bias tests; −1: none), ``statistic`` ``(B, n_units, n_hyp)`` the CUSUM values.
    """

    n_units: int
    noise_std: float
    min_loss: float = 0.5
    min_bias: float | None = None
    false_alarm_samples: float = 1.0e6
    threshold: float | None = None
    statistic: np.ndarray = field(init=False, repr=False)
    alarm_sample: np.ndarray = field(init=False, repr=False)
    alarm_hypothesis: np.ndarray = field(init=False, repr=False)
    _k: int = field(init=False, repr=False, default=0)

    def __post_init__(self) -> None:
        self.n_units = as_int(self.n_units, "n_units", 1)
        if self.n_units > 1024:
            raise ValueError(f"n_units: at most 1024 actuator units, got {self.n_units}")
        self.noise_std = _positive(self.noise_std, "noise_std")
        d = _positive(self.min_loss, "min_loss")
        if d > 1.0:
            raise ValueError(f"min_loss: must be in (0, 1], got {self.min_loss!r}")
        self.min_loss = d
        if self.min_bias is not None:
            self.min_bias = _positive(self.min_bias, "min_bias")
        n_stats = self.n_units * self.n_hypotheses
        if self.threshold is None:
            N = _positive(self.false_alarm_samples, "false_alarm_samples")
            if N <= 1.0:
                raise ValueError(f"false_alarm_samples: must be > 1, got {N!r}")
            self.false_alarm_samples = N
            self.threshold = math.log(n_stats * N)
        else:
            self.threshold = _positive(self.threshold, "threshold")
            self.false_alarm_samples = math.exp(self.threshold) / n_stats
        self.reset(1)

    @property
    def n_hypotheses(self) -> int:
        """Statistics per unit: the loss test, plus ±bias with ``min_bias``."""
        return 1 if self.min_bias is None else 3

    def reset(self, batch_size: int) -> None:
        """Zero the statistics for ``batch_size`` spacecraft."""
        B = as_int(batch_size, "batch_size", 1)
        if B * self.n_units > 100_000_000:
            raise ValueError(f"batch_size: {B} spacecraft × {self.n_units} units is too many")
        self.statistic = np.zeros((B, self.n_units, self.n_hypotheses))
        self.alarm_sample = np.full((B, self.n_units), -1, dtype=np.int64)
        self.alarm_hypothesis = np.full((B, self.n_units), -1, dtype=np.int64)
        self._k = 0

    def update(self, command: object, measured: object) -> np.ndarray:
        """Advance one sample with the commanded and measured unit rates ``(B, n_units)``;
        returns the latched alarm flags ``(B, n_units)``."""
        B, n = self.statistic.shape[:2]
        c = as_array(command, "command")
        y = as_array(measured, "measured")
        for name, a in (("command", c), ("measured", y)):
            if a.shape != (B, n):
                raise ValueError(f"{name}: expected shape {(B, n)}, got {a.shape}")
        r = y - c
        s2 = self.noise_std**2
        d = self.min_loss
        inc = [(-d * c * r - 0.5 * d * d * c * c) / s2]
        if self.min_bias is not None:
            b = self.min_bias
            inc += [(b * r - 0.5 * b * b) / s2, (-b * r - 0.5 * b * b) / s2]
        self.statistic = np.maximum(self.statistic + np.stack(inc, axis=-1), 0.0)
        crossed = (self.statistic >= self.threshold).any(axis=-1)
        new = crossed & (self.alarm_sample < 0)
        self.alarm_sample[new] = self._k
        # the test that crossed (the largest excess over the threshold)
        self.alarm_hypothesis[new] = np.argmax(self.statistic, axis=-1)[new]
        self._k += 1
        return self.alarm_sample >= 0

    def expected_delay(self, command_rms: float, loss: float | None = None) -> float:
        """Approximate mean detection delay [samples] of an effectiveness loss ``loss``
        (default ``min_loss``) under commands of RMS ``command_rms`` [rad/s]:
        ``h / E[s] + 1`` with ``E[s] = (Δ loss − ½Δ²) c̄²/σ²`` (``inf`` when the drift is not
        positive, e.g. a loss below ``Δ/2``)."""
        c = as_scalar(command_rms, "command_rms")
        if not c >= 0.0:
            raise ValueError(f"command_rms: must be >= 0, got {command_rms!r}")
        a = self.min_loss if loss is None else as_scalar(loss, "loss")
        if not 0.0 <= a <= 1.0:
            raise ValueError(f"loss: must be in [0, 1], got {loss!r}")
        drift = (self.min_loss * a - 0.5 * self.min_loss**2) * c * c / self.noise_std**2
        return math.inf if drift <= 0.0 else float(self.threshold) / drift + 1.0
