"""Compiled kernels of the plant: rigid body, SGCMG pyramid and ideal torque actuators, the
regularised-inverse steering laws, time-only disturbances and the RKMK4 step — the one
implementation of each per-step formula (the numpy methods of the classes are the batched
reference and the fallback without a compiler; the tests hold the two to 1e-12).

Codes shared with :mod:`spacecraft._fused`:

- actuator: ``ACT_IDEAL`` (held = torque (3,), optional per-axis clip), ``ACT_SGCMG`` (state δ
  (4,), held = δ̇ (4,), ideal gimbal servo);
- steering: ``STEER_PINV``, ``STEER_SR``, ``STEER_GSR`` (params λ₀, μ, ε, ε₀, ω_ε, φ₁..₃),
  ``STEER_PINV_NULL`` (params k, ε, floor of m, then the cluster's unit momenta) and
  ``STEER_KERNEL``: a user's law through the seam :mod:`spacecraft.steering_kernel` (its
  parameters, and the law itself as a first-class function ``steer_fn``);
- disturbance: ``DIST_NONE``, ``DIST_CONSTANT`` (params T (3,)), ``DIST_CONSTANT_HARMONIC``
  (params n, scale) — time-only, no pointer call — and ``DIST_KERNEL``: a torque of the public
  seam :mod:`spacecraft.disturbance_kernel` called through a function pointer ``dfn`` with the
  spacecraft's parameter row ``dpk`` and, when ``datt``, the stage attitude R exp(θ_s).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from liecontrol._jit import njit
from liecontrol._kernels.so3 import dexpinv_rkmk4, right_multiply_exp_into

ACT_IDEAL = 0
ACT_SGCMG = 1
STEER_PINV = 0
STEER_SR = 1
STEER_GSR = 2
STEER_PINV_NULL = 3
STEER_KERNEL = 4
DIST_NONE = 0
DIST_CONSTANT = 1
DIST_CONSTANT_HARMONIC = 2
DIST_KERNEL = 3

#: relative trust threshold of the cofactor determinant (as spacecraft.steering)
_DET_REL_TRUST = 1e-10


@njit(inline="always")
def disturbance_at(kind: int, p: np.ndarray, t: float) -> tuple[float, float, float]:
    """A time-only external torque: none, constant ``p[:3]``, or the constant + harmonic torque
    of Wu, Huang, Wei & Guo (orbit rate ``p[0]``, scale ``p[1]``)."""
    if kind == DIST_CONSTANT:
        return p[0], p[1], p[2]
    if kind == DIST_CONSTANT_HARMONIC:
        s1 = math.sin(p[0] * t)
        s2 = math.sin(2.0 * p[0] * t)
        c = p[1]
        a = c * (0.02 + 0.02 * s1 + 0.01 * s2)
        return a, c * (0.08 + 0.04 * s1 + 0.01 * s2), a
    return 0.0, 0.0, 0.0


@njit(inline="always")
def rigid_acceleration(
    J: np.ndarray, Jinv: np.ndarray, w0: float, w1: float, w2: float,
    t0: float, t1: float, t2: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Euler's equation ω̇ = J⁻¹(τ − ω × Jω)."""
    j0 = J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2
    j1 = J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2
    j2 = J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2
    r0 = t0 - (w1 * j2 - w2 * j1)
    r1 = t1 - (w2 * j0 - w0 * j2)
    r2 = t2 - (w0 * j1 - w1 * j0)
    return (
        Jinv[0, 0] * r0 + Jinv[0, 1] * r1 + Jinv[0, 2] * r2,
        Jinv[1, 0] * r0 + Jinv[1, 1] * r1 + Jinv[1, 2] * r2,
        Jinv[2, 0] * r0 + Jinv[2, 1] * r1 + Jinv[2, 2] * r2,
    )


