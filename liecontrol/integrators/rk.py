"""Explicit Runge–Kutta integrators: classical RK4 on ℝⁿ and RKMK4 on SO(3) × ℝⁿ.

RKMK4 (Runge–Kutta–Munthe-Kaas, order 4) integrates the mixed system

    Ṙ = R ω^,   ẋ = x_dot,     with (ω, x_dot) = f(t, R, x),  R ∈ SO(3), x ∈ ℝⁿ,

(ω the body angular velocity, right trivialisation, ``docs/design.md``) by writing
R(t) = R_k exp(θ(t)^) on one step and integrating the chart ODE in the Lie algebra

    θ̇ = J_r(θ)⁻¹ ω,    J_r(θ)⁻¹ = I + ½ θ^ + (1/θ² − cot(θ/2)/(2θ)) θ^²,

with the classical RK4 tableau (θ(t_k) = 0), then R_{k+1} = R_k exp(θ_{k+1}^). Because the
result is R_k times an exact matrix exponential, R stays on SO(3) to round-off whatever the
step.

dexp⁻¹ is **truncated**: J_r(θ)⁻¹ ω ≈ ω + ½ θ×ω + (1/12) θ×(θ×ω), i.e. the Bernoulli series
Σ_k (B_k/k!) ad_{−θ}^k ω cut after k = 2. Munthe-Kaas (1999) shows that truncating after
k = p − 2 keeps order p, because θ = O(h) in every stage; for p = 4 this needs no norm, no
trigonometry and no small-angle branch, so it is cheaper than ``so3.right_jacobian_inv`` on the
hot path and still 4th order (checked by ``tests/test_integrators.py``: error ratio ≈ 16 when
halving h). The exponential is Rodrigues' formula in half-angle form
(sin θ/θ = (sin(θ/2)/(θ/2))·cos(θ/2), (1 − cos θ)/θ² = ½ (sin(θ/2)/(θ/2))²), accurate at θ → 0
without a branch.

Sources: H. Munthe-Kaas, "High order Runge–Kutta methods on manifolds", Appl. Numer. Math. 29
(1999) 115–127; Iserles, Munthe-Kaas, Nørsett & Zanna, "Lie-group methods", Acta Numerica 9
(2000) §5.

The ``*_unchecked`` steps do no validation at all (the simulator's hot path); the public
:func:`rk4_step`, :func:`rkmk4_step` and :func:`integrate` validate their arguments and the
shapes/finiteness of what ``f`` returns.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._array_api import is_numpy, namespace, safe_sqrt
from .._kernels.so3 import dexpinv_rkmk4, exp_into
from .._validation import (
    as_array,
    check_output_finite,
    check_positive_scalar,
    check_rotation_matrix,
)

__all__ = [
    "rk4_step",
    "rk4_step_unchecked",
    "rkmk4_step",
    "rkmk4_step_unchecked",
    "integrate",
    "Trajectory",
    "RKMK4Field",
    "RK4Field",
]

#: f(t, R, x) -> (omega, x_dot): R (..., 3, 3), x (..., n) -> omega (..., 3), x_dot (..., n).
RKMK4Field = Callable[[float, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
#: f(t, y) -> y_dot: y (..., n) -> y_dot (..., n).
RK4Field = Callable[[float, np.ndarray], np.ndarray]

# hat(v).reshape(..., 9) == v @ _HAT9 (row-major 3×3 skew matrix as a linear map of v).
_HAT9 = np.zeros((3, 9))
_HAT9[2, 1], _HAT9[1, 2] = -1.0, 1.0
_HAT9[2, 3], _HAT9[0, 5] = 1.0, -1.0
_HAT9[1, 6], _HAT9[0, 7] = -1.0, 1.0
_HAT9.setflags(write=False)
# Below this half-angle sin(x)/x == 1 in double precision; clamping avoids 0/0 at θ = 0 exactly.
_TINY = 1e-300


def _exp(w: Any) -> Any:
    """Rodrigues exp of rotation vectors ``(..., 3) -> (..., 3, 3)``, branch-free (half angle);
    NumPy or JAX (pure).

    Component-wise: on (B,) slices this is ~2× faster than (B, 3, 3) broadcasting for B ~ 10³.
    θ/2 is a guarded norm (:func:`liecontrol._array_api.safe_sqrt`) so the derivative at θ = 0
    is finite; the floor ``_TINY`` only avoids 0/0 in the value.
    """
    xp = namespace(w)
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    a2 = x * x + y * y + z * z
    half = xp.maximum(safe_sqrt(a2, xp) * 0.5, _TINY)
    q = xp.sin(half) / half  # sin(θ/2)/(θ/2)
    a = q * xp.cos(half)  # sin θ/θ
    b = 0.5 * q * q  # (1 − cos θ)/θ²
    c = 1.0 - b * a2  # cos θ
    bx, by = b * x, b * y
    bxy, bxz, byz = bx * y, bx * z, by * z
    ax, ay, az = a * x, a * y, a * z
    return xp.stack(
        (
            xp.stack((c + bx * x, bxy - az, bxz + ay), axis=-1),
            xp.stack((bxy + az, c + by * y, byz - ax), axis=-1),
            xp.stack((bxz - ay, byz + ax, c + b * z * z), axis=-1),
        ),
        axis=-2,
    )


def _dexpinv(theta: Any, omega: Any) -> Any:
    """J_r(θ)⁻¹ ω truncated after the θ^² term: ω + ½ θ×ω + (1/12)(θ (θ·ω) − ω |θ|²); NumPy or
    JAX (pure)."""
    xp = namespace(theta, omega)
    t0, t1, t2 = theta[..., 0], theta[..., 1], theta[..., 2]
    w0, w1, w2 = omega[..., 0], omega[..., 1], omega[..., 2]
    tw = (t0 * w0 + t1 * w1 + t2 * w2) * (1.0 / 12.0)
    c = 1.0 - (t0 * t0 + t1 * t1 + t2 * t2) * (1.0 / 12.0)
    return xp.stack(
        (
            c * w0 + 0.5 * (t1 * w2 - t2 * w1) + t0 * tw,
            c * w1 + 0.5 * (t2 * w0 - t0 * w2) + t1 * tw,
            c * w2 + 0.5 * (t0 * w1 - t1 * w0) + t2 * tw,
        ),
        axis=-1,
    )


def _exp_f(w0: float, w1: float, w2: float) -> np.ndarray:
    """:func:`_exp` of one rotation vector given as floats (the compiled Rodrigues kernel)."""
    out = np.empty((3, 3))
    exp_into(w0, w1, w2, out)
    return out


def rk4_step_unchecked(f: RK4Field, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One classical RK4 step y_{k+1} = y_k + h/6 (k₁ + 2k₂ + 2k₃ + k₄), no validation."""
    h2 = 0.5 * h
    k1 = f(t, y)
    k2 = f(t + h2, y + h2 * k1)
    k3 = f(t + h2, y + h2 * k2)
    k4 = f(t + h, y + h * k3)
    return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def rkmk4_step_unchecked(
    f: RKMK4Field,
    t: float,
    R: np.ndarray,
    x: np.ndarray,
    h: float,
    *,
    stage_attitude: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """One RKMK4 step on SO(3) × ℝⁿ with no validation (hot path; see the module docstring).

    ``stage_attitude=False`` declares that ``f`` does not read its ``R`` argument (e.g. a plant
    without attitude-dependent torques): the stages then pass ``R=None`` instead of
    ``R e^θ``. The chart update (dexp⁻¹) needs only θ, so the result is bitwise the same and
    three of the four exponentials and 3×3 products per step are skipped (~12 % of a batched
    closed-loop step at B = 1000).

    Stages (classical RK4 tableau on the chart θ, θ₁ = 0):
    K₁ = ω(t, R, x); θ₂ = h/2 K₁; K₂ = dexp⁻¹_θ₂ ω(t + h/2, R e^θ₂, x + h/2 ẋ₁); θ₃ = h/2 K₂;
    K₃ = dexp⁻¹_θ₃ ω(t + h/2, R e^θ₃, x + h/2 ẋ₂); θ₄ = h K₃;
    K₄ = dexp⁻¹_θ₄ ω(t + h, R e^θ₄, x + h ẋ₃);
    R_{k+1} = R exp(h/6 (K₁ + 2K₂ + 2K₃ + K₄)), x_{k+1} = x + h/6 (ẋ₁ + 2ẋ₂ + 2ẋ₃ + ẋ₄).

    Pure for NumPy and JAX arrays alike (``f`` pure too): under ``jax.jit``/``vmap``/``grad``
    this is the same step; one NumPy body takes the equivalent Python-float route.
    """
    if R.size == 9 and is_numpy(namespace(R, x)):
        return _rkmk4_step_one(f, t, R, x, h, stage_attitude)
    h2 = 0.5 * h
    w1, d1 = f(t, R, x)
    th = h2 * w1
    w2, d2 = f(t + h2, R @ _exp(th) if stage_attitude else None, x + h2 * d1)
    k2 = _dexpinv(th, w2)
    th = h2 * k2
    w3, d3 = f(t + h2, R @ _exp(th) if stage_attitude else None, x + h2 * d2)
    k3 = _dexpinv(th, w3)
    th = h * k3
    w4, d4 = f(t + h, R @ _exp(th) if stage_attitude else None, x + h * d3)
    k4 = _dexpinv(th, w4)
    h6 = h / 6.0
    theta = (2.0 * (k2 + k3) + w1 + k4) * h6
    dx = (2.0 * (d2 + d3) + d1 + d4) * h6
    return R @ _exp(theta), x + dx


def _rkmk4_step_one(
    f: RKMK4Field,
    t: float,
    R: np.ndarray,
    x: np.ndarray,
    h: float,
    stage_attitude: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`rkmk4_step_unchecked` for a single body: the Lie-algebra arithmetic runs on Python
    floats, several times faster than numpy on 1-element arrays; same scheme, same result."""
    h2 = 0.5 * h
    w1, d1 = f(t, R, x)
    a0, a1, a2 = w1.ravel().tolist()
    u0, u1, u2 = h2 * a0, h2 * a1, h2 * a2
    w2, d2 = f(t + h2, R @ _exp_f(u0, u1, u2) if stage_attitude else None, x + h2 * d1)
    b0, b1, b2 = dexpinv_rkmk4(u0, u1, u2, *w2.ravel().tolist())
    u0, u1, u2 = h2 * b0, h2 * b1, h2 * b2
    w3, d3 = f(t + h2, R @ _exp_f(u0, u1, u2) if stage_attitude else None, x + h2 * d2)
    c0, c1, c2 = dexpinv_rkmk4(u0, u1, u2, *w3.ravel().tolist())
    u0, u1, u2 = h * c0, h * c1, h * c2
    w4, d4 = f(t + h, R @ _exp_f(u0, u1, u2) if stage_attitude else None, x + h * d3)
    e0, e1, e2 = dexpinv_rkmk4(u0, u1, u2, *w4.ravel().tolist())
    h6 = h / 6.0
    dx = d2 + d3
    dx *= 2.0
    dx += d1
    dx += d4
    dx *= h6
    R_next = R @ _exp_f(
        h6 * (a0 + 2.0 * (b0 + c0) + e0),
        h6 * (a1 + 2.0 * (b1 + c1) + e1),
        h6 * (a2 + 2.0 * (b2 + c2) + e2),
    )
    return R_next, x + dx


# ---------------------------------------------------------------------------------------------
# validated public wrappers


def _check_f(f: object) -> None:
    if not callable(f):
        raise ValueError(f"f: must be callable, got {type(f).__name__}")


def _check_t(t: object) -> float:
    a = as_array(t, "t")
    if a.ndim != 0:
        raise ValueError(f"t: must be a scalar, got shape {a.shape}")
    return float(a)


def _check_h(h: object) -> float:
    a = as_array(h, "h")
    if a.ndim != 0:
        raise ValueError(f"h: must be a scalar, got shape {a.shape}")
    return check_positive_scalar(a, "h")


def _check_state(R: object, x: object, rname: str = "R", xname: str = "x"):
    Ra = check_rotation_matrix(R, rname)
    xa = as_array(x, xname)
    if xa.ndim < 1 or xa.shape[:-1] != Ra.shape[:-2]:
        raise ValueError(
            f"{xname}: expected shape {Ra.shape[:-2] + ('n',)} matching the batch shape of "
            f"{rname} {Ra.shape}, got {xa.shape}"
        )
    return Ra, xa


def _checked_lie_field(
    f: Callable, batch: tuple[int, ...], n: int, dim: int = 3, name: str = "omega"
) -> Callable:
    """Wrap a field ``f(t, G, x) -> (velocity (batch, dim), x_dot (batch, n))`` so a wrong shape
    or a non-finite value in its output raises a ValueError (SO(3): ``omega``, dim 3; SE(3):
    ``xi``, dim 6 — shared with :mod:`.rkmk_se3`)."""

    def g(t: float, G: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = f(t, G, x)
        if not (isinstance(out, tuple) and len(out) == 2):
            raise ValueError(f"f: must return a tuple ({name}, x_dot)")
        w = np.asarray(out[0], dtype=np.float64)
        d = np.asarray(out[1], dtype=np.float64)
        if w.shape != batch + (dim,):
            raise ValueError(f"f: returned {name} of shape {w.shape}, expected {batch + (dim,)}")
        if d.shape != batch + (n,):
            raise ValueError(f"f: returned x_dot of shape {d.shape}, expected {batch + (n,)}")
        if not (np.isfinite(w).all() and np.isfinite(d).all()):
            raise ValueError(f"f: returned a non-finite value at t = {t!r}")
        return w, d

    return g


def _checked_rk4_field(f: RK4Field, shape: tuple[int, ...]) -> RK4Field:
    def g(t: float, y: np.ndarray) -> np.ndarray:
        d = np.asarray(f(t, y), dtype=np.float64)
        if d.shape != shape:
            raise ValueError(f"f: returned y_dot of shape {d.shape}, expected {shape}")
        if not np.isfinite(d).all():
            raise ValueError(f"f: returned a non-finite value at t = {t!r}")
        return d

    return g


def _step_naming_h(step: Callable, g: Callable, t: float, state: tuple, h: float) -> Any:
    """``step(g, t, *state, h)``; a non-finite value of ``f`` at a *later* stage (the first
    stage, at the given state, was finite) means the step itself left the float range: the
    error then names ``h`` instead of ``f``."""
    calls = [0]

    def counted(*args: Any) -> Any:
        calls[0] += 1
        return g(*args)

    try:
        return step(counted, t, *state, h)
    except ValueError as exc:
        if calls[0] > 1 and str(exc).startswith("f: returned a non-finite value"):
            raise ValueError(
                f"h: the step h = {h:g} takes the state out of the float range ({exc} inside "
                "the step; f was finite at the start): too large"
            ) from None
        raise


def rk4_step(f: RK4Field, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One classical RK4 step on ℝⁿ, batched: ``y`` is ``(..., n)``, ``f(t, y) -> (..., n)``.

    y_{k+1} = y_k + h/6 (k₁ + 2k₂ + 2k₃ + k₄) (Kutta 1901). Validates ``f``, ``t``, ``y``, ``h``
    and ``f``'s output; :func:`rk4_step_unchecked` is the same step without checks.
    """
    _check_f(f)
    t = _check_t(t)
    h = _check_h(h)
    y = as_array(y, "y")
    if y.ndim < 1:
        raise ValueError(f"y: expected shape (..., n), got {y.shape}")
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is named just below
        y1 = _step_naming_h(rk4_step_unchecked, _checked_rk4_field(f, y.shape), t, (y,), h)
    return check_output_finite(y1, "h", "the step")


def rkmk4_step(
    f: RKMK4Field, t: float, R: np.ndarray, x: np.ndarray, h: float
) -> tuple[np.ndarray, np.ndarray]:
    """One RKMK4 step on SO(3) × ℝⁿ (order 4), returning ``(R_next, x_next)``.

    ``R``: ``(..., 3, 3)`` rotations (body → inertial), ``x``: ``(..., n)`` with the same batch
    shape (n may be 0), ``f(t, R, x) -> (omega, x_dot)`` with Ṙ = R ω^. Validates everything
    (including ``f``'s output); the simulator should call :func:`rkmk4_step_unchecked`.
    See the module docstring for the scheme and its sources.
    """
    _check_f(f)
    t = _check_t(t)
    h = _check_h(h)
    R, x = _check_state(R, x)
    g = _checked_lie_field(f, R.shape[:-2], x.shape[-1])
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is named just below
        R1, x1 = _step_naming_h(rkmk4_step_unchecked, g, t, (R, x), h)
    check_output_finite(R1, "h", "the step")
    return R1, check_output_finite(x1, "h", "the step")


@dataclass(frozen=True)
class Trajectory:
    """Sampled solution of :func:`integrate`.

    Attributes:
        t: ``(K,)`` sample times.
        R: ``(K, ..., 3, 3)`` attitudes.
        x: ``(K, ..., n)`` Euclidean states.
    """

    t: np.ndarray
    R: np.ndarray
    x: np.ndarray

    def __post_init__(self) -> None:
        t, R, x = _check_record(self.t, self.R, self.x, "R", (3, 3))
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "x", x)


def _check_record(
    t: object, G: object, x: object, gname: str, tail: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A trajectory record's arrays: finite, ``t (K,)`` with ``K >= 1``, ``G (K, ..., *tail)``
    and ``x (K, ...)`` (the group part is checked for shape only: the ``"rk4"`` method does not
    stay exactly on the group)."""
    t = as_array(t, "t")
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t: expected shape (K,) with K >= 1, got {t.shape}")
    G = as_array(G, gname, tail)
    x = as_array(x, "x")
    for name, a in ((gname, G), ("x", x)):
        if a.ndim < 1 or a.shape[0] != t.shape[0]:
            raise ValueError(f"{name}: expected {t.shape[0]} samples like t, got shape {a.shape}")
    if G.ndim < len(tail) + 1:
        raise ValueError(f"{gname}: expected shape (K, ..., {tail[0]}, {tail[1]}), got {G.shape}")
    return t, G, x


_METHODS = ("rkmk4", "rk4")


def integrate(
    f: RKMK4Field,
    t0: float,
    R0: np.ndarray,
    x0: np.ndarray,
    h: float,
    n_steps: int,
    method: str = "rkmk4",
    *,
    save_every: int = 1,
) -> Trajectory:
    """Integrate Ṙ = R ω^, ẋ = x_dot from (t0, R0, x0) with ``n_steps`` fixed steps of size h.

    ``method``: ``"rkmk4"`` (Lie-group RKMK4, R stays on SO(3)) or ``"rk4"`` (classical RK4 on
    the 9 entries of R and on x in the embedding ℝ⁹ × ℝⁿ: R drifts off SO(3); kept as the
    textbook baseline the geometric integrators are compared with).
    Samples every ``save_every`` steps (the initial and, if n_steps is a multiple, final state
    included). Raises ``FloatingPointError`` if the state becomes non-finite.
    """
    _check_f(f)
    t0 = _check_t(t0)
    h = _check_h(h)
    R0, x0 = _check_state(R0, x0, "R0", "x0")
    if method not in _METHODS:
        raise ValueError(f"method: must be one of {_METHODS}, got {method!r}")
    n_steps = _check_count(n_steps, "n_steps", minimum=0)
    save_every = _check_count(save_every, "save_every", minimum=1)
    batch, n = R0.shape[:-2], x0.shape[-1]
    # validate f's output once at t0; the loop then runs the unchecked step
    _checked_lie_field(f, batch, n)(t0, R0, x0)

    K = n_steps // save_every + 1
    ts = np.empty(K)
    Rs = np.empty((K,) + R0.shape)
    xs = np.empty((K,) + x0.shape)
    ts[0], Rs[0], xs[0] = t0, R0, x0
    R, x = R0, x0
    if method == "rk4":

        def fe(t: float, y: np.ndarray) -> np.ndarray:
            Ry = y[..., :9].reshape(batch + (3, 3))
            w, d = f(t, Ry, y[..., 9:])
            out = np.empty(y.shape)
            out[..., :9] = (Ry @ (w @ _HAT9).reshape(batch + (3, 3))).reshape(batch + (9,))
            out[..., 9:] = d
            return out

        y = np.concatenate((R0.reshape(batch + (9,)), x0), axis=-1)
    j = 1
    for k in range(1, n_steps + 1):
        t = t0 + (k - 1) * h
        if method == "rkmk4":
            R, x = rkmk4_step_unchecked(f, t, R, x, h)
            finite = np.isfinite(R).all() and np.isfinite(x).all()
        else:
            y = rk4_step_unchecked(fe, t, y, h)
            finite = np.isfinite(y).all()
        if not finite:
            raise FloatingPointError(f"integrate: non-finite state at t = {t0 + k * h!r}")
        if k % save_every == 0:
            ts[j] = t0 + k * h
            if method == "rkmk4":
                Rs[j], xs[j] = R, x
            else:
                Rs[j] = y[..., :9].reshape(batch + (3, 3))
                xs[j] = y[..., 9:]
            j += 1
    return Trajectory(ts, Rs, xs)


def _check_count(k: object, name: str, minimum: int) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
        raise ValueError(f"{name}: must be an integer, got {k!r}")
    if k < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {k}")
    return int(k)
