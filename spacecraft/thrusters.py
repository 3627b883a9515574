"""Momentum unloading with thrusters: a thruster layout, pulse-width pulse-frequency (PWPF)
modulation, a minimum impulse bit, and the propellant used — momentum management that works at
any inclination (magnetorquers do not: :func:`spacecraft.momentum.magnetic_dumping_feasibility`).

**Layout.** Thruster ``j`` at body position ``r_j`` [m] firing along the unit direction
``d_j`` (the exhaust leaves along ``−d_j``) with thrust ``F_j`` [N] gives the body torque
``t_j = F_j r_j × d_j``; the columns ``t_j`` form ``T`` (3 × n). Every signed body axis ``±e_a``
must lie in the cone of the ``t_j`` (a non-negative combination): checked with non-negative
least squares when the layout is built, otherwise ``ValueError`` naming ``positions``. For each
signed axis, all thrusters whose torque lies along it fire together (a couple: no net force), or,
where none does, those of the non-negative combination: the *pulse torque* ``τ_a±`` of the axis
(cross-axis torque of an imperfect layout included).
:meth:`ThrusterLayout.pairs` builds the usual six couples (two thrusters per signed axis).

**Unloading law.** The stored actuator momentum ``h`` (body axes) is driven to ``h_target`` by
the external torque ``τ_des = −k (h − h_target)`` (the attitude loop holds the attitude, so the
actuator absorbs what the thrusters apply, ``ḣ ≈ τ_d + τ_thr``; sign as for
:class:`spacecraft.momentum.CrossProductDumping`). Per body axis a PWPF modulator (Wie, *Space
Vehicle Dynamics and Control*, 2nd ed., AIAA 2008, §7.5) turns the normalised demand
``u_a = τ_des,a / |τ_a±|`` into on/off pulses: a first-order filter of the demand minus the
modulator's own output ``y ∈ {−1, 0, 1}``, ``ḟ = (K_m (u − y) − f)/τ_m`` (the feedback makes the
pulses short and the duty cycle ≈ ``|u|``; without it the trigger would hold a thruster on until
the demand itself fell below ``U_off/K_m``), and a Schmitt trigger (on at ``|f| ≥ U_on``, off at
``|f| ≤ U_off``); once on, a thruster stays
on for at least ``min_on_time`` (the minimum impulse bit ``F·t_min``). The valve command is
sampled at the plant's integration steps (held over each step), so ``min_on_time`` must be at
least one step and the pulses are whole steps. A ``deadband`` on ``‖h − h_target‖`` stops the
unloading once the momentum is low (a small residual is left on purpose; thrusters are for
momentum *unloading*, not fine control).

**Propellant.** ``ṁ = Σ_on F_j / (I_sp g₀)`` integrated over the firing steps, logged per
spacecraft as ``propellant_kg``.

The object keeps the modulator state between calls (per spacecraft, by time): a run restarts it
when time goes back (a new run from ``t0``) or the batch size changes. Assumptions: thrusters
produce torque only about the centre of mass as laid out (the net force — a translation — is
ignored here; couples cancel it), the thrust is constant while on, the valve timing is the
integration step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import nnls

from liecontrol._validation import as_array, as_scalar

__all__ = ["ThrusterLayout", "ThrusterUnloading", "G0"]

#: Standard gravity [m/s²] (the I_sp convention).
G0 = 9.80665


def _pos(v: object, name: str) -> float:
    x = as_scalar(v, name)
    if not (x > 0.0 and math.isfinite(x)):
        raise ValueError(f"{name}: must be finite and > 0, got {v!r}")
    return x


@dataclass(frozen=True)
class ThrusterLayout:
    """Thruster geometry (module docstring).

    Args:
        positions: ``(n, 3)`` body positions about the centre of mass [m].
        directions: ``(n, 3)`` thrust directions (normalised here).
        thrust: ``F`` [N], scalar or ``(n,)``.
        isp: specific impulse [s] (> 0).
    """

    positions: np.ndarray
    directions: np.ndarray
    thrust: float | np.ndarray = 1.0
    isp: float = 220.0
    torque_matrix: np.ndarray = field(init=False, repr=False)
    axis_sets: np.ndarray = field(init=False, repr=False)
    axis_torques: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        P = as_array(self.positions, "positions")
        D = as_array(self.directions, "directions")
        if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 1 or P.shape[0] > 256:
            raise ValueError(f"positions: expected shape (n, 3) with 1 <= n <= 256, got {P.shape}")
        if D.shape != P.shape:
            raise ValueError(f"directions: expected shape {P.shape}, got {D.shape}")
        dn = np.linalg.norm(D, axis=1)
        if np.any(dn <= 1e-12):
            raise ValueError("directions: every thrust direction must be non-zero")
        D = D / dn[:, None]
        F = as_array(self.thrust, "thrust")
        F = np.broadcast_to(F, (P.shape[0],)) if F.ndim == 0 else F
        if F.shape != (P.shape[0],) or not np.all(F > 0.0):
            raise ValueError(f"thrust: expected > 0, scalar or shape ({P.shape[0]},)")
        isp = _pos(self.isp, "isp")
        T = (np.cross(P, D) * F[:, None]).T  # (3, n)
        scale = float(np.abs(T).max()) if T.size else 0.0
        sets = np.zeros((6, P.shape[0]))
        torques = np.zeros((6, 3))
        for a in range(3):
            for k, sgn in enumerate((1.0, -1.0)):
                e = np.zeros(3)
                e[a] = sgn
                coef, res = nnls(T, e * scale) if scale > 0.0 else (np.zeros(P.shape[0]), 1.0)
                if scale == 0.0 or res > 1e-6 * scale or coef.max() <= 0.0:
                    axis = ("+" if sgn > 0 else "-") + "xyz"[a]
                    raise ValueError(
                        f"positions: the layout has no torque authority about {axis} (no "
                        "non-negative thruster combination gives it; check positions and "
                        "directions)"
                    )
                tn = np.linalg.norm(T, axis=0)
                aligned = (e @ T) > (1.0 - 1e-9) * np.maximum(tn, 1e-300)
                if aligned.any():
                    on = aligned.astype(np.float64)  # every thruster torquing along ±e_a (couples)
                else:  # fire the non-negative combination's thrusters fully
                    on = np.where(coef / coef.max() > 1e-9, 1.0, 0.0)
                sets[2 * a + k] = on
                torques[2 * a + k] = T @ on
        for name, v in (("positions", P), ("directions", D), ("thrust", F.astype(np.float64))):
            v = np.array(v, dtype=np.float64)
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        object.__setattr__(self, "isp", isp)
        for name, v in (("torque_matrix", T), ("axis_sets", sets), ("axis_torques", torques)):
            v.setflags(write=False)
            object.__setattr__(self, name, v)

    @classmethod
    def pairs(cls, arm: float, thrust: float = 1.0, isp: float = 220.0) -> ThrusterLayout:
        """Six couples, two thrusters per signed body axis at ``±arm`` [m] from the centre of
        mass (12 thrusters; each couple gives ``2 F arm`` about its axis and no net force)."""
        L = _pos(arm, "arm")
        P, D = [], []
        for a in range(3):
            b, c = (a + 1) % 3, (a + 2) % 3
            for sgn in (1.0, -1.0):
                # torque sgn·e_a from r = ±L e_b, d = ±sgn e_c  (e_b × e_c = e_a)
                for s2 in (1.0, -1.0):
                    r = np.zeros(3)
                    d = np.zeros(3)
                    r[b] = s2 * L
                    d[c] = s2 * sgn
                    P.append(r)
                    D.append(d)
        return cls(np.array(P), np.array(D), thrust, isp)

    @property
    def n(self) -> int:
        return int(self.positions.shape[0])


@dataclass
class ThrusterUnloading:
    """Thruster momentum unloading as the plant's ``momentum_management`` (module docstring):
    ``dipole(t, R, h)`` returns the thruster torque held over the step from ``t`` (body axes),
    ``torque(t, R, m)`` returns it as the external torque.

    Args:
        layout: the :class:`ThrusterLayout`.
        gain: ``k`` [1/s] of ``τ_des = −k (h − h_target)`` (> 0).
        min_on_time: minimum valve on-time [s] (> 0; the minimum impulse bit is ``F·t_min``).
        pulse_period: the PWPF design pulse period [s]; must be ≥ ``min_on_time`` (a minimum
            impulse bit longer than the pulse is an input error); default 10 × ``min_on_time``.
        deadband: stop unloading below ``‖h − h_target‖`` [N·m·s] (≥ 0).
        h_target: target stored momentum ``(3,)`` [N·m·s].
        k_m, u_on, u_off: PWPF filter gain and Schmitt thresholds (``0 < u_off < u_on``);
            the filter time constant is ``pulse_period / 2``.
    """

    layout: ThrusterLayout
    gain: float = 1e-3
    min_on_time: float = 0.1
    pulse_period: float | None = None
    deadband: float = 0.0
    h_target: np.ndarray | None = None
    k_m: float = 4.5
    u_on: float = 0.45
    u_off: float = 0.15
    _state: dict = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.layout, ThrusterLayout):
            raise ValueError(f"layout: expected a ThrusterLayout, got {type(self.layout).__name__}")
        self.gain = _pos(self.gain, "gain")
        self.min_on_time = _pos(self.min_on_time, "min_on_time")
        pp = 10.0 * self.min_on_time if self.pulse_period is None else self.pulse_period
        self.pulse_period = _pos(pp, "pulse_period")
        if self.min_on_time > self.pulse_period:
            raise ValueError(
                f"min_on_time: the minimum impulse bit's on-time {self.min_on_time:g} s exceeds "
                f"the pulse period {self.pulse_period:g} s"
            )
        db = as_scalar(self.deadband, "deadband")
        if not db >= 0.0:
            raise ValueError(f"deadband: must be >= 0, got {self.deadband!r}")
        self.deadband = db
        ht = np.zeros(3) if self.h_target is None else as_array(self.h_target, "h_target")
        if ht.shape != (3,):
            raise ValueError(f"h_target: expected shape (3,), got {ht.shape}")
        self.h_target = ht
        self.k_m = _pos(self.k_m, "k_m")
        self.u_on = _pos(self.u_on, "u_on")
        self.u_off = _pos(self.u_off, "u_off")
        if not self.u_off < self.u_on:
            raise ValueError(f"u_off: must be < u_on = {self.u_on:g}, got {self.u_off:g}")

    def _fresh(self, B: int, t: float) -> dict:
        return {
            "t": t, "B": B, "f": np.zeros((B, 3)), "on": np.zeros((B, 3)),
            "on_since": np.full((B, 3), -np.inf), "tau": np.zeros((B, 3)),
            "firing": np.zeros((B, self.layout.n), dtype=bool), "propellant": np.zeros(B),
        }  # fmt: skip

    def dipole(self, t: float, R: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The thruster torque ``(B, 3)`` [N·m] held from ``t`` (advances the modulator once per
        new ``t``; a repeated ``t`` returns the same command)."""
        h = np.asarray(h, dtype=np.float64)
        B = h.shape[0]
        t = float(t)
        st = self._state
        if not st or st["B"] != B or (st["t"] is not None and t < st["t"]):
            st = self._state = self._fresh(B, t)
            st["t"] = None
        elif t == st["t"]:
            return st["tau"].copy()
        dt = 0.0 if st["t"] is None else t - st["t"]
        # propellant of the firing held over the previous step
        F = self.layout.thrust
        st["propellant"] = st["propellant"] + dt * (st["firing"] * F).sum(axis=1) / (
            self.layout.isp * G0
        )
        dh = h - self.h_target
        active = np.linalg.norm(dh, axis=1) > self.deadband
        tau_des = np.where(active[:, None], -self.gain * dh, 0.0)
        pos = self.layout.axis_torques[0::2, [0, 1, 2]].diagonal()  # τ_a+ along a
        neg = -self.layout.axis_torques[1::2, [0, 1, 2]].diagonal()  # |τ_a−| along a
        u = np.where(tau_des >= 0.0, tau_des / pos, tau_des / neg)
        tau_m = 0.5 * self.pulse_period
        a = math.exp(-dt / tau_m) if dt > 0.0 else 1.0
        # the output held over the previous step is fed back (Wie's PWPF)
        st["f"] = a * st["f"] + (1.0 - a) * self.k_m * (u - st["on"])
        f = st["f"]
        on = st["on"]
        held_min = (t - st["on_since"]) < self.min_on_time - 1e-12
        turn_on = (on == 0.0) & (np.abs(f) >= self.u_on)
        # off once f falls to U_off in the firing direction (with the output fed back f swings
        # past zero while a minimum on-time holds the valve open)
        turn_off = (on != 0.0) & (on * f <= self.u_off) & ~held_min
        new_on = np.where(turn_on, np.sign(f), np.where(turn_off, 0.0, on))
        st["on_since"] = np.where(turn_on, t, st["on_since"])
        st["on"] = new_on
        # fire the signed-axis thruster sets
        sets = self.layout.axis_sets
        firing = np.zeros((B, self.layout.n), dtype=bool)
        for ax in range(3):
            firing |= (new_on[:, ax] > 0)[:, None] & (sets[2 * ax] > 0)[None, :]
            firing |= (new_on[:, ax] < 0)[:, None] & (sets[2 * ax + 1] > 0)[None, :]
        st["firing"] = firing
        st["tau"] = firing.astype(np.float64) @ self.layout.torque_matrix.T
        st["t"] = t
        return st["tau"].copy()

    def torque(self, t: float, R: np.ndarray, m: np.ndarray) -> np.ndarray:
        """The held thruster torque as the external body torque ``(B, 3)`` [N·m]."""
        return np.asarray(m, dtype=np.float64)

    @property
    def propellant_kg(self) -> np.ndarray:
        """Propellant used so far per spacecraft ``(B,)`` [kg] (up to the last command)."""
        st = self._state
        return np.zeros(0) if not st else st["propellant"].copy()

    def log(self, t: float, R: np.ndarray, h: np.ndarray) -> dict[str, np.ndarray]:
        """Per-sample log: ``thruster_torque`` ``(B, 3)``, ``thrusters_on`` ``(B, n)``,
        ``propellant_kg`` ``(B,)``."""
        tau = self.dipole(t, R, h)
        return {
            "thruster_torque": tau,
            "thrusters_on": self._state["firing"].copy(),
            "propellant_kg": self._state["propellant"].copy(),
        }
