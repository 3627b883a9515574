"""The run's log in one allocation (spacecraft._log_memory): disjoint, aligned, C-contiguous
arrays of the asked shapes and dtypes; a compiled run's log arrays are such views, and writing
one leaves the others as they were."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SEED000_J

from liecontrol.control import ConstantAttitude
from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth
from liecontrol.lie import so3
from spacecraft import RigidBody, SgcmgActuator, SingularityRobust, Spacecraft, simulate
from spacecraft._log_memory import carve


def _base(a: np.ndarray) -> np.ndarray:
    while a.base is not None:
        a = a.base
    return a


def test_carved_arrays_have_their_shapes_and_are_disjoint_and_aligned():
    shapes = {
        "a": ((5, 2, 3, 3), np.float64),
        "flags": ((5, 2, 3), np.bool_),
        "empty": ((0, 2, 6), np.float64),
        "b": ((7,), np.float64),
        "c": ((5, 2, 1), np.bool_),
    }
    out = carve(shapes)
    assert list(out) == list(shapes)
    for name, (shape, dtype) in shapes.items():
        a = out[name]
        assert a.shape == shape and a.dtype == np.dtype(dtype), name
        assert a.flags.c_contiguous and a.flags.writeable, name
        assert a.ctypes.data % 64 == 0 or a.size == 0, name
    base = _base(out["a"])
    assert all(_base(a) is base for a in out.values())
    filled = [n for n in out if out[n].size]
    for i, n in enumerate(filled):
        for m in filled[i + 1 :]:
            assert not np.shares_memory(out[n], out[m]), (n, m)
    # every byte of every array can be written without touching another
    out["a"][...] = 1.5
    out["flags"][...] = True
    out["b"][...] = -2.0
    out["c"][...] = False
    assert np.all(out["a"] == 1.5) and np.all(out["flags"]) and np.all(out["b"] == -2.0)
    assert not np.any(out["c"])


def test_negative_dimension_is_named():
    with pytest.raises(ValueError, match="bad"):
        carve({"bad": ((3, -1), np.float64)})


def test_compiled_run_log_is_one_block_of_disjoint_arrays():
    J = SEED000_J
    k_R, k_W = gains_from_bandwidth(J, 0.05, 0.9, matrix=True)
    plant = Spacecraft(RigidBody(J), SgcmgActuator(steering=SingularityRobust()))
    R0 = so3.exp(np.array([[0.4, -0.2, 0.3], [0.1, 0.2, -0.5]]))
    res = simulate(
        plant, GeometricPD(J, k_R, k_W), ConstantAttitude(np.eye(3)),
        plant.initial_state(R0), 5.0, 0.1,
    )  # fmt: skip
    arrays = {
        "R": res.R, "omega": res.omega, "u": res.u, "u_cmd": res.u_cmd,
        "delta": res.actuator["delta"], "saturated": res.actuator["saturated"],
        "h": res.actuator["h"], "e_R": res.controller["e_R"],
    }  # fmt: skip
    base = _base(res.R)
    assert all(_base(a) is base for a in arrays.values())
    before = {k: np.array(v) for k, v in arrays.items()}
    res.R[...] = np.nan
    for k, v in arrays.items():
        if k != "R":
            np.testing.assert_array_equal(v, before[k], err_msg=k)
    assert res.omega.shape == (51, 2, 3)