@njit(inline="always")
def cmg_momentum_jacobian(
    S0: np.ndarray,
    C0: np.ndarray,
    delta: np.ndarray,
    A_out: np.ndarray,
    sn: np.ndarray,
    cs: np.ndarray,
) -> tuple[float, float, float]:
    """Cluster momentum h(δ) = Σᵢ (S0ᵢ sin δᵢ + C0ᵢ cos δᵢ) and Jacobian A = S0 ∘ cos δ − C0 ∘ sin δ
    (columns: h₀ times the unit momenta at δ = π/2 and δ = 0); sin δ and cos δ are left in
    ``sn``, ``cs`` (the integration step that follows reuses them)."""
    h0 = h1 = h2 = 0.0
    for i in range(S0.shape[1]):
        s = math.sin(delta[i])
        c = math.cos(delta[i])
        sn[i] = s
        cs[i] = c
        h0 += S0[0, i] * s + C0[0, i] * c
        h1 += S0[1, i] * s + C0[1, i] * c
        h2 += S0[2, i] * s + C0[2, i] * c
        A_out[0, i] = S0[0, i] * c - C0[0, i] * s
        A_out[1, i] = S0[1, i] * c - C0[1, i] * s
        A_out[2, i] = S0[2, i] * c - C0[2, i] * s
    return h0, h1, h2


@njit(inline="always")
def sincos_into(x: np.ndarray, xo: int, m: int, trig: np.ndarray, so: int, co: int) -> None:
    """sin and cos of the m gimbal angles ``x[xo:xo + m]`` into ``trig`` from offsets ``so``,
    ``co``."""
    for i in range(m):
        v = x[xo + i]
        trig[so + i] = math.sin(v)
        trig[co + i] = math.cos(v)


@njit(inline="always")
def cmg_momentum_and_rate_term(
    S0: np.ndarray, C0: np.ndarray, trig: np.ndarray, so: int, co: int, delta_dot: np.ndarray
) -> tuple[float, float, float, float, float, float]:
    """``(h, A δ̇)`` of the SGCMG cluster from sin δ and cos δ held in ``trig`` from offsets
    ``so`` and ``co``: h = Σᵢ (S0ᵢ sin δᵢ + C0ᵢ cos δᵢ), A δ̇ = Σᵢ (S0ᵢ cos δᵢ − C0ᵢ sin δᵢ) δ̇ᵢ —
    the part of the bus torque that does not depend on ω (an RK stage pair with the same gimbal
    angles shares it). (Offsets into one scratch array rather than slices: a slice costs two
    reference-count updates in compiled code.)"""
    h0 = h1 = h2 = r0 = r1 = r2 = 0.0
    for i in range(S0.shape[1]):
        s = trig[so + i]
        c = trig[co + i]
        h0 += S0[0, i] * s + C0[0, i] * c
        h1 += S0[1, i] * s + C0[1, i] * c
        h2 += S0[2, i] * s + C0[2, i] * c
        a = c * delta_dot[i]
        b = s * delta_dot[i]
        r0 += S0[0, i] * a - C0[0, i] * b
        r1 += S0[1, i] * a - C0[1, i] * b
        r2 += S0[2, i] * a - C0[2, i] * b
    return h0, h1, h2, r0, r1, r2


@njit(inline="always")
def cmg_bus_torque_from(
    hr: tuple[float, float, float, float, float, float], w0: float, w1: float, w2: float
) -> tuple[float, float, float]:
    """Internal torque of the SGCMG cluster on the bus, u = −A(δ) δ̇ − ω × h(δ), from
    ``hr = (h, A δ̇)`` (:func:`cmg_momentum_and_rate_term`)."""
    h0, h1, h2, r0, r1, r2 = hr
    return -(r0 + w1 * h2 - w2 * h1), -(r1 + w2 * h0 - w0 * h2), -(r2 + w0 * h1 - w1 * h0)


@njit(inline="always")
def cmg_bus_torque_at(
    S0: np.ndarray, C0: np.ndarray, w0: float, w1: float, w2: float,
    trig: np.ndarray, so: int, co: int, delta_dot: np.ndarray,
) -> tuple[float, float, float]:  # fmt: skip
    """Internal torque of the SGCMG cluster on the bus, u = −A(δ) δ̇ − ω × h(δ), from sin δ and
    cos δ held in ``trig`` from offsets ``so`` and ``co`` (:func:`cmg_momentum_and_rate_term`,
    :func:`cmg_bus_torque_from`)."""
    hr = cmg_momentum_and_rate_term(S0, C0, trig, so, co, delta_dot)
    return cmg_bus_torque_from(hr, w0, w1, w2)


