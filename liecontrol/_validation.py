"""Input validation shared by every public entry point.

Every message starts with the argument's name and then says what is wrong, e.g.
``"R: not orthonormal (max |RᵀR − I| = 3.2e-02 > 1e-09)"``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "as_array",
    "check_finite",
    "check_shape_tail",
    "check_rotation_matrix",
    "check_inertia",
    "check_inertia_3x3",
    "check_spd",
    "rotations_pass_fast",
    "check_positive",
    "check_nonnegative",
    "as_scalar",
    "check_positive_scalar",
    "check_tolerance",
    "check_bool",
    "broadcast_batch",
    "check_output_finite",
    "norm_last",
    "as_int",
    "transform_matrix",
    "ROTATION_ATOL",
]

#: Default tolerance on max |RᵀR − I| and |det R − 1| for a matrix to count as a rotation.
ROTATION_ATOL = 1e-9

_F64 = np.dtype(np.float64)


def transform_matrix(x: object) -> np.ndarray | None:
    """The matrix array of a rotation/rigid-motion *object*, or ``None`` for anything else.

    Accepted objects: scipy's ``Rotation`` → ``(3, 3)`` or ``(N, 3, 3)`` (single or stacked,
    via ``as_matrix()``), scipy's ``RigidTransform`` → ``(4, 4)`` or ``(N, 4, 4)``, and
    liecontrol's own ``SO3`` / ``SE3`` wrappers. This is the one place where every validated
    entry point learns to take those objects (it is called by the float-array conversion
    under :func:`as_array` and :func:`check_rotation_matrix` when a matrix shape is
    expected), so an attitude argument accepts a scipy ``Rotation`` wherever it accepts a
    matrix, and nowhere else (see :func:`_to_float_array`). The check is by the type's module
    and name, so scipy is never imported here.
    """
    t = type(x)
    mod = t.__module__
    if mod.startswith("scipy.spatial.transform"):
        if t.__name__ in ("Rotation", "RigidTransform"):
            return np.asarray(x.as_matrix(), dtype=np.float64)  # type: ignore[attr-defined]
        return None
    if mod == "liecontrol.lie.groups" and t.__name__ in ("SO3", "SE3"):
        return np.array(x.as_matrix(), dtype=np.float64)  # type: ignore[attr-defined]
    return None


def _to_float_array(x: object, name: str, matrix: int | None = None) -> np.ndarray:
    """``x`` as a float64 array; complex input with a non-zero imaginary part, strings and
    non-numeric objects raise (numpy alone would warn and drop the imaginary part).

    ``matrix`` = 3 (or 4) says the argument is a rotation (or rigid-motion) matrix: a scipy
    ``Rotation`` (``RigidTransform``) or an ``SO3`` (``SE3``) is then converted to its matrices
    (:func:`transform_matrix`). Anywhere else such an object raises — silently using its 3×3
    matrix as, say, three rotation vectors would give a meaningless result.
    """
    if type(x) is np.ndarray and x.dtype == _F64:
        return x  # the fast path: nothing to convert
    m = transform_matrix(x)
    if m is not None:
        if matrix is not None and m.shape[-1] == matrix:
            return m
        kind = type(x).__name__
        raise ValueError(
            f"{name}: got a {kind} object where "
            + (f"a ({matrix}, {matrix}) matrix" if matrix else "an array of numbers")
            + f" is expected (a {kind} is accepted only for "
            + ("rigid-motion" if m.shape[-1] == 4 else "attitude")
            + " arguments; convert it explicitly, e.g. with .as_rotvec() or .as_quat())"
        )
    try:
        raw = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be converted to a float array ({exc})") from None
    if raw.dtype.kind == "c":
        if np.any(raw.imag != 0):
            raise ValueError(
                f"{name}: complex values are not accepted (expected real numbers, got dtype "
                f"{raw.dtype})"
            )
        raw = raw.real
    elif raw.dtype.kind == "O" and any(v is None for v in raw.flat):
        # numpy would turn None into NaN: the error would then speak of a non-finite value
        raise ValueError(
            f"{name}: expected real numbers, got None"
            + ("" if raw.ndim == 0 else " among the entries")
        )
    elif raw.dtype.kind in "USVMm":
        # numpy would parse "1.5" as a number: text, bytes and dates are not numbers here
        raise ValueError(
            f"{name}: cannot be converted to a float array (expected real numbers, got dtype "
            f"{raw.dtype})"
        )
    try:
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name}: cannot be converted to a float array ({exc})") from None


def as_array(x: object, name: str, tail: tuple[int, ...] | None = None) -> np.ndarray:
    """Return ``x`` as a finite real float64 array, checking the trailing shape if given.

    Never copies when ``x`` already is a float64 array (callers must not mutate the result).
    Complex input is rejected unless every imaginary part is exactly zero. With ``tail``
    (3, 3) or (4, 4), a scipy ``Rotation`` / ``RigidTransform`` (or ``SO3`` / ``SE3``) is
    accepted and converted to its matrices.
    """
    a = _to_float_array(x, name, tail[0] if tail in ((3, 3), (4, 4)) else None)
    if tail is not None:
        check_shape_tail(a, name, tail)
    check_finite(a, name)
    return a


def as_scalar(x: object, name: str) -> float:
    """Return ``x`` as a finite real Python float; arrays (other than 0-d) are rejected with
    ``"{name}: expected a scalar, got an array of shape …"``."""
    if type(x) is float and math.isfinite(x):
        return x  # the fast path of controllers' time arguments
    if isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name}: expected a real number, got a bool")
    a = _to_float_array(x, name)
    if a.ndim != 0:
        raise ValueError(f"{name}: expected a scalar, got an array of shape {a.shape}")
    check_finite(a, name)
    return float(a)


def check_positive_scalar(x: object, name: str) -> float:
    """A finite real scalar ``> 0`` as a Python float (arrays rejected)."""
    v = as_scalar(x, name)
    if not v > 0.0:
        raise ValueError(f"{name}: must be > 0, got {v}")
    return v


def check_tolerance(x: object, name: str, upper: float | None = None) -> float:
    """A tolerance argument (``atol``, ``lock_tol``, ``norm_tol``, …): a finite real scalar
    ``> 0`` (and ``< upper`` when given, e.g. 1 for a threshold on |cos a| that would otherwise
    flag everything). NaN or a negative value would otherwise silently switch the check it
    controls off (every comparison with NaN is False)."""
    v = check_positive_scalar(x, name)
    if upper is not None and not v < upper:
        raise ValueError(f"{name}: must be < {upper:g} (a larger tolerance flags every input)")
    return v


def check_finite(a: np.ndarray, name: str) -> None:
    """Raise if ``a`` holds NaN or inf."""
    if not np.all(np.isfinite(a)):
        bad = int(np.size(a) - np.count_nonzero(np.isfinite(a)))
        raise ValueError(f"{name}: contains {bad} non-finite value(s) (NaN or inf)")


def check_shape_tail(a: np.ndarray, name: str, tail: tuple[int, ...]) -> None:
    """Raise unless ``a.shape`` ends with ``tail``."""
    k = len(tail)
    if a.ndim < k or tuple(a.shape[a.ndim - k :]) != tuple(tail):
        want = "(..., " + ", ".join(str(t) for t in tail) + ")"
        raise ValueError(f"{name}: expected shape {want}, got {a.shape}")


def check_rotation_matrix(R: object, name: str = "R", atol: float = ROTATION_ATOL) -> np.ndarray:
    """Validate a (batch of) rotation matrices and return it as a float64 array."""
    a = as_array(R, name, (3, 3))
    err = np.abs(np.swapaxes(a, -1, -2) @ a - np.eye(3)).max(axis=(-2, -1))
    worst = float(err.max()) if err.size else 0.0
    if worst > atol:
        raise ValueError(f"{name}: not orthonormal (max |RᵀR − I| = {worst:.2e} > {atol:.0e})")
    det = np.linalg.det(a)
    if np.any(det < 0):
        raise ValueError(f"{name}: determinant is −1 (a reflection, not a rotation)")
    return a


def rotations_pass_fast(R: object, atol: float = ROTATION_ATOL) -> bool:
    """True iff ``R`` is already a float64 ndarray of shape ``(..., 3, 3)`` that
    :func:`check_rotation_matrix` would accept unchanged (finite, ``max |RᵀR − I| ≤ atol``,
    ``det ≥ 0``).

    The cheap test for controller hot paths (called at every control sample): ``False`` means
    "run :func:`check_rotation_matrix`", which raises the usual message (or converts, e.g. a
    list). NaN/inf make the comparisons False, so they are rejected too. The determinant is the
    triple product instead of ``np.linalg.det`` (a matrix within ``atol`` of orthonormal has
    ``det ≈ ±1``, so the sign is unambiguous); one matrix runs on Python floats, where numpy's
    per-call overhead would dominate.
    """
    if not (
        isinstance(R, np.ndarray) and R.dtype == _F64 and R.ndim >= 2 and R.shape[-2:] == (3, 3)
    ):
        return False
    if R.size == 9:
        a, b, c, d, e, f, g, h, k = R.ravel().tolist()
        # columns' Gram matrix RᵀR − I and det R = c0 · (c1 × c2)
        err = max(
            abs(a * a + d * d + g * g - 1.0),
            abs(b * b + e * e + h * h - 1.0),
            abs(c * c + f * f + k * k - 1.0),
            abs(a * b + d * e + g * h),
            abs(a * c + d * f + g * k),
            abs(b * c + e * f + h * k),
        )
        det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
        return err <= atol and det >= 0.0
    if R.size == 0:
        return True
    # the nine entries as contiguous rows (one copy), then the Gram matrix RᵀR − I and the
    # determinant entry-wise: ~2× cheaper than a stacked matmul of 3×3 matrices
    a, b, c, d, e, f, g, h, k = R.reshape(-1, 9).T.copy()
    err = np.abs(a * a + d * d + g * g - 1.0)
    for x in (
        b * b + e * e + h * h - 1.0,
        c * c + f * f + k * k - 1.0,
        a * b + d * e + g * h,
        a * c + d * f + g * k,
        b * c + e * f + h * k,
    ):
        np.maximum(err, np.abs(x, out=x), out=err)  # NaN propagates, so it is rejected below
    if not err.max() <= atol:
        return False
    det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
    return bool(np.all(det >= 0.0))


def check_spd(
    M: object, name: str, *, symbol: str = "M", what: str = "", pd_rtol: float = 0.0
) -> np.ndarray:
    """Check that ``M`` is a finite, symmetric (``max |M − Mᵀ| ≤ 1e-9 max |M|``), positive-definite
    square matrix (smallest eigenvalue ``> pd_rtol ·`` largest); return its eigenvalues in
    ascending order (``np.linalg.eigvalsh``).

    Messages: ``"{name}: {what}not symmetric (max |{symbol} − {symbol}ᵀ| = …)"`` and
    ``"{name}: {what}not positive definite (smallest eigenvalue …)"``; ``what`` qualifies the
    matrix (e.g. ``"gain matrix "``), ``symbol`` names it in the formula.
    """
    a = as_array(M, name)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{name}: expected a square matrix (n, n), got shape {a.shape}")
    scale = float(np.abs(a).max()) if a.size else 0.0
    asym = float(np.abs(a - a.T).max()) if a.size else 0.0
    if asym > 1e-9 * max(scale, 1e-300):
        raise ValueError(f"{name}: {what}not symmetric (max |{symbol} − {symbol}ᵀ| = {asym:.2e})")
    eig = np.linalg.eigvalsh(a)
    if eig.size and eig[0] <= pd_rtol * max(float(eig[-1]), 1e-300):
        raise ValueError(f"{name}: {what}not positive definite (smallest eigenvalue {eig[0]:.3e})")
    return eig


def check_inertia(J: object, name: str = "J", rtol: float = 1e-9) -> np.ndarray:
    """Validate a 3×3 (or batched) inertia matrix: finite, symmetric, positive definite and
    satisfying the triangle inequality on its principal moments."""
    a = as_array(J, name, (3, 3))
    scale = np.abs(a).max(axis=(-2, -1))
    asym = np.abs(a - np.swapaxes(a, -1, -2)).max(axis=(-2, -1))
    if np.any(asym > rtol * np.maximum(scale, 1e-300)):
        raise ValueError(f"{name}: not symmetric (max |J − Jᵀ| = {float(asym.max()):.2e})")
    eig = np.linalg.eigvalsh(a)
    if np.any(eig <= 0):
        raise ValueError(
            f"{name}: not positive definite (smallest principal moment {float(eig.min()):.3e})"
        )
    # principal moments must satisfy J1 + J2 >= J3 for a physical body
    slack = eig[..., 0] + eig[..., 1] - eig[..., 2]
    if np.any(slack < -rtol * eig[..., 2]):
        raise ValueError(
            f"{name}: principal moments violate the triangle inequality "
            f"(J1 + J2 < J3 by {float(-slack.min()):.3e})"
        )
    return a


def check_inertia_3x3(J: object, name: str = "J") -> np.ndarray:
    """:func:`check_inertia` for exactly one inertia matrix: also rejects a batch (shape not
    ``(3, 3)``). Returns the validated float64 array (not a copy when ``J`` already is one)."""
    a = as_array(J, name)
    # the shape first: a single-matrix API says "(3, 3)", not check_inertia's "(..., 3, 3)"
    if a.shape != (3, 3):
        raise ValueError(f"{name}: expected shape (3, 3), got {a.shape}")
    return check_inertia(a, name)


def check_positive(x: object, name: str) -> np.ndarray | float:
    """Validate a strictly positive finite scalar or array; scalars come back as float."""
    a = as_array(x, name)
    if np.any(a <= 0):
        raise ValueError(f"{name}: must be > 0, got {a if a.ndim == 0 else a.min()}")
    return float(a) if a.ndim == 0 else a


def check_nonnegative(x: object, name: str) -> np.ndarray | float:
    """Validate a non-negative finite scalar or array; scalars come back as float."""
    a = as_array(x, name)
    if np.any(a < 0):
        raise ValueError(f"{name}: must be >= 0, got {a if a.ndim == 0 else a.min()}")
    return float(a) if a.ndim == 0 else a


def check_bool(x: object, name: str) -> bool:
    """A flag argument: ``True``/``False`` (or numpy bools) only — a string such as ``"no"``
    would otherwise count as true."""
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    raise TypeError(f"{name}: expected True or False, got {type(x).__name__} {x!r}")


def broadcast_batch(*named: tuple[str, tuple[int, ...]]) -> tuple[int, ...]:
    """The broadcast of the batch shapes given as ``(name, shape)`` pairs; raises
    ``"{name}: batch shape … does not broadcast …"`` naming the first argument that does not fit
    the ones before it (instead of numpy's anonymous broadcasting error)."""
    out: tuple[int, ...] = ()
    first = named[0][0]
    for name, shape in named:
        try:
            out = np.broadcast_shapes(out, tuple(shape))
        except ValueError:
            raise ValueError(
                f"{name}: batch shape {tuple(shape)} does not broadcast against {first}'s and "
                f"the other arguments' batch shape {out}"
            ) from None
    return out


def check_output_finite(out: np.ndarray, name: str, what: str) -> np.ndarray:
    """Raise ``"{name}: {what} overflows float64 …"`` if a computed result holds inf/NaN (the
    input was finite, so only overflow can cause it); return ``out`` otherwise."""
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name}: {what} overflows float64 for this input (too large)")
    return out