@njit
def _solve3_pivot(M: np.ndarray, r0: float, r1: float, r2: float) -> tuple[float, float, float]:
    """Solve the 3×3 system M x = r by Gaussian elimination with partial pivoting (the route for
    systems whose cofactor determinant is too small to trust)."""
    a = M.copy()
    b = np.array([r0, r1, r2])
    for k in range(3):
        p = k
        for i in range(k + 1, 3):
            if abs(a[i, k]) > abs(a[p, k]):
                p = i
        if p != k:
            for j in range(3):
                a[k, j], a[p, j] = a[p, j], a[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, 3):
            f = a[i, k] / a[k, k]
            for j in range(k, 3):
                a[i, j] -= f * a[k, j]
            b[i] -= f * b[k]
    x2 = b[2] / a[2, 2]
    x1 = (b[1] - a[1, 2] * x2) / a[1, 1]
    x0 = (b[0] - a[0, 1] * x1 - a[0, 2] * x2) / a[0, 0]
    return x0, x1, x2


@njit(inline="always")
def gram(A: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """Upper triangle (M00, M01, M02, M11, M12, M22) of M = AAᵀ for ``A (3, n)``."""
    a = b = c = d = e = f = 0.0
    for i in range(A.shape[1]):
        x = A[0, i]
        y = A[1, i]
        z = A[2, i]
        a += x * x
        b += x * y
        c += x * z
        d += y * y
        e += y * z
        f += z * z
    return a, b, c, d, e, f


@njit(inline="always")
def cmg_momentum_and_measure(
    S0: np.ndarray, C0: np.ndarray, delta: np.ndarray, A: np.ndarray, sn: np.ndarray,
    cs: np.ndarray,
) -> tuple[float, float, float, float]:  # fmt: skip
    """Cluster momentum h(δ) and singularity measure m = √det(ÂÂᵀ), Â = A/h₀ (h₀ the norm of
    S0's first column): :func:`cmg_momentum_jacobian` (``A``, ``sn``, ``cs`` its scratch) and
    :func:`gram` — the compiled route of :meth:`spacecraft.sgcmg.SgcmgPyramid.momentum` and
    ``singularity_measure`` (the numpy reference; the determinant as its row·adjugate form)."""
    h0, h1, h2 = cmg_momentum_jacobian(S0, C0, delta, A, sn, cs)
    a, b, c, d, e, f = gram(A)
    inv = 1.0 / (S0[0, 0] * S0[0, 0] + S0[1, 0] * S0[1, 0] + S0[2, 0] * S0[2, 0])
    a, b, c, d, e, f = a * inv, b * inv, c * inv, d * inv, e * inv, f * inv
    det = a * (d * f - e * e) + b * (c * e - b * f) + c * (b * e - c * d)
    return h0, h1, h2, math.sqrt(max(det, 0.0))


@njit(inline="always")
def _regularised_multiplier(
    g: tuple, lam: float, eps: float, gsr: bool, e1: float, e2: float, e3: float,
    q0: float, q1: float, q2: float,
) -> tuple[float, float, float]:  # fmt: skip
    """y = (AAᵀ + λ E + ε tr(AAᵀ)/3 I)⁻¹ q given the Gram entries ``g`` of AAᵀ
    (:func:`gram`), E = I or the GSR dither matrix; Cramer's rule on the symmetric 3×3,
    pivoted elimination where its determinant is too small to trust."""
    a, b, c, d, e, f = g
    tr3 = (a + d + f) / 3.0
    reg = lam + eps * tr3
    if not reg > 0.0:
        reg = 1.0
    a += reg
    d += reg
    f += reg
    if gsr:
        b += lam * e3
        c += lam * e2
        e += lam * e1
    c00 = d * f - e * e
    c01 = c * e - b * f
    c02 = b * e - c * d
    c11 = a * f - c * c
    c12 = b * c - a * e
    c22 = a * d - b * b
    det = a * c00 + b * c01 + c * c02
    tr3 += reg
    if det >= _DET_REL_TRUST * tr3 * tr3 * tr3:
        inv = 1.0 / det
        return (
            (c00 * q0 + c01 * q1 + c02 * q2) * inv,
            (c01 * q0 + c11 * q1 + c12 * q2) * inv,
            (c02 * q0 + c12 * q1 + c22 * q2) * inv,
        )
    Mr = np.empty((3, 3))
    Mr[0, 0] = a
    Mr[0, 1] = b
    Mr[0, 2] = c
    Mr[1, 0] = b
    Mr[1, 1] = d
    Mr[1, 2] = e
    Mr[2, 0] = c
    Mr[2, 1] = e
    Mr[2, 2] = f
    return _solve3_pivot(Mr, q0, q1, q2)


@njit(inline="always")
def steer_regularised(
    kind: int, p: np.ndarray, t: float, A: np.ndarray, q0: float, q1: float, q2: float,
    out: np.ndarray,
) -> None:  # fmt: skip
    """δ̇ = Aᵀ(AAᵀ + λ s² E + ε tr(AAᵀ)/3 I)⁻¹ ḣ for the pseudo-inverse (λ = 0, E = I),
    singularity-robust (λ = λ₀ e^{−μ m²}, E = I; Nakamura & Hanafusa 1986) and generalized
    singularity-robust (E with the dither εᵢ = ε₀ sin(ω_ε t + φᵢ) off the diagonal; Wie 2005)
    laws, m = √det(ÂÂᵀ) with Â = A/s, s² = ‖A‖²_F/n. ``p = (λ₀, μ, ε, ε₀, ω_ε, φ₁, φ₂, φ₃)``."""
    n = A.shape[1]
    g = gram(A)
    lam = 0.0
    if kind != STEER_PINV:
        a, b, c, d, e, f = g
        det0 = a * (d * f - e * e) + b * (c * e - b * f) + c * (b * e - c * d)
        s2 = (a + d + f) / n
        s2_safe = s2 if s2 > 0.0 else 1.0
        m2 = max(det0, 0.0) / (s2_safe * s2_safe * s2_safe)
        lam = p[0] * math.exp(-p[1] * m2) * s2
    e1 = e2 = e3 = 0.0
    if kind == STEER_GSR:
        w = p[4] * t
        e1 = p[3] * math.sin(w + p[5])
        e2 = p[3] * math.sin(w + p[6])
        e3 = p[3] * math.sin(w + p[7])
    y0, y1, y2 = _regularised_multiplier(g, lam, p[2], kind == STEER_GSR, e1, e2, e3, q0, q1, q2)
    for i in range(n):
        out[i] = A[0, i] * y0 + A[1, i] * y1 + A[2, i] * y2


@njit
def measure_gradient(
    Su: np.ndarray, Cu: np.ndarray, delta: np.ndarray, floor: float, grad: np.ndarray
) -> float:
    """Singularity measure m = √det(ÂÂᵀ) of the unit Jacobian Â and its gradient
    ∂m/∂δᵢ = −âᵢᵀ adj(ÂÂᵀ) ĥᵢ / max(m, floor) (Jacobi's formula; ĥᵢ, âᵢ the unit momentum and
    its derivative) into ``grad``; ``Su``, ``Cu`` the unit momenta at δ = π/2 and 0."""
    n = Su.shape[1]
    a = b = c = d = e = f = 0.0
    for i in range(n):
        sn = math.sin(delta[i])
        cs = math.cos(delta[i])
        ax = Su[0, i] * cs - Cu[0, i] * sn
        ay = Su[1, i] * cs - Cu[1, i] * sn
        az = Su[2, i] * cs - Cu[2, i] * sn
        a += ax * ax
        b += ax * ay
        c += ax * az
        d += ay * ay
        e += ay * az
        f += az * az
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
    m = math.sqrt(max(a * c00 + b * c01 + c * c02, 0.0))
    den = max(m, floor)
    for i in range(n):
        sn = math.sin(delta[i])
        cs = math.cos(delta[i])
        hx = Su[0, i] * sn + Cu[0, i] * cs
        hy = Su[1, i] * sn + Cu[1, i] * cs
        hz = Su[2, i] * sn + Cu[2, i] * cs
        ax = Su[0, i] * cs - Cu[0, i] * sn
        ay = Su[1, i] * cs - Cu[1, i] * sn
        az = Su[2, i] * cs - Cu[2, i] * sn
        w0 = c00 * hx + c01 * hy + c02 * hz
        w1 = c01 * hx + c11 * hy + c12 * hz
        w2 = c02 * hx + c12 * hy + c22 * hz
        grad[i] = -(ax * w0 + ay * w1 + az * w2) / den
    return m


@njit
def steer_null_motion(
    p: np.ndarray, A: np.ndarray, q0: float, q1: float, q2: float, Su: np.ndarray,
    Cu: np.ndarray, delta: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """Pseudo-inverse plus null motion (Wu, Huang, Wei & Guo):
    δ̇ = A⁺ḣ + k (I − A⁺A) ∇_δ m, with A⁺ = Aᵀ(AAᵀ + ε tr(AAᵀ)/3 I)⁻¹. ``p = (k, ε, floor of
    m)``. ``out`` holds ∇m until the last loop."""
    n = A.shape[1]
    measure_gradient(Su, Cu, delta, p[2], out)
    g0 = g1 = g2 = 0.0
    for i in range(n):
        g0 += A[0, i] * out[i]
        g1 += A[1, i] * out[i]
        g2 += A[2, i] * out[i]
    gm = gram(A)
    x0, x1, x2 = _regularised_multiplier(gm, 0.0, p[1], False, 0.0, 0.0, 0.0, q0, q1, q2)
    y0, y1, y2 = _regularised_multiplier(gm, 0.0, p[1], False, 0.0, 0.0, 0.0, g0, g1, g2)
    k = p[0]
    for i in range(n):
        pinv = A[0, i] * x0 + A[1, i] * x1 + A[2, i] * x2
        proj = A[0, i] * y0 + A[1, i] * y1 + A[2, i] * y2
        out[i] = pinv + k * (out[i] - proj)


@njit
def no_steering(
    t: float, A: np.ndarray, hdot: np.ndarray, delta: np.ndarray, params: np.ndarray,
    out: np.ndarray,
) -> None:  # fmt: skip
    """The steering pointer of a configuration whose law is built in (never called: the code
    selects the built-in formula)."""
    return None


@njit(inline="always")
def sgcmg_command(
    S0: np.ndarray, C0: np.ndarray, steer: int, sp: np.ndarray, steer_fn: object,
    rate_limit: float, u: np.ndarray, w: np.ndarray, delta: np.ndarray, t: float,
    dd_out: np.ndarray, hd_out: np.ndarray, A: np.ndarray, sn: np.ndarray, cs: np.ndarray,
) -> bool:  # fmt: skip
    """The SGCMG cluster's hardware command: ḣ_cmd = −(ω × h(δ) + u), δ̇ = steering(A(δ), ḣ_cmd),
    scaled down uniformly to the gimbal-rate limit. Returns whether it was scaled. ``A (3, n)``
    is scratch space for the Jacobian, ``sn``, ``cs`` receive sin δ and cos δ; the null-motion
    law's unit momenta follow its three parameters in ``sp[8:]``; ``STEER_KERNEL`` calls
    ``steer_fn(t, A, ḣ_cmd, δ, sp, δ̇)`` (:mod:`spacecraft.steering_kernel`)."""
    h0, h1, h2 = cmg_momentum_jacobian(S0, C0, delta, A, sn, cs)
    w0, w1, w2 = w[0], w[1], w[2]
    q0 = -((w1 * h2 - w2 * h1) + u[0])
    q1 = -((w2 * h0 - w0 * h2) + u[1])
    q2 = -((w0 * h1 - w1 * h0) + u[2])
    hd_out[0] = q0
    hd_out[1] = q1
    hd_out[2] = q2
    if steer == STEER_PINV_NULL:
        n = S0.shape[1]
        Su = sp[8 : 8 + 3 * n].reshape((3, n))
        Cu = sp[8 + 3 * n : 8 + 6 * n].reshape((3, n))
        steer_null_motion(sp, A, q0, q1, q2, Su, Cu, delta, dd_out)
    elif steer == STEER_KERNEL:
        steer_fn(t, A, hd_out, delta, sp, dd_out)
    else:
        steer_regularised(steer, sp, t, A, q0, q1, q2, dd_out)
    peak = 0.0
    for i in range(dd_out.shape[0]):
        peak = max(peak, abs(dd_out[i]))
    if peak > rate_limit:
        scale = rate_limit / peak
        for i in range(dd_out.shape[0]):
            dd_out[i] = dd_out[i] * scale
        return True
    return False


@njit(inline="always")
def ideal_command(
    u: np.ndarray, clip_on: bool, clip: np.ndarray, held: np.ndarray, sat: np.ndarray
) -> bool:
    """The ideal actuator's command: ``held = u`` clipped to ``±clip`` per axis when
    ``clip_on``; ``sat[i]`` = axis ``i`` at its limit (``|held_i| ≥ clip_i``, the one saturation
    test of the compiled loops, as :meth:`spacecraft.actuators.IdealTorqueActuator.log`).
    Returns whether any axis is at its limit."""
    limited = False
    for i in range(3):
        v = u[i]
        at = False
        if clip_on:
            v = min(max(v, -clip[i]), clip[i])
            at = abs(v) >= clip[i]
        held[i] = v
        sat[i] = at
        limited = limited or at
    return limited


@njit(inline="always")
def actuator_torque(
    act: int, S0: np.ndarray, C0: np.ndarray, w0: float, w1: float, w2: float,
    x: np.ndarray, xo: int, held: np.ndarray, trig: np.ndarray,
) -> tuple[float, float, float]:  # fmt: skip
    """The internal torque the actuator exerts on the bus for the held command; the actuator
    state is ``x[xo:]``, ``trig`` scratch of twice the gimbal count."""
    if act == ACT_SGCMG:
        m = held.shape[0]
        sincos_into(x, xo, m, trig, 0, m)
        return cmg_bus_torque_at(S0, C0, w0, w1, w2, trig, 0, m, held)
    return held[0], held[1], held[2]


@njit(inline="always")
def _stage_term(
    act: int, S0: np.ndarray, C0: np.ndarray, x: np.ndarray, xo: int, held: np.ndarray,
    work: np.ndarray, so: int, co: int, trig: bool,
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """The ω-independent part of a stage's actuator torque: SGCMG ``(h, A δ̇)`` at the stage's
    gimbal angles ``x[xo:]`` (:func:`cmg_momentum_and_rate_term`; ``work`` from ``so`` and
    ``co`` holds their sin and cos, computed here when ``trig`` is set); zeros otherwise."""
    if act == ACT_SGCMG:
        m = held.shape[0]
        if trig:
            sincos_into(x, xo, m, work, so, co)
        return cmg_momentum_and_rate_term(S0, C0, work, so, co, held)
    return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@njit(inline="always")
def stage_disturbance(
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool, t: float, R: np.ndarray,
    u0: float, u1: float, u2: float, first: bool, w0: float, w1: float, w2: float,
    work: np.ndarray, o: int,
) -> tuple[float, float, float]:  # fmt: skip
    """The external torque at an RKMK4 stage: a time-only code (:func:`disturbance_at`), or for
    ``DIST_KERNEL`` the seam's torque ``dfn(t, R_s, ω_s, dpk, out)`` (spacecraft.
    disturbance_kernel) at the stage attitude R_s = R exp(u) (R itself at the ``first`` stage;
    not formed unless ``datt``) and the stage rate; ``work[o:o + 15]`` is its scratch."""
    if dist == DIST_KERNEL:
        Rs = work[o : o + 9].reshape((3, 3))
        ws = work[o + 9 : o + 12]
        out = work[o + 12 : o + 15]
        ws[0] = w0
        ws[1] = w1
        ws[2] = w2
        if datt and not first:
            right_multiply_exp_into(R, u0, u1, u2, Rs)
            dfn(t, Rs, ws, dpk, out)
        else:
            dfn(t, R, ws, dpk, out)
        return out[0], out[1], out[2]
    return disturbance_at(dist, dp, t)


@njit(inline="always")
def _field(
    act: int, J: np.ndarray, Jinv: np.ndarray,
    d: tuple[float, float, float],
    w0: float, w1: float, w2: float, held: np.ndarray,
    hr: tuple[float, float, float, float, float, float],
) -> tuple[float, float, float]:  # fmt: skip
    """ω̇ of the packed state (ω, x_act) for a held actuator command (the actuator state's own
    derivative is the held δ̇ of the SGCMG, nothing for the ideal actuator) under the external
    torque ``d`` (:func:`stage_disturbance`); the rate ω is passed as values. SGCMG: the bus
    torque from the stage's ``hr = (h, A δ̇)`` (:func:`_stage_term`); ideal: the held torque."""
    if act == ACT_SGCMG:
        t0, t1, t2 = cmg_bus_torque_from(hr, w0, w1, w2)
    else:
        t0, t1, t2 = held[0], held[1], held[2]
    d0, d1, d2 = d
    return rigid_acceleration(J, Jinv, w0, w1, w2, t0 + d0, t1 + d1, t2 + d2)


@njit(inline="always")
def rkmk4_step(
    act: int, J: np.ndarray, Jinv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    t: float, R: np.ndarray, x: np.ndarray, held: np.ndarray,
    h: float, R_out: np.ndarray, x_out: np.ndarray, work: np.ndarray, trig_ready: bool,
) -> None:  # fmt: skip
    """One RKMK4 step of one rigid spacecraft on SO(3) × ℝⁿ (Munthe-Kaas 1998): the classical
    RK4 tableau on the chart θ with dexp⁻¹ truncated at fourth order; R_{k+1} = R exp(h/6 (K₁ +
    2K₂ + 2K₃ + K₄)). The time-only disturbances do not read the stage attitudes; a seam torque
    (``DIST_KERNEL``, :func:`stage_disturbance`) that reads them gets R exp(θ_s) with the
    Python route's θ₂ = h/2 K₁, θ₃ = h/2 K₂, θ₄ = h K₃. ``work`` (≥ 7n + 15) is scratch space;
    with ``trig_ready`` its slots ``[5n, 5n + m)`` and ``[6n, 6n + m)`` already hold sin and
    cos of the m gimbal angles x[3:] (the SGCMG command of the same step computed them). The
    stage rates and their derivatives are kept in locals (values, not scratch-array round
    trips); the actuator state's derivative is the held command in every stage (SGCMG: δ̇), so
    its stages are x + c h δ̇."""
    n = x.shape[0]
    m = n - 3
    h2 = 0.5 * h
    # work: the stage's actuator state at 4n + 3; sin, cos of the gimbal angles at 5n, 6n
    os_, so, co = 4 * n, 5 * n, 6 * n
    x0, x1, x2 = x[0], x[1], x[2]
    hr = _stage_term(act, S0, C0, x, 3, held, work, so, co, not trig_ready)
    do = 7 * n
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t, R, 0.0, 0.0, 0.0, True, x0, x1, x2, work, do
    )  # fmt: skip
    k10, k11, k12 = _field(act, J, Jinv, d, x0, x1, x2, held, hr)
    u0, u1, u2 = h2 * x0, h2 * x1, h2 * x2
    s0, s1, s2 = x0 + h2 * k10, x1 + h2 * k11, x2 + h2 * k12
    for i in range(m):
        work[os_ + 3 + i] = x[3 + i] + h2 * held[i]
    # stages 2 and 3 have the same gimbal angles bitwise (ẋ_act = held δ̇ in both): one (h, Aδ̇)
    hr = _stage_term(act, S0, C0, work, os_ + 3, held, work, so, co, True)
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t + h2, R, u0, u1, u2, False, s0, s1, s2, work, do
    )  # fmt: skip
    k20, k21, k22 = _field(act, J, Jinv, d, s0, s1, s2, held, hr)
    b0, b1, b2 = dexpinv_rkmk4(u0, u1, u2, s0, s1, s2)
    u0, u1, u2 = h2 * b0, h2 * b1, h2 * b2
    s0, s1, s2 = x0 + h2 * k20, x1 + h2 * k21, x2 + h2 * k22
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t + h2, R, u0, u1, u2, False, s0, s1, s2, work, do
    )  # fmt: skip
    k30, k31, k32 = _field(act, J, Jinv, d, s0, s1, s2, held, hr)
    c0, c1, c2 = dexpinv_rkmk4(u0, u1, u2, s0, s1, s2)
    u0, u1, u2 = h * c0, h * c1, h * c2
    s0, s1, s2 = x0 + h * k30, x1 + h * k31, x2 + h * k32
    for i in range(m):
        work[os_ + 3 + i] = x[3 + i] + h * held[i]
    hr = _stage_term(act, S0, C0, work, os_ + 3, held, work, so, co, True)
    d = stage_disturbance(
        dist, dp, dfn, dpk, datt, t + h, R, u0, u1, u2, False, s0, s1, s2, work, do
    )  # fmt: skip
    k40, k41, k42 = _field(act, J, Jinv, d, s0, s1, s2, held, hr)
    e0, e1, e2 = dexpinv_rkmk4(u0, u1, u2, s0, s1, s2)
    h6 = h / 6.0
    x_out[0] = x0 + (((k20 + k30) * 2.0 + k10) + k40) * h6
    x_out[1] = x1 + (((k21 + k31) * 2.0 + k11) + k41) * h6
    x_out[2] = x2 + (((k22 + k32) * 2.0 + k12) + k42) * h6
    for i in range(m):
        d = held[i]
        x_out[3 + i] = x[3 + i] + (((d + d) * 2.0 + d) + d) * h6
    right_multiply_exp_into(
        R,
        h6 * (x0 + 2.0 * (b0 + c0) + e0),
        h6 * (x1 + 2.0 * (b1 + c1) + e1),
        h6 * (x2 + 2.0 * (b2 + c2) + e2),
        R_out,
    )


@njit
def rkmk4_step_batch(
    act: int, J: np.ndarray, Jinv: np.ndarray, S0: np.ndarray, C0: np.ndarray,
    dist: int, dp: np.ndarray, dfn: Any, dpk: np.ndarray, datt: bool,
    t: float, R: np.ndarray, x: np.ndarray, held: np.ndarray,
    h: float, R_out: np.ndarray, x_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`rkmk4_step` over a batch (``J``, ``Jinv`` ``(1, 3, 3)`` shared or ``(B, 3, 3)``;
    the seam torque's parameters ``dpk`` ``(1, n_p)`` shared or ``(B, n_p)``)."""
    shared = J.shape[0] == 1
    pshared = dpk.shape[0] == 1
    work = np.empty(7 * x.shape[1] + 15)
    for b in range(R.shape[0]):
        k = 0 if shared else b
        kp = 0 if pshared else b
        rkmk4_step(
            act, J[k], Jinv[k], S0, C0, dist, dp, dfn, dpk[kp], datt, t, R[b], x[b], held[b], h,
            R_out[b], x_out[b], work, False,
        )  # fmt: skip


@njit
def sgcmg_command_batch(
    S0: np.ndarray, C0: np.ndarray, steer: int, sp: np.ndarray, rate_limit: float,
    u: np.ndarray, w: np.ndarray, delta: np.ndarray, t: float,
    dd_out: np.ndarray, hd_out: np.ndarray, sat_out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`sgcmg_command` over a batch (the built-in laws: the Python loop's command; a
    user's kernel flies only the fused loop)."""
    A = np.empty((3, S0.shape[1]))
    sn = np.empty(S0.shape[1])
    cs = np.empty(S0.shape[1])
    for b in range(u.shape[0]):
        sat_out[b] = sgcmg_command(
            S0, C0, steer, sp, no_steering, rate_limit, u[b], w[b], delta[b], t, dd_out[b],
            hd_out[b], A, sn, cs,
        )  # fmt: skip


@njit
def cmg_bus_torque_batch(
    S0: np.ndarray, C0: np.ndarray, w: np.ndarray, delta: np.ndarray, delta_dot: np.ndarray,
    out: np.ndarray,
) -> None:  # fmt: skip
    """The cluster's bus torque (:func:`cmg_bus_torque_at`) over a batch."""
    m = delta.shape[1]
    trig = np.empty(2 * m)
    for b in range(w.shape[0]):
        sincos_into(delta[b], 0, m, trig, 0, m)
        out[b, 0], out[b, 1], out[b, 2] = cmg_bus_torque_at(
            S0, C0, w[b, 0], w[b, 1], w[b, 2], trig, 0, m, delta_dot[b]
        )


@njit
def steer_batch(
    kind: int, p: np.ndarray, t: float, A: np.ndarray, q: np.ndarray, out: np.ndarray
) -> None:
    """:func:`steer_regularised` over a batch ``A (N, 3, n)``, ``q (N, 3)`` → ``out (N, n)``."""
    for b in range(A.shape[0]):
        steer_regularised(kind, p, t, A[b], q[b, 0], q[b, 1], q[b, 2], out[b])