def norm_last(a: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis without overflow or underflow: ``a·a`` is used directly
    when it is safely inside the float range, otherwise each row is scaled by its max |aᵢ|
    first (so ‖1e300·q‖ = 1e300‖q‖ and ‖1e-300·q‖ = 1e-300‖q‖)."""
    if a.size <= 64:
        # small arrays (one quaternion, a few sigma points): Python floats decide the fast path
        # without numpy's per-call overhead (errstate, two reductions)
        flat = a.ravel().tolist()
        if flat and max(flat) < 1e100 and min(flat) > -1e100 and all(
            x == 0.0 or abs(x) > 1e-100 for x in flat
        ):
            return np.sqrt(np.sum(a * a, axis=-1))
    with np.errstate(over="ignore", under="ignore"):
        n2 = np.sum(a * a, axis=-1)
    # a non-zero row can underflow to n2 = 0, so rows with n2 = 0 take the scaled route too
    if not n2.size or (np.max(n2) < 1e200 and np.min(n2) >= 1e-200):
        return np.sqrt(n2)
    n = np.array(np.sqrt(n2))  # an array also for a single row (item assignment below)
    bad = ~(n2 < 1e200) | (n2 < 1e-200)  # rows outside the safe range (zero rows stay 0)
    rows = a[bad]
    m = np.max(np.abs(rows), axis=-1, keepdims=True)
    m = np.where(m > 0.0, m, 1.0)
    u = rows / m
    n[bad] = m[..., 0] * np.sqrt(np.sum(u * u, axis=-1))
    return n if n.ndim else n[()]


def as_int(x: object, name: str, minimum: int | None = None) -> int:
    """An integer argument (a count, an index, a size) as a Python int: Python/numpy integers
    and integral floats (``3.0``) pass; bools, fractions, NaN/inf, strings and arrays are
    rejected with a message naming ``name``; ``minimum`` (if given) is the smallest allowed."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer, float, np.floating)):
        raise TypeError(f"{name}: expected an integer, got {type(x).__name__} {x!r}")
    if isinstance(x, (float, np.floating)):
        if not (math.isfinite(x) and float(x).is_integer()):
            raise ValueError(f"{name}: expected an integer, got {x!r}")
    v = int(x)
    if minimum is not None and v < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {v}")
    return v
