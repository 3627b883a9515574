"""Sweep of bad inputs over every ``__all__`` export of every package (issue 12).

For each public callable (function, class constructor and, for the classes listed in
:data:`METHODS`, their main methods) the sweep builds one **valid example call**, then, for each
parameter in turn, replaces the example value by a bad one and classifies what happens:

=====================  =======================================================================
``clear``              ``ValueError``/``TypeError`` whose message starts with the parameter's
                       name (or the documented :class:`spacecraft.SimulationDiverged`)
``ok``                 a finite result for an input that is legitimately valid (huge values,
                       negatives where no sign is required, …)
``unclear``            any other exception, or a message that does not name the parameter
``silent_nan``         the call returned NaN/inf
``silent_meaningless`` the call returned a finite result for an input that can't be right
                       (NaN, inf, complex, a string, an empty or wrongly shaped array, a
                       negative/zero value where positivity is required, …)
``mutated``            an input array/list/dict was changed by the call
``hang``               the case took longer than :data:`CASE_TIMEOUT_S`
=====================  =======================================================================

Design: a **deterministic table of perturbations**, not hypothesis. The interesting inputs are
exactly the boundary values named in the issue (NaN, ±inf, 1e300, 0, −x, 0.5j, ``"abc"``,
``[]``, a wrong trailing shape); random search would only rediscover them, less reliably and at
a cost. A fixed table makes the per-module counts comparable from one commit to the next and
keeps the run time bounded (the whole sweep is ~10⁴ calls).

Example calls are built systematically: a parameter with a default uses the default; otherwise
the example comes from the per-callable :data:`OVERRIDES`, then the per-name table
:data:`NAME_EXAMPLES` (``R`` → a rotation, ``omega`` → a rate vector, ``J`` → an inertia, …),
then the annotation (``float`` → 1.0, ``int`` → 2). Whether a sign is required comes from the
parameter name (:data:`POSITIVE`, :data:`NONNEGATIVE`) and whether a scalar may become an array
from the annotation (``float`` alone: no).

Run ``python tests/test_public_api_sweep.py --summary [prefix ...]`` for the counts per module,
``--details`` to list every non-clean case.
"""

from __future__ import annotations

import copy
import dataclasses
import enum
import importlib
import inspect
import math
import pkgutil
import re
import signal
import sys
import tempfile
import time
import typing
import warnings
from collections import Counter
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

PACKAGES = ("liecontrol", "spacecraft", "benchmarks")
CASE_TIMEOUT_S = 10.0

# outcome classes; the first two are fine
GOOD = ("clear", "ok")
BAD = ("unclear", "silent_nan", "silent_meaningless", "mutated", "hang")

J_EX = np.array([[15053.0, 3000.0, -1000.0], [3000.0, 6510.0, 2000.0], [-1000.0, 2000.0, 11122.0]])
R_EX = np.array(
    [
        [0.36, 0.48, -0.8],
        [-0.8, 0.6, 0.0],
        [0.48, 0.64, 0.6],
    ]
)  # a rotation (orthonormal to round-off, det +1)
G_EX = np.eye(4)
G_EX[:3, :3] = R_EX
G_EX[:3, 3] = [1.0, -2.0, 0.5]
Q_EX = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])


def _spd(n: int) -> np.ndarray:
    return np.eye(n) + 0.1 * np.ones((n, n))


# ---------------------------------------------------------------------------------------------
# example values by parameter name (factories: every case gets fresh objects)
# ---------------------------------------------------------------------------------------------


def _so3():
    from liecontrol.lie import so3

    return so3


def _spacecraft_plant():
    from spacecraft import (
        RigidBody,
        SgcmgActuator,
        SgcmgPyramid,
        SingularityRobust,
        Spacecraft,
    )

    return Spacecraft(RigidBody(J_EX), SgcmgActuator(SgcmgPyramid(), SingularityRobust()))


def _pd_controller():
    from liecontrol.control.geometric_pd import GeometricPD

    return GeometricPD(J_EX, 2.0, 400.0)


def _constant_reference():
    from liecontrol.control import ConstantAttitude

    return ConstantAttitude(np.eye(3))


def _scenario():
    from benchmarks.scenarios import rest_to_rest

    return rest_to_rest(10.0, duration=1.0, dt=0.5, control_period=0.5)


def _sim_result():
    from spacecraft import simulate

    plant = _spacecraft_plant()
    return simulate(
        plant,
        _pd_controller(),
        _constant_reference(),
        plant.initial_state(R_EX),
        t_final=1.0,
        dt=0.5,
    )


def _cluster():
    from spacecraft import SgcmgPyramid

    return SgcmgPyramid()


def _orbit():
    from spacecraft import CircularOrbit

    return CircularOrbit()


def _payload():
    from spacecraft import ROTATING_PAYLOAD_EXAMPLE

    return ROTATING_PAYLOAD_EXAMPLE


def _plates():
    from spacecraft.surface_forces import box_plates

    return box_plates([1.0, 2.0, 1.5], [0.0, 0.0, 0.2])


def _surface_forces_overrides() -> dict[str, dict[str, Callable[[], Any]]]:
    """Examples for the environment torques (spacecraft.surface_forces)."""
    mod = "spacecraft.surface_forces."
    return {
        mod + "Plate": {"area": lambda: 2.0, "normal": lambda: np.array([0.0, 0.6, 0.8])},
        mod + "box_plates": {"size": lambda: np.array([1.0, 2.0, 1.5])},
        mod + "sun_position_au": {"jd": lambda: 2453827.5},
        mod + "in_cylindrical_shadow": {"sun_direction": lambda: np.array([1.0, 0.2, 0.1])},
        mod + "aerodynamic_torque": {
            "plates": _plates,
            "velocity": lambda: np.array([7000.0, 500.0, -200.0]),
            "density": lambda: 1e-12,
        },
        mod + "solar_pressure_torque": {
            "plates": _plates,
            "sun_direction": lambda: np.array([0.3, 0.5, 0.8]),
        },
        mod + "AerodynamicTorque": {"plates": _plates, "orbit": _orbit},
        mod + "SolarPressureTorque": {"plates": _plates, "orbit": _orbit},
        mod + "ResidualDipoleTorque": {
            "dipole": lambda: np.array([1.0, -0.5, 0.2]),
            "orbit": _orbit,
        },
    }


def _spacecraft_spec():
    from benchmarks.scenarios import SpacecraftSpec

    return SpacecraftSpec()


def _tuning_overrides() -> dict[str, dict[str, Callable[[], Any]]]:
    """Examples for the tuning layer (liecontrol.control.tuning, benchmarks' use of it)."""
    try:
        from liecontrol.control.tuning import ActuatorLimits, ClosedLoopSpec
    except ImportError:  # an older tree without the tuning layer (the sweep still runs)
        return {}

    def spec():
        return ClosedLoopSpec(0.05, 0.9, 0.2)

    def pd():
        from liecontrol.control import GeometricPD

        return GeometricPD(np.diag([1.0, 2.0, 3.0]), 0.01, 0.2)

    mod = "liecontrol.control.tuning."
    out: dict[str, dict[str, Callable[[], Any]]] = {
        mod + name: {"spec": spec}
        for name in (
            "tune_geometric_pd",
            "tune_intrinsic_pid",
            "tune_integral_pd",
            "tune_prescribed_performance",
            "tune_mrp_adrc",
            "tune_euler_tsm",
            "tune_quaternion_pd",
            "tune_mrp_pd",
        )
    }
    out[mod + "tune_small_angle_pid"] = {"spec": spec, "J": lambda: np.diag([1.0, 2.0, 3.0])}
    out[mod + "tune_finite_time_so3"] = {
        "spec": spec,
        **{k: (lambda: 0.5) for k in ("r", "rho", "terminal_share")},
        "eps": lambda: 0.05,
        "layer_ratio": lambda: 0.05,
    }
    out[mod + "tune_adaptive_so3"] = {
        "spec": spec,
        "disturbance_bound": lambda: 0.3,
        "frequencies": lambda: [0.0011, 0.0022],
    }
    out[mod + "tune_mpc"] = {"spec": spec, "limits": lambda: ActuatorLimits(1.0)}
    out[mod + "required_actuation"] = {"spec": spec, "step_rotvec": lambda: np.array([0.1, 0, 0])}
    out[mod + "check_actuator"] = {
        "spec": spec,
        "limits": lambda: ActuatorLimits(1e3, 1e3),
        "step_rotvec": lambda: np.array([0.1, 0.0, 0.0]),
    }
    out[mod + "step_peaks"] = {"omega_n": lambda: 0.05, "zeta": lambda: 0.9}
    out[mod + "ClosedLoopSpec"] = {
        "omega_n": lambda: 0.05,
        "zeta": lambda: 0.9,
        "sample_period": lambda: 0.2,
    }
    out[mod + "measure_small_angle_response"] = {
        "controller": pd,
        "J": lambda: np.diag([1.0, 2.0, 3.0]),
        "sample_period": lambda: 0.5,
        "duration": lambda: 30.0,
    }
    return out


NAME_EXAMPLES: dict[str, Callable[[], Any]] = {
    "R": lambda: R_EX.copy(),
    "R_d": lambda: np.eye(3),
    "R0": lambda: R_EX.copy(),
    "R1": lambda: R_EX.copy(),
    "R2": lambda: np.eye(3),
    "R_d0": lambda: np.eye(3),
    "omega": lambda: np.array([0.01, -0.02, 0.03]),
    "omega_d": lambda: np.zeros(3),
    "omega_dot_d": lambda: np.zeros(3),
    "omega0": lambda: np.array([0.01, -0.02, 0.03]),
    "w": lambda: np.array([0.3, -0.2, 0.1]),
    "v": lambda: np.array([0.3, -0.2, 0.1]),
    "phi": lambda: np.array([0.3, -0.2, 0.1]),
    "theta": lambda: np.array([0.3, -0.2, 0.1]),
    "angles": lambda: np.array([0.3, -0.2, 0.1]),
    "torque": lambda: np.array([0.1, -0.2, 0.3]),
    "hdot_cmd": lambda: np.array([0.1, -0.2, 0.3]),
    "u_cmd": lambda: np.array([[0.1, -0.2, 0.3]]),
    "c": lambda: np.array([0.0, 0.6, 0.8]),
    "b1": lambda: np.array([1.0, 0.0, 0.0]),
    "b2": lambda: np.array([0.0, 1.0, 0.0]),
    "r1": lambda: np.array([0.0, 0.0, 1.0]),
    "r2": lambda: np.array([1.0, 0.0, 0.0]),
    "ref1": lambda: np.array([1.0, 0.0, 0.0]),
    "ref2": lambda: np.array([0.0, 1.0, 0.0]),
    "r": lambda: np.array([7.0e6, 1.0e5, -2.0e5]),
    "p": lambda: np.array([0.1, -0.2, 0.05]),
    "q": lambda: Q_EX.copy(),
    "q0": lambda: Q_EX.copy(),
    "q1": lambda: np.array([1.0, 0.0, 0.0, 0.0]),
    "q2": lambda: np.array([1.0, 0.0, 0.0, 0.0]),
    "g": lambda: G_EX.copy(),
    "g0": lambda: G_EX.copy(),
    "g1": lambda: G_EX.copy(),
    "g2": lambda: np.eye(4),
    "g_d": lambda: np.eye(4),
    "g_rel": lambda: np.eye(4),
    "xi": lambda: np.array([0.01, -0.02, 0.03, 0.1, 0.2, -0.1]),
    "xi_d": lambda: np.zeros(6),
    "xi0": lambda: np.array([[0.01, -0.02, 0.03, 0.1, 0.2, -0.1]]),
    "J": lambda: J_EX.copy(),
    "J_plant": lambda: J_EX.copy(),
    "J_ctrl": lambda: J_EX.copy(),
    "true_J": lambda: J_EX.copy(),
    "inertia": lambda: np.diag([1.0, 2.0, 2.5]),
    "m": lambda: 500.0,
    "mass": lambda: 5.0,
    "k_R": lambda: 2.0,
    "k_W": lambda: 400.0,
    "k_Omega": lambda: 400.0,
    "k_I": lambda: 0.1,
    "k_p": lambda: 2.0,
    "k_d": lambda: 400.0,
    "t": lambda: 0.0,
    "t0": lambda: 0.0,
    "dt": lambda: 0.1,
    "h": lambda: 0.1,
    "n": lambda: 0.0011,
    "omega_n": lambda: 0.05,
    "zeta": lambda: 0.7,
    "threshold": lambda: 1.0,
    "delta": lambda: np.array([0.785, -0.785, 0.785, -0.785]),
    "delta_dot": lambda: np.array([0.1, -0.2, 0.3, -0.4]),
    "limit": lambda: 1.0,
    "A": lambda: np.array([[1.0, 0.0, 0.5, 0.1], [0.0, 1.0, 0.2, 0.3], [0.2, 0.1, 1.0, 0.0]]),
    "M": lambda: _spd(3),
    "P": lambda: _spd(3),
    "P0": lambda: _spd(3),
    "Q": lambda: _spd(3),
    "x": lambda: np.array([0.1, -0.2, 0.3]),
    "y": lambda: np.array([0.0, 1.0, 4.0, 9.0]),
    "err": lambda: np.array([10.0, 5.0, 0.5, 0.2]),
    "rng": lambda: np.random.default_rng(0),
    "seq": lambda: "ZYX",
    "coupling": lambda: np.array([[20.0, 3.0, 1.0], [2.0, 15.0, -3.0]]),
    "frequencies": lambda: np.array([0.8, 1.9]),
    "hinge": lambda: np.array([0.0, 0.0, 1.0]),
    "com_offset": lambda: np.array([0.01, 0.0, 0.0]),
    "spin_rate": lambda: 10.0,
    "time_constant": lambda: 0.05,
    "axes": lambda: np.eye(3),
    "plant": _spacecraft_plant,
    "controller": _pd_controller,
    "reference": _constant_reference,
    "cluster": _cluster,
    "orbit": _orbit,
    "source": _payload,
    "scenario": _scenario,
    "spec": _spacecraft_spec,
    "result": _sim_result,
    "angle_deg": lambda: 30.0,
    "scale": lambda: (1.1, 0.9, 1.0),
    # liecontrol.interop.basilisk
    "sigma_BN": lambda: np.array([0.1, -0.2, 0.05]),
    "omega_BN_B": lambda: np.array([0.01, -0.02, 0.03]),
    "dcm": lambda: R_EX.T.copy(),
    "euler_set": lambda: "321",
    "beta": lambda: Q_EX.copy(),
    "prv": lambda: np.array([0.3, -0.2, 0.1]),
    "delta0": lambda: np.array([0.785, -0.785, 0.785, -0.785]),
}

#: parameters whose value must be > 0 (a negative or zero value is invalid)
POSITIVE = frozenset(
    "dt h period control_period m mass n mu h0 time_constant omega_n spin_rate_max"
    " gimbal_rate_limit frequencies lambda0 T duration n_samples chunk_size jobs max_workers"
    " timeout wheel_inertia max_speed rho_inf decay steps log_every max_tries R_e".split()
)
#: parameters whose value must be >= 0
NONNEGATIVE = frozenset(
    "noise_std white_std noise_density bias_rw_std initial_bias_std zeta damping scale_std"
    " axis_std eps epsilon0 mu_sr k_R k_W k_Omega k_I k_p k_d threshold".split()
)

#: free-text string parameters (labels, descriptions): any string is a valid value
FREE_TEXT = frozenset("name description suite notes family source where label title".split())


#: per-callable example overrides: qualified name -> {parameter: factory}
def _formation_overrides() -> dict[str, dict[str, Callable[[], Any]]]:
    def cons():
        return importlib.import_module("liecontrol.control.consensus")

    def form():
        return importlib.import_module("spacecraft.formation")

    def stack(n):
        return lambda: np.stack([R_EX, np.eye(3), R_EX.T][:n])

    gains = {"J": lambda: np.diag([8.0, 10.0, 12.0]), "k_R": lambda: 1.0, "k_Omega": lambda: 2.0}
    small = lambda: form().FormationScenario(  # noqa: E731
        "x", "", "consensus", cons().CommunicationGraph.ring(3), 0.5
    )
    return {
        "liecontrol.control.consensus.CommunicationGraph": {
            "adjacency": lambda: np.ones((3, 3)) - np.eye(3)
        },
        "liecontrol.control.consensus.AttitudeConsensus": {
            "graph": lambda: cons().CommunicationGraph.ring(3),
            **gains,
        },
        "liecontrol.control.consensus.LeaderFollowerConsensus": {
            "graph": lambda: cons().CommunicationGraph.tree([-1, 0, 0]),
            **gains,
        },
        "liecontrol.control.consensus.PoseFormation": {
            "graph": lambda: cons().CommunicationGraph.tree([-1, 0]),
            "relative_poses": lambda: np.stack([np.eye(4)] * 2),
            "tracking": lambda: _pose_pd(),
        },
        "liecontrol.control.consensus.consensus_error": {"R": stack(3)},
        "liecontrol.control.consensus.pairwise_angles": {"R": stack(3)},
        "spacecraft.formation.SpinReference": {
            "R_0": lambda: R_EX.copy(),
            "omega_d": lambda: np.array([0.0, 0.0, 0.01]),
        },
        "spacecraft.formation.FormationScenario": {
            "name": lambda: "x",
            "description": lambda: "",
            "kind": lambda: "consensus",
            "graph": lambda: cons().CommunicationGraph.ring(3),
            "duration": lambda: 1.0,
        },
        "spacecraft.formation.formation_scenario": {"name": lambda: "consensus-ring-6"},
        "spacecraft.formation.run_formation": {"scenario": small},
        "spacecraft.formation.settling_time": {
            "t": lambda: np.array([0.0, 1.0, 2.0]),
            "err": lambda: np.array([3.0, 1.0, 0.1]),
            "tolerance": lambda: 0.5,
        },
        "spacecraft.formation.formation_table": {
            "results": lambda: [form().run_formation(small())]
        },
        "spacecraft.formation.measure_throughput": {
            "n": lambda: 3,
            "steps": lambda: 2,
            "repeats": lambda: 2,
        },
    }


def _cmg_dynamics_overrides() -> dict[str, dict[str, Callable[[], Any]]]:
    mod = "spacecraft.cmg_dynamics."

    def inertias():
        from spacecraft.cmg_dynamics import CmgInertias

        return CmgInertias(0.2, 0.5, (1.0, 1.0, 1.5))

    return {
        mod + "CmgInertias": {"gimbal": lambda: (1.0, 1.0, 1.5)},
        mod + "GimbalStops": {"lower": lambda: -1.0, "upper": lambda: 1.0},
        mod + "VscmgActuator": {
            "bus_inertia": lambda: np.diag([1500.0, 1200.0, 900.0]),
            "inertias": inertias,
        },
        mod + "MiniCmgPreset": {
            "h0": lambda: 0.0165,
            "wheel_spin": lambda: 1.6e-5,
            "wheel_transverse": lambda: 8.3e-6,
            "gimbal": lambda: (1e-5, 1e-5, 1.2e-5),
            "gimbal_rate_limit": lambda: 2.0,
            "gimbal_torque_limit": lambda: 5e-3,
            "beta": lambda: 0.955,
        },
    }


def _fault_overrides() -> dict[str, dict[str, Callable[[], Any]]]:
    """Examples for spacecraft.faults and liecontrol.control.fault_tolerant."""
    mod = "spacecraft.faults."

    def f():
        return importlib.import_module("spacecraft.faults")

    def cmg():
        from spacecraft.actuators import SgcmgActuator

        return SgcmgActuator()

    def stuck():
        return (f().GimbalStuck(1, 1.0),)

    def law():
        from spacecraft.steering import SingularityRobust

        return SingularityRobust()

    def plant():
        from spacecraft.plant import Spacecraft
        from spacecraft.rigid_body import RigidBody

        return Spacecraft(RigidBody(np.diag([1000.0, 1200.0, 900.0])), cmg())

    ft = "liecontrol.control.fault_tolerant."
    return {
        mod + "make_fault": {"kind": lambda: "cmg-gimbal-stuck", "unit": lambda: 1},
        mod + "check_faults": {
            "faults": stuck,
            "actuator": lambda: "sgcmg",
            "n_units": lambda: 4,
            "duration": lambda: 10.0,
        },
        mod + "fault_units": {"faults": stuck, "n_units": lambda: 4},
        mod + "FaultyActuator": {"inner": cmg, "faults": stuck},
        mod + "default_detector": {"actuator": cmg},
        mod + "ReconfiguredSteering": {"law": law, "faults": stuck, "reduced_law": law},
        mod + "reduced_singularity_measure": {
            "cluster": _cluster,
            "delta": lambda: np.array([0.3, -0.8, 1.1, 0.2]),
            "failed": lambda: (1,),
        },
        mod + "singular_fraction": {
            "cluster": _cluster,
            "failed": lambda: (1,),
            "n_samples": lambda: 200,
            "rng": lambda: np.random.default_rng(0),
        },
        mod + "Reconfigurability": {
            "actuator": lambda: "sgcmg",
            "n_units": lambda: 4,
            "remaining": lambda: (0, 2, 3),
            "rank": lambda: 3,
            "three_axis": lambda: True,
            "note": lambda: "3 of 4 gimbals remain",
        },
        mod + "reconfigurability": {"actuator": cmg, "faults": stuck},
        mod + "with_faults": {"plant": plant, "faults": stuck},
        ft + "AdaptiveFaultTolerantSO3": {"K": lambda: 50.0, "lam": lambda: 0.05},
        ft + "fault_tolerant_gains": {"omega_n": lambda: 0.05, "sample_period": lambda: 0.2},
        ft + "inverse_right_jacobian_apply": {
            "x": lambda: np.array([0.3, -0.2, 0.1]),
            "y": lambda: np.array([0.1, 0.2, -0.3]),
        },
    }


def _finite_time_overrides() -> dict[str, dict[str, Callable[[], Any]]]:
    def params(c3=0.1):
        from liecontrol.control.finite_time import FiniteTimeParams

        return FiniteTimeParams(
            k1=0.1, k2=0.02, r=0.5, eps=0.05, c1=0.05, c2=0.01, rho=0.5, eps_s=0.005, c3=c3
        )

    mod = "liecontrol.control.finite_time."
    powers = {"r": lambda: 0.5, "rho": lambda: 0.5, "eps": lambda: 0.05, "mu": lambda: 1.5}
    return {
        mod + "FiniteTimeParams": powers,
        mod + "FiniteTimeSO3": powers,
        mod + "FixedTimeSO3": powers,
        mod + "terminal_gain": {"x": lambda: np.array([0.01, 0.5]), "p": lambda: 0.5, **powers},
        **{
            mod + fn: {"params": params, "theta0": lambda: 1.0, "tol": lambda: 0.01}
            for fn in ("sliding_variable", "sliding_time")
        },
        mod + "angle_decay_rate": {"params": params, "theta": lambda: np.array([0.1, 3.0])},
        # a finite-time law (c3 = 0): s0 = inf is refused there (allowed with c3 > 0)
        **{
            mod + fn: {
                "params": lambda: params(c3=0.0),
                "theta0": lambda: 1.0,
                "tol": lambda: 0.01,
                "s0": lambda: 0.5,
                "s1": lambda: 0.01,
            }
            for fn in ("reaching_time", "convergence_time_bound")
        },
    }


def _small_figure() -> Any:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.0, 2.0))
    fig.add_subplot().plot([0.0, 1.0], [0.0, 1.0])
    return fig


def _orbit_spec() -> Any:
    from benchmarks.scenarios import OrbitSpec

    return OrbitSpec()


def _detumble_law() -> Any:
    from spacecraft.detumble import DetumbleLaw

    return DetumbleLaw(1e-4)


def _cube_normals() -> Any:
    from spacecraft.sun_sensors import CUBE_NORMALS

    return CUBE_NORMALS


def _sun_sensors() -> Any:
    from spacecraft.orbit import CircularOrbit
    from spacecraft.sun_sensors import CoarseSunSensors

    return CoarseSunSensors(CircularOrbit())


def _safe_mode_run() -> Any:
    from benchmarks.safe_mode import SunAcquisitionRun

    one = np.array([100.0])
    return SunAcquisitionRun(
        t=np.array([0.0, 1.0]),
        sun_angle_deg=np.zeros((2, 1)),
        rate_deg_s=np.zeros((2, 1)),
        eclipse=np.array([False, True]),
        time_to_acquire_s=one,
        sun_angle_error_deg=one,
        peak_rate_eclipse_deg_s=one,
        sun_angle_exit_deg=one,
        reacquire_s=one,
        tol_deg=5.0,
        eclipse_entry_s=1.0,
        eclipse_exit_s=2.0,
    )


OVERRIDES: dict[str, dict[str, Callable[[], Any]]] = {
    "benchmarks.figure_layout.layout_problems": {"fig": _small_figure},
    # planned slews and Wie & Lu's eigenaxis law (tests/test_modes.py)
    "liecontrol.control.slew_profile.EigenaxisSlewProfile": {
        "R_start": lambda: R_EX.copy(),
        "R_target": lambda: np.eye(3),
        "max_rate": lambda: 0.02,
        "max_accel": lambda: 5e-4,
        "max_jerk": lambda: 1e-4,
    },
    "liecontrol.control.slew_profile.eigenaxis_accel_limit": {
        "axis": lambda: np.array([1.0, 1.0, 1.0]),
        "max_torque": lambda: 5.0,
    },
    "spacecraft.detumble.separation_tumble": {"n": lambda: 2},
    "benchmarks.controllers.mean_field_squared": {"orbit": lambda: _orbit_spec()},
    "spacecraft.detumble.simulate_detumble": {
        "law": lambda: _detumble_law(),
        "omega0": lambda: np.array([0.1, -0.05, 0.08]),
        "t_final": lambda: 20.0,
        "threshold": lambda: 0.01,
        "dt": lambda: 1.0,
    },
    # safe-mode Sun acquisition (tests/test_sun_acquisition.py)
    "liecontrol.control.sun_acquisition.DirectionMeasurement": {
        "R": lambda: np.eye(3)[None],
        "omega": lambda: np.array([[0.01, -0.02, 0.005]]),
        "direction": lambda: np.array([[0.6, 0.0, 0.8]]),
    },
    "spacecraft.sun_sensors.SunPointingReference": {"sensors": lambda: _sun_sensors()},
    "spacecraft.sun_sensors.SunSensorGyro": {"sensors": lambda: _sun_sensors()},
    "spacecraft.sun_sensors.estimate_sun_vector": {
        "outputs": lambda: np.array([[0.6, 0.0, 0.0, 0.0, 0.8, 0.0]]),
        "normals": lambda: np.array(_cube_normals()),
    },
    "spacecraft.sun_sensors.sun_sensor_coverage": {"normals": lambda: np.array(_cube_normals())},
    "benchmarks.safe_mode.format_table": {"runs": lambda: {"damp": _safe_mode_run()}},
    "benchmarks.detumble_study.DetumbleScenario": {
        "name": lambda: "d",
        "inclination_deg": lambda: 51.6,
    },
    "benchmarks.detumble_study.format_table": {
        "rows": lambda: [
            {
                "scenario": "d",
                "inclination_deg": 51.6,
                "law": "bdot",
                "k": 5e-5,
                "t_median_s": 3280.0,
                "t_min_s": 2570.0,
                "t_max_s": 4730.0,
            }
        ]
    },
    # the gradient-tuning study's building blocks (tests/test_robust_tuning.py)
    "benchmarks.gradient_tuning.training_batch": {"n": lambda: 2, "seed": lambda: 1},
    "benchmarks.gradient_tuning.protocol_controller": {
        "members": lambda: [_scenario()],
    },
    "benchmarks.planned_slews.format_table": {
        "rows": lambda: [
            {"controller": "pd", "variant": "step", "time_to_target_s": 270.0},
            {"controller": "pd", "variant": "planned", "time_to_target_s": 118.0},
        ]
    },
    "liecontrol.control.eigenaxis.RateLimitedEigenaxis": {
        "k": lambda: 0.0018,
        "c": lambda: 0.054,
        "max_rate": lambda: 0.02,
    },
    # adaptive geometric control: gains of the seed-000 bus at ω_n = 0.03 rad/s
    "liecontrol.control.adaptive.AdaptiveGeometricSO3": {
        "k_R": lambda: 7.3,
        "k_s": lambda: 0.05 * J_EX,
        "c": lambda: 0.009,
        "gamma_theta": lambda: 1e7,
        "gamma_phi": lambda: 7.0,
        "frequencies": lambda: [0.0011, 0.0022],
        "disturbance_bound": lambda: 0.3,
    },
    "liecontrol.control.adaptive.inertia_from_parameters": {
        "theta": lambda: np.array([3.0, 2.0, 4.0, 0.1, -0.2, 0.3])
    },
    "liecontrol.control.adaptive.inertia_regressor": {"a": lambda: np.array([0.1, -0.2, 0.3])},
    "liecontrol.control.adaptive.harmonic_regressor": {
        "t": lambda: 10.0,
        "frequencies": lambda: [0.1, 0.2],
    },
    "liecontrol.control.adaptive.disturbance_parameters": {
        "constant": lambda: np.array([0.02, 0.08, 0.02]),
        "sine": lambda: np.array([[0.02, 0.04, 0.02]]),
    },
    "liecontrol.control.adaptive.error_rate_matrix": {"R_tilde": lambda: R_EX.copy()},
    # the singular-transit comparison: a 0.2 s path keeps each call in milliseconds
    "benchmarks.singular_transit.singular_gimbal_angles": {
        "cluster": lambda: _cluster(),
        "u": lambda: np.array([0.3, -0.8, 0.5]),
        "signs": lambda: (1.0, -1.0, 1.0, 1.0),
    },
    "benchmarks.singular_transit.classify_singularity": {
        "cluster": lambda: _cluster(),
        "delta": lambda: np.deg2rad([-90.0, 0.0, 90.0, 0.0]),
    },
    "benchmarks.singular_transit.TransitPath": {
        "name": lambda: "short",
        "delta0_deg": lambda: (60.0, -60.0, 60.0, -60.0),
        "direction": lambda: (0.0, 0.0, 1.0),
    },
    "benchmarks.singular_transit.track_path": {
        "law": lambda: __import__("spacecraft.steering").steering.PseudoInverse(),
        "cluster": lambda: _cluster(),
        "path": lambda: _short_transit_path(),
        "dt": lambda: 0.05,
    },
    "benchmarks.singular_transit.transit_table": {
        "results": lambda: [_short_transit_result()],
        "kinds": lambda: {"short": "elliptic"},
    },
    # 6×6 matrices acting on twists (the generic "M" example is 3×3)
    **{
        f"liecontrol.interop.twist_order.{fn}": {"M": lambda: _spd(6)}
        for fn in ("swap_blocks", "matrix_to_v_omega", "matrix_to_omega_v")
    },
    **{
        f"liecontrol.control.chart_baselines.{cls}": {"K": lambda: 2.0, "P": lambda: 5.0}
        for cls in ("MrpPD", "MrpPDLaw")
    },
    "spacecraft.plant.PlantState": {
        "R": lambda: R_EX[None].copy(),
        "omega": lambda: np.zeros((1, 3)),
        "x_act": lambda: np.zeros((1, 4)),
    },
    "spacecraft.plant.Spacecraft": {
        "body": lambda: __import__("spacecraft").RigidBody(J_EX),
        "actuator": lambda: __import__("spacecraft").IdealTorqueActuator(),
    },
    "spacecraft.rigid_body.perturbed_inertia": {"scale_std": lambda: 0.05},
    # finite/fixed-time sliding mode on SO(3) (liecontrol.control.finite_time, issue 19)
    **_finite_time_overrides(),
    **_fault_overrides(),
    # full CMG dynamics (spacecraft.cmg_dynamics, issue 14)
    **_cmg_dynamics_overrides(),
    # pointing cones (liecontrol.control.constrained, issue 13)
    **{
        f"liecontrol.control.constrained.{cls}": {
            "body_axis": lambda: np.array([0.0, 0.0, 1.0]),
            "inertial_direction": lambda: np.array([1.0, 0.0, 0.0]),
            "half_angle_deg": lambda: 30.0,
        }
        for cls in ("KeepOutCone", "KeepInCone")
    },
    **{
        f"liecontrol.control.constrained.{fn}": {
            "cones": lambda: (
                __import__("liecontrol.control.constrained").control.constrained.KeepOutCone(
                    (0.0, 0.0, 1.0), (1.0, 0.0, 0.0), 30.0
                ),
            )
        }
        for fn in ("cone_margins_deg", "check_admissible")
    },
    # the Gymnasium environments' pure maps and wrappers (spacecraft.envs, issue 16)
    "spacecraft.envs.observations.check_components": {"observation": lambda: ("rotvec", "rate")},
    "spacecraft.envs.observations.observation_size": {
        "components": lambda: ("rotvec", "rate", "actuator"),
        "scales": lambda: __import__("spacecraft.envs").envs.ObservationScales(),
        "n_act": lambda: 4,
    },
    "spacecraft.envs.observations.build_observation": {
        "components": lambda: ("rotvec", "quaternion", "6d", "rate", "momentum", "actuator"),
        "scales": lambda: __import__("spacecraft.envs").envs.ObservationScales(),
        "R": lambda: R_EX[None].copy(),
        "omega": lambda: np.array([[0.01, -0.02, 0.03]]),
        "R_d": lambda: np.eye(3),
        "omega_d": lambda: np.zeros(3),
        "h": lambda: np.array([[1.0, 2.0, 3.0]]),
        "x_act": lambda: np.array([[0.1, -0.2, 0.3, -0.4]]),
    },
    "spacecraft.envs.observations.check_action": {
        "action": lambda: np.array([0.1, -0.2, 0.3]),
        "batch": lambda: None,
    },
    "spacecraft.envs.observations.action_to_torque": {
        "action": lambda: np.array([0.1, -0.2, 0.3]),
        "mode": lambda: "torque",
        "scale": lambda: 10.0,
    },
    "spacecraft.envs.cem.LinearPolicy": {"W": lambda: np.zeros((3, 6))},
    "spacecraft.envs.policy.PolicyController": {"policy": lambda: _zero_policy},
    "benchmarks.policies.policy_factory": {
        "policy": lambda: _zero_policy,
        "config": lambda: __import__("spacecraft.envs").envs.AttitudeEnvConfig(),
    },
    "spacecraft.actuators.ReactionWheelAssembly": {"axes": lambda: np.eye(3)},
    "spacecraft.disturbances.ConstantTorque": {"torque": lambda: np.array([0.1, -0.2, 0.3])},
    "spacecraft.disturbances.SumOfDisturbances": {
        "sources": lambda: {"c": __import__("spacecraft").ConstantTorque(np.ones(3))}
    },
    "spacecraft.environment.GravityGradientTorque": {"orbit": _orbit},
    **_surface_forces_overrides(),
    # momentum management (spacecraft.momentum, spacecraft.geomagnetic)
    "spacecraft.momentum.sgcmg_momentum_capacity": {
        "gimbal_axes": lambda: _cluster().gimbal_axes(),
        "h0": lambda: 300.0,
        "direction": lambda: np.array([0.3, -0.5, 0.8]),
    },
    "spacecraft.momentum.momentum_fraction": {
        "actuator": lambda: __import__("spacecraft").SgcmgActuator(),
        "x_act": lambda: np.array([[0.3, -0.6, 0.8, -0.2]]),
    },
    "spacecraft.momentum.CrossProductDumping": {"orbit": _orbit},
    # dumping feasibility and the growth metric (issue 25)
    **{
        f"spacecraft.momentum.{fn}": {
            "dumping": lambda: __import__("spacecraft.momentum").momentum.CrossProductDumping(
                _orbit()
            ),
            "disturbance": lambda: np.array([0.0, 0.01, 0.0]),
            "attitude": lambda: np.eye(3),
            "n_orbits": lambda: 1.0,
        }
        for fn in ("magnetic_dumping_feasibility", "check_dumping_feasibility")
    },
    "spacecraft.momentum.momentum_growth_per_orbit": {
        "t": lambda: np.linspace(0.0, 200.0, 21),
        "value": lambda: np.linspace(0.1, 0.3, 21),
        "period": lambda: 100.0,
    },
    "spacecraft.thrusters.ThrusterLayout": {
        "positions": lambda: np.array(
            [[0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0]], dtype=float
        ),
        "directions": lambda: np.array(
            [[0, 0, 1], [0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0]], dtype=float
        ),
    },
    "spacecraft.thrusters.ThrusterUnloading": {
        "layout": lambda: __import__("spacecraft.thrusters").thrusters.ThrusterLayout.pairs(1.0)
    },
    "spacecraft.steering.StopAware": {
        "law": lambda: __import__("spacecraft").SingularityRobust(),
        "lower": lambda: -1.0,
        "upper": lambda: 1.0,
    },
    "spacecraft.orbit.EarthPointingReference": {"orbit": _orbit},
    "spacecraft.payload.RotatingPayload": {"inertia": lambda: np.diag([1.0, 1.0, 1.5])},
    "spacecraft.payload.RotatingPayloadTorque": {"payloads": lambda: (_payload(),)},
    "spacecraft.payload.jitter_estimate": {"omega_n": lambda: 0.05, "zeta": lambda: 0.7},
    **_tuning_overrides(),
    "spacecraft.se3_plant.SE3Plant": {"J": lambda: np.diag([300.0, 400.0, 350.0])},
    # formations (liecontrol.control.consensus, spacecraft.formation)
    **_formation_overrides(),
    "spacecraft.se3_plant.DockingReference": {
        "target": lambda: __import__("spacecraft").OrbitingTarget(),
    },
    "spacecraft.se3_plant.simulate_pose": {
        "plant": lambda: __import__("spacecraft").SE3Plant(500.0, np.diag([300.0, 400.0, 350.0])),
        "controller": lambda: _pose_pd(),
        "reference": lambda: __import__("spacecraft").DockingReference(
            __import__("spacecraft").OrbitingTarget(), np.eye(4)
        ),
        "g0": lambda: _docking_g0(),
        "xi0": lambda: _docking_xi0(),
        "t_final": lambda: 2.0,
        "dt": lambda: 1.0,
    },
    "spacecraft.simulator.simulate": {
        "initial_state": lambda: _spacecraft_plant().initial_state(R_EX),
        "t_final": lambda: 1.0,
        "dt": lambda: 0.5,
    },
    "spacecraft.simulator.SimulationDiverged": {},
    "spacecraft.sensors.TwoVectorAttitude": {},
    "spacecraft.sensors.TimedSensor": {
        "sensor": lambda: __import__("spacecraft.sensors").sensors.StarTracker()
    },
    "spacecraft.steering.saturate_gimbal_rates": {},
    "spacecraft.steering.singularity_robust_inverse": {"lam": lambda: 0.01},
    "spacecraft.mpc_constraints.steering_map": {
        "law": lambda: __import__("spacecraft").SingularityRobust(),
    },
    "spacecraft.payload.harmonic_phasor": {"payload": _payload},
    "spacecraft.payload.closed_loop_gain": {
        "J_jj": lambda: 1000.0,
        "omega": lambda: np.array([1.0, 2.0]),
    },
    "benchmarks.metrics.compute_metrics": {"result": _sim_result},
    "benchmarks.ranking.wilson_interval": {"k": lambda: 3, "n": lambda: 8},
    "liecontrol.control.kernel.resolve": {"controller": _pd_controller, "batch_size": lambda: 2},
    "spacecraft.disturbance_kernel.sum_kernel": {
        "parts": lambda: [
            ("bias", __import__("spacecraft").ConstantTorque(np.array([0.0, 0.1, 0.0]))),
            ("harmonic", __import__("spacecraft").ConstantHarmonicTorque()),
        ]
    },
    "spacecraft.disturbance_kernel.resolve": {
        "dist": lambda: __import__("spacecraft").ConstantTorque(np.array([0.0, 0.1, 0.0]))
    },
    "benchmarks.tuning_report.not_equivalent": {"response": lambda: {"overshoot_pct": 1.0}},
    "benchmarks.ranking.cell_verdict": {"k": lambda: 3, "n": lambda: 8},
    "benchmarks.dispersion.member_scenarios": {"scenario": _scenario, "n": lambda: 2},
    "benchmarks.requirements.Requirement": {"metric": lambda: "rpe_deg", "limit": lambda: 0.1},
    "benchmarks.requirements.pointing_errors": {
        "t": lambda: np.arange(0.0, 21.0),
        "e": lambda: np.zeros((21, 1, 3)),
        "window_s": lambda: 5.0,
        "start": lambda: 10.0,
    },
    "benchmarks.requirements.meets": {
        "requirements": lambda: (
            __import__("benchmarks.requirements").requirements.Requirement("overshoot_pct", 10.0),
        ),
        "metrics": lambda: {"overshoot_pct": 5.0},
    },
    "benchmarks.results_file.history_arrays": {"result": _sim_result},
    "benchmarks.results_file.history_unit": {"name": lambda: "R"},
    "benchmarks.metrics.error_angle": {"R": lambda: R_EX[None], "R_d": lambda: np.eye(3)[None]},
    "benchmarks.metrics.rate_error": {
        "R": lambda: R_EX[None],
        "R_d": lambda: np.eye(3)[None],
        "omega": lambda: np.array([[0.1, 0.0, 0.0]]),
        "omega_d": lambda: np.zeros((1, 3)),
    },
    "benchmarks.metrics.trapezoid": {
        "y": lambda: [0.0, 1.0, 4.0, 9.0],
        "t": lambda: [0.0, 1.0, 2.0, 3.0],
    },
    "benchmarks.metrics.settling_time": {
        "t": lambda: [0.0, 1.0, 2.0, 3.0],
        "err": lambda: [10.0, 5.0, 0.5, 0.2],
    },
    "benchmarks.runner.run_suite": {
        "scenarios": lambda: [_scenario()],
        "controllers": lambda: ["geometric-pd-large-angle"],
        "jobs": lambda: 1,
    },
    "benchmarks.runner.initial_state": {"scenario": _scenario},
    "benchmarks.runner.build_reference": {"spec": lambda: _scenario().reference},
    "benchmarks.runner.build_plant": {"spec": _spacecraft_spec},
    "benchmarks.runner.build_actuator": {"spec": _spacecraft_spec},
    "benchmarks.runner.build_steering": {"spec": _spacecraft_spec},
    "benchmarks.runner.build_disturbance": {"specs": lambda: ()},
    "benchmarks.runner.ConstantRateReference": {"omega_d": lambda: np.array([0.0, 0.0, 0.01])},
    "benchmarks.runner.HeldController": {"inner": _pd_controller, "period": lambda: 0.5},
    "benchmarks.runner.TimedController": {"inner": _pd_controller},
    "benchmarks.scenarios.scale_principal_moments": {"scale": lambda: (1.1, 0.9, 1.0)},
    "benchmarks.scenarios.Scenario": {
        "name": lambda: "sweep-example",
        "description": lambda: "an example",
    },
    "benchmarks.scenarios.get_scenario": {"name": lambda: "slew-90"},
    "benchmarks.scenarios.get_suite": {"name": lambda: "quick"},
    "benchmarks.controllers.make_controller": {
        "name": lambda: "geometric-pd-large-angle",
        "ctx": _spacecraft_spec,
    },
    "benchmarks.controllers.get_controller": {"name": lambda: "geometric-pd-large-angle"},
    "benchmarks.controllers.geometric_pd_factory": {"error": lambda: "large_angle"},
    "benchmarks.controllers.applicable": {
        "scenario": _scenario,
        "names": lambda: ("geometric-pd-large-angle",),
    },
    "benchmarks.controllers.actuator_limits": {"spacecraft": _spacecraft_spec},
    "benchmarks.controllers.spec_for": {"ctx": lambda: _controller_context()},
    "benchmarks.controllers.tuned_spec": {"ctx": lambda: _controller_context()},
    "benchmarks.controllers.ControllerInfo": {
        "name": lambda: "sweep-pd",
        "factory": lambda: __import__("benchmarks.controllers").controllers.geometric_pd_factory(
            "log"
        ),
    },
    "benchmarks.runner.StackedController": {
        "members": lambda: [_pd_controller(), _pd_controller()],
        "sizes": lambda: [1, 2],
    },
    "benchmarks.runner.StackedReference": {
        "references": lambda: [_constant_reference(), _constant_reference()],
        "sizes": lambda: [1, 2],
    },
    "benchmarks.runner.build_sensors": {
        "spec": lambda: __import__("benchmarks.scenarios").scenarios.SensorSpec()
    },
    "benchmarks.runner.FilteredAttitude": {
        "spec": lambda: __import__("benchmarks.scenarios").scenarios.SensorSpec(estimator="mekf")
    },
    "benchmarks.montecarlo.chunk_samples": {
        "cfg": lambda: __import__("benchmarks.montecarlo").montecarlo.MonteCarloConfig(
            n_samples=4, chunk_size=2
        ),
        "chunk": lambda: 1,
    },
    "benchmarks.scenarios.Suite": {
        "name": lambda: "sweep",
        "description": lambda: "a suite",
        "scenarios": lambda: (_scenario(),),
    },
    "benchmarks.tuning_report.describe_tuning": {"controller": _pd_controller},
    "benchmarks.controllers.ControllerContext": {
        "spacecraft": _spacecraft_spec,
        "control_period": lambda: 0.5,
    },
    "benchmarks.executors.make_executor": {"kind": lambda: "serial"},
    "benchmarks.scenario_files.scenario_from_dict": {
        "table": lambda: {
            "name": "s",
            "description": "d",
            "duration": 1.0,
            "dt": 0.5,
            "control_period": 0.5,
            "initial": {"angle_deg": 10.0, "axis": [1.0, 0.0, 0.0]},
        }
    },
    "benchmarks.scenario_files.scenarios_from_dict": {
        "data": lambda: {
            "scenario": [
                {
                    "name": "s",
                    "description": "d",
                    "duration": 1.0,
                    "dt": 0.5,
                    "control_period": 0.5,
                }
            ]
        }
    },
    "benchmarks.scenario_files.scenario_to_dict": {"scenario": _scenario},
    "benchmarks.report.fmt": {"x": lambda: 1.5},
    "benchmarks.report.markdown_table": {
        "header": lambda: ["a", "b"],
        "rows": lambda: [["1", "2"]],
    },
}


def _controller_context():
    from benchmarks.controllers import ControllerContext

    return ControllerContext(_spacecraft_spec(), 0.5)


def _pose_pd():
    from liecontrol.control.se3_control import BulloMurrayPD

    return BulloMurrayPD(500.0, np.diag([300.0, 400.0, 350.0]), 5.0, 0.1, 300.0, 10.0)


def _docking_g0():
    from spacecraft import DockingReference, OrbitingTarget

    ref = DockingReference(OrbitingTarget(), np.eye(4))
    return ref.offset_state(0.0, np.zeros((1, 3)), np.zeros((1, 3)))[0]


def _docking_xi0():
    from spacecraft import DockingReference, OrbitingTarget

    ref = DockingReference(OrbitingTarget(), np.eye(4))
    return ref.offset_state(0.0, np.zeros((1, 3)), np.zeros((1, 3)))[1]


def _short_transit_path() -> Any:
    """A 0.2 s singular-transit path (benchmarks.singular_transit) for the sweep."""
    from benchmarks.singular_transit import TransitPath

    return TransitPath("short", (60.0, -60.0, 60.0, -60.0), (0.0, 0.0, 1.0), duration=0.2)


def _short_transit_result() -> Any:
    """One TransitResult of :func:`_short_transit_path` under the pseudo-inverse."""
    from benchmarks.singular_transit import track_path
    from spacecraft.steering import PseudoInverse

    return track_path(PseudoInverse(), _cluster(), _short_transit_path(), 0.05)


def _zero_policy(obs: np.ndarray) -> np.ndarray:
    """A policy ``obs -> action`` for the sweep (spacecraft.envs): the zero action."""
    return np.zeros((np.shape(obs)[0], 3))


#: methods swept on an instance built from the class's example call: qualified class name ->
#: {method: {parameter: factory}} (parameters not listed come from the tables above)
METHODS: dict[str, dict[str, dict[str, Callable[[], Any]]]] = {
    **{
        f"spacecraft.steering.{law}": {
            "__call__": {
                "A": lambda: _cluster().jacobian(np.array([0.785, -0.785, 0.785, -0.785])),
                "hdot_cmd": lambda: np.array([0.1, -0.2, 0.3]),
                "delta": lambda: np.array([0.785, -0.785, 0.785, -0.785]),
                "cluster": _cluster,
            }
        }
        for law in (
            "PseudoInverse",
            "PseudoInverseNullMotion",
            "SingularityRobust",
            "GeneralizedSingularityRobust",
            "LocalGradient",
            "SingularDirectionAvoidance",
        )
    },
    "spacecraft.sgcmg.SgcmgPyramid": {
        "jacobian": {},
        "momentum": {},
        "singularity_measure": {},
    },
    "spacecraft.actuators.SgcmgActuator": {
        "command": {
            "u_cmd": lambda: np.array([[0.1, -0.2, 0.3]]),
            "omega": lambda: np.zeros((1, 3)),
            "x_act": lambda: np.array([[0.785, -0.785, 0.785, -0.785]]),
        }
    },
    "spacecraft.cmg_dynamics.VscmgActuator": {
        "command": {
            "u_cmd": lambda: np.array([[0.1, -0.2, 0.3]]),
            "omega": lambda: np.zeros((1, 3)),
            "x_act": lambda: (
                __import__("spacecraft.cmg_dynamics")
                .cmg_dynamics.VscmgActuator(
                    np.diag([1500.0, 1200.0, 900.0]),
                    __import__("spacecraft.cmg_dynamics").cmg_dynamics.CmgInertias(
                        0.2, 0.5, (1.0, 1.0, 1.5)
                    ),
                )
                .initial_state(1)
            ),
        },
        "open_loop": {"gimbal_torque": lambda: np.array([[0.1, -0.1, 0.2, 0.0]])},
    },
    "spacecraft.actuators.ReactionWheelAssembly": {
        "command": {
            "u_cmd": lambda: np.array([[0.01, -0.02, 0.03]]),
            "omega": lambda: np.zeros((1, 3)),
            "x_act": lambda: np.zeros((1, 3)),
        }
    },
    "spacecraft.rigid_body.RigidBody": {
        "angular_acceleration": {"torque": lambda: np.array([0.1, -0.2, 0.3])},
        "kinetic_energy": {},
    },
    "spacecraft.flexible.FlexibleModes": {"schur_inertia": {}, "free_free_frequencies": {}},
    "spacecraft.orbit.CircularOrbit": {"position": {}, "lvlh_attitude": {}},
    "spacecraft.disturbances.ConstantHarmonicTorque": {"torque_at": {}},
    "spacecraft.payload.RotatingPayload": {"torque": {}},
    "spacecraft.sensors.StarTracker": {
        "measure": {"R": lambda: R_EX[None].copy(), "omega": lambda: np.zeros((1, 3))}
    },
    "spacecraft.sensors.TimedSensor": {
        "measure": {"R": lambda: R_EX[None].copy(), "omega": lambda: np.zeros((1, 3))}
    },
    "spacecraft.plant.Spacecraft": {
        "initial_state": {"R0": lambda: R_EX.copy()},
    },
    "spacecraft.se3_plant.SE3Plant": {
        "gravity_wrench": {"g": lambda: _docking_g0()},
        "energy": {"g": lambda: _docking_g0(), "xi": lambda: _docking_xi0()},
    },
}

#: callables not swept, with the reason
NOT_SWEPT: dict[str, str] = {
    "spacecraft.faults.Reconfigurability": "a result record built by reconfigurability "
    "(which is swept)",
    "spacecraft.momentum.DumpingFeasibility": "a result record built by "
    "magnetic_dumping_feasibility (which is swept)",
    "spacecraft.faults.ActuatorFault": "the abstract base of the four fault kinds (it refuses "
    "to be instantiated, tested in test_faults); the kinds themselves are swept",
    "benchmarks.cli.main": "the command line; its errors are tested in test_benchmarks_cli",
    "spacecraft.formation.plot_formation": "writes a figure of a FormationResult (tested in "
    "test_formation)",
    "spacecraft.formation.FormationResult": "a result record built by run_formation",
    "benchmarks.runner.run_group": "an executor task payload built by run_suite, not user input",
    "benchmarks.montecarlo.run_chunk": "an executor task payload built by run_montecarlo",
    "benchmarks.montecarlo.run_montecarlo": "runs a Monte Carlo campaign (seconds per call); "
    "its arguments are validated by MonteCarloConfig, which is swept",
    "benchmarks.montecarlo.measure_throughput": "a timing run (seconds per call)",
    "benchmarks.results_file.write_histories": "writes a file from a suite/Monte Carlo result; "
    "its bad input (format, path, result) is tested in test_results_file",
    "benchmarks.results_file.write_histories_with_report": "the CLI's wrapper of "
    "write_histories (tested in test_results_file)",
    "benchmarks.results_file.load_histories": "reads a file; missing, foreign and corrupt files "
    "are tested in test_results_file",
    "benchmarks.results_file.provenance": "takes a suite/Monte Carlo result (tested in "
    "test_results_file)",
    "benchmarks.results_file.Histories": "a loaded file's container, built by load_histories",
    "benchmarks.results_file.RunHistory": "one run of a loaded file, built by load_histories",
    "benchmarks.unwinding.run_unwinding": "runs the unwinding campaign (seconds per call); its "
    "arguments are validated by UnwindingConfig, which is swept",
    "benchmarks.perf_lie.run": "a timing run",
    "benchmarks.perf_lie.main": "a timing script entry point",
    "benchmarks.gradient_tuning.main": "the command line (parses sys.argv; minutes per run)",
    "spacecraft.robust_tuning.RobustTuningResult": "a result record built by tune_requirements",
    "spacecraft.robust_tuning.tune_requirements": "needs JAX and a compiled JaxClosedLoop "
    "(seconds per call); its bad input is tested in test_robust_tuning",
    "benchmarks.gradient_tuning.tune_scenario": "tunes over a 600 s scenario (a minute per "
    "call); its parts are swept (training_batch, scenario_requirements) or tested in "
    "test_robust_tuning (tune_requirements' bad input)",
    "benchmarks.gradient_tuning.held_out_cells": "runs the suite on a scenario (seconds per "
    "call; tested in test_robust_tuning)",
    "benchmarks.singular_transit.main": "the command line (parses sys.argv; seconds per run)",
    "benchmarks.planned_slews.main": "the command line (parses sys.argv; minutes per run)",
    "benchmarks.constraint_margins.main": "the command line (parses sys.argv; minutes per run)",
    "benchmarks.constraint_margins.MarginCell": "a result record built by run_cell",
    "benchmarks.constraint_margins.write_csv": "writes margin_grid's cells (tested in "
    "test_constraint_margins)",
    "benchmarks.constraint_margins.plot": "draws margin_grid's cells (tested in "
    "test_constraint_margins)",
    "benchmarks.runner.detumble_inputs": "the runner's detumble step, fed by run_suite (tested "
    "against a direct simulate_detumble call in test_detumble_suite)",
    "benchmarks.runner.detumble_metrics": "the runner's detumble step on a DetumbleResult "
    "(tested in test_detumble_suite)",
    "benchmarks.constraint_margins.margin_grid": "runs laws × rates × periods (minutes); its "
    "bad input and a 2×2 grid are tested in test_constraint_margins",
    "benchmarks.constraint_margins.run_cell": "flies one 120 s closed loop (seconds per call); "
    "tested against a direct simulation in test_constraint_margins",
    "spacecraft.detumble.DetumbleResult": "a log container built by simulate_detumble",
    "benchmarks.safe_mode.main": "the command line (parses sys.argv; seconds per run)",
    "benchmarks.detumble_study.main": "the command line (parses sys.argv; a minute per run)",
    "benchmarks.detumble_study.detumble_table": "runs scenarios × gains × laws (seconds per "
    "call); its bad input is tested in test_modes",
    "benchmarks.safe_mode.sun_acquisition_run": "flies the safe-mode scenario (seconds per "
    "call); its bad input is tested in test_sun_acquisition",
    "benchmarks.safe_mode.SunAcquisitionRun": "a result record built by sun_acquisition_run",
    "benchmarks.planned_slews.planned_vs_step": "runs two scenarios × every controller (minutes)",
    "benchmarks.singular_transit.run_comparison": "runs the whole comparison (seconds per call); "
    "its laws argument is tested in test_steering_laws, the rest is swept via track_path",
    "benchmarks.singular_transit.TransitResult": "a result record built by track_path",
    "benchmarks.perf_estimation.time_filters": "a timing run",
    "benchmarks.perf_estimation.main": "a timing script entry point",
    "benchmarks.executors.DaskExecutor": "needs a dask scheduler (tested in test_montecarlo)",
    "spacecraft.mpc_constraints.stack_constraints": "variadic (*constraints): no named argument",
    # global registries: a sweep would register junk process-wide (tested in test_scenarios,
    # test_cli_extend)
    "benchmarks.scenarios.register_scenario": "mutates the global scenario registry",
    "benchmarks.scenarios.unregister_scenario": "mutates the global scenario registry",
    "benchmarks.controllers.register": "mutates the global controller registry",
    "benchmarks.controllers.unregister": "mutates the global controller registry",
    "benchmarks.cli.load_plugins": "imports user modules (a side effect by design)",
    "benchmarks.tuning_report.measure_registered": "runs a closed-loop tuning measurement",
    "benchmarks.tuning_report.tuning_section": "measures every registered controller",
    "liecontrol.control.tuning.measure_small_angle_response": "runs a closed-loop simulation; "
    "NB warmup=1e300 hangs (no bound on the horizon): reported, left to the module's owner",
    "liecontrol.control.tuning.SmallAngleResponse": "a result record (the measurement's output)",
    # writers of a finished campaign's report: their input is a result the library built
    **{
        name: "writes the report of a finished run (its input is a result record)"
        for name in (
            "benchmarks.report.write_report",
            "benchmarks.report.write_csv",
            "benchmarks.report.write_json",
            "benchmarks.report.write_figures",
            "benchmarks.report.figures_section",
            "benchmarks.montecarlo.write_montecarlo_report",
            "benchmarks.montecarlo.read_journal",
            "benchmarks.unwinding.write_unwinding_report",
            "benchmarks.unwinding.verdict",
            "benchmarks.runner.with_verdict",
            "benchmarks.metrics.judge",
        )
    },
    "spacecraft.envs.cem.train_cem": "a training run (seconds per call); its argument checks "
    "are tested in test_envs",
    "spacecraft.envs.cem.episode_returns": "rollouts of a vector environment (seconds per call)",
    "spacecraft.envs.cem.CemResult": "a result record the library builds and returns",
    "benchmarks.policies.register_policy": "mutates the global controller registry",
    "benchmarks.policies.compare_policy": "runs benchmark simulations (seconds per call); "
    "tested in test_envs",
    "spacecraft.payload.fit_payload_imbalance": "a least-squares fit that needs a reachable "
    "target; its argument checks are tested in test_payload",
    # result records: built by the library from validated inputs and returned, never passed in
    **{
        name: "a result record the library builds and returns (not an input)"
        for name in (
            "spacecraft.actuators.CmgCommand",
            "spacecraft.cmg_dynamics.VscmgCommand",
            "spacecraft.actuators.WheelCommand",
            "spacecraft.sensors.GyroState",
            "spacecraft.simulator.SimulationResult",
            "spacecraft.se3_plant.PoseSimulationResult",
            "spacecraft.payload.JitterEstimate",
            "benchmarks.metrics.Metrics",
            "benchmarks.runner.RunOutcome",
            "benchmarks.runner.SuiteResult",
            "benchmarks.montecarlo.ChunkSamples",
            "benchmarks.montecarlo.MonteCarloResult",
            "benchmarks.unwinding.UnwindingRecord",
            "benchmarks.unwinding.UnwindingResult",
            "benchmarks.perf_lie.PerfRow",
            "benchmarks.executors.TaskFailure",
            "benchmarks.ranking.CellSummary",
        )
    },
    "liecontrol.control.kernel.check": "needs a compiled @njit law; its argument checks (law, "
    "params, state, signature) are tested in test_kernel_seam",
    "liecontrol.control.kernel.ControllerKernel": "a record built by a controller's "
    "fused_kernel() and validated by kernel.check (tested in test_kernel_seam)",
    "spacecraft.steering_kernel.SteeringKernel": "a record built by a steering law's "
    "fused_kernel() and validated by steering_kernel.check (tested in test_steering_kernel)",
    "spacecraft.steering_kernel.resolve": "needs a steering law with a compiled @njit kernel; "
    "its checks (kernel, params, signature, non-finite rates, the owner rule) are tested in "
    "test_steering_kernel",
    "spacecraft.disturbance_kernel.check": "needs a compiled @njit torque; its argument checks "
    "(torque, params, signature, non-finite torque) are tested in test_disturbance_kernel",
    "spacecraft.disturbance_kernel.DisturbanceKernel": "a record built by a disturbance's "
    "fused_kernel() and validated by disturbance_kernel.check (test_disturbance_kernel)",
    "spacecraft.disturbance_kernel.no_torque": "a compiled kernel (no validation by design: "
    "liecontrol._jit); the loop's placeholder torque",
    "spacecraft.environment.gravity_gradient_kernel": "a compiled kernel (no validation by "
    "design: liecontrol._jit); held to GravityGradientTorque in test_disturbance_kernel",
    **{
        f"spacecraft.surface_forces.{name}_kernel": "a compiled kernel (no validation by design: "
        "liecontrol._jit); held to its source's __call__ in test_surface_force_kernels"
        for name in ("aerodynamic", "solar_pressure", "residual_dipole")
    },
    # report sections over a whole SuiteResult: their argument check (a SuiteResult, named
    # ``result``) is tested in test_dispersion_ranking; a call runs simulations (seconds)
    **{
        name: "a report section over a SuiteResult (runs step responses or timings)"
        for name in (
            "benchmarks.controller_cost.cost_section",
            "benchmarks.controller_cost.controller_cost",
            "benchmarks.ranking_report.dispersion_section",
            "benchmarks.ranking_report.not_equivalent_controllers",
            "benchmarks.ranking_report.alias_groups",
            "benchmarks.ranking_report.suite_aliases",
            "benchmarks.ranking_report.dealiased",
            "benchmarks.ranking_report.verdict_changes",
            "benchmarks.ranking.summarise_cell",
            "benchmarks.ranking.rank_cells",
            "benchmarks.ranking.find_aliases",
            "benchmarks.tuning_report.step_response",
            "benchmarks.runner.bandwidth_sensitivity",
        )
    },
}

#: module-name prefixes not swept, with the reason (the sweep must run in about a minute)
NOT_SWEPT_MODULES: dict[str, str] = {
    "benchmarks.reproductions": "paper reproductions: each export runs a whole reproduction "
    "(seconds to minutes per call); their options are tested in test_seed00x and the CLI tests",
    "benchmarks.perf_": "timing scripts (benchmarks.perf_*), not library API",
    "benchmarks.finite_time_study": "a study script: every call runs minutes of closed-loop "
    "simulation; its arguments are validated and tested in test_finite_time",
    "spacecraft.differentiable": "the optional JAX route: needs the [jax] extra (not installed "
    "in CI) and compiles a program per call (seconds); its bad input is tested in "
    "test_jax_route",
    "benchmarks.cmg_model_study": "a study script: run_study/main run minutes of closed-loop "
    "simulation; study_scenarios' bad input is tested in test_cmg_model_option",
}

#: (qualified name, parameter, perturbation) that is legitimately accepted, with the reason
ACCEPTED: dict[tuple[str, str, str], str] = {
    ("liecontrol.control.adaptive.harmonic_regressor", "frequencies", "empty"): "no harmonic: "
    "the constant-only model Φ = I₃",
    ("liecontrol.control.adaptive.AdaptiveGeometricSO3", "frequencies", "empty"): "no harmonic: "
    "a constant disturbance only",
    ("liecontrol.control.tuning.tune_adaptive_so3", "frequencies", "empty"): "as "
    "AdaptiveGeometricSO3",
    **{
        (f"spacecraft.faults.{fn}", "failed", "empty"): "no gimbal lost: the healthy cluster"
        for fn in ("reduced_singularity_measure", "singular_fraction")
    },
    ("liecontrol.charts.quaternion.slerp", "t", "empty"): "an empty batch of times gives an "
    "empty batch of quaternions",
    ("liecontrol.estimation.cholesky.tria", "A", "wrong_shape"): "triangularisation takes any "
    "(n, m) factor",
    ("liecontrol.estimation.stukf.FadingState", "steps", "zero"): "0 steps is the initial "
    "state (the default)",
    ("spacecraft.simulator.StarTrackerGyro", "attitude", "unknown_name"): "any identifier names "
    "a sensor; simulate() checks it against the sensors it is given",
    ("spacecraft.simulator.StarTrackerGyro", "rate", "unknown_name"): "as attitude",
    ("spacecraft.steering.pseudo_inverse", "A", "wrong_shape"): "A is (..., 3, n) for any n",
    ("spacecraft.envs.cem.LinearPolicy", "W", "wrong_shape"): "W is (3, n_obs) for any "
    "observation size",
    ("spacecraft.envs.observations.build_observation", "h", "negative"): "h is the actuator "
    "momentum (a signed vector), not a step size",
    ("spacecraft.envs.observations.build_observation", "h", "zero"): "as negative",
    ("spacecraft.actuators.ReactionWheelAssembly", "axes", "wrong_shape"): "(3, N), any N >= 3",
    ("spacecraft.momentum.sgcmg_momentum_capacity", "gimbal_axes", "wrong_shape"): "(3, n) for "
    "any number n of units",
    **{
        ("benchmarks.metrics.settling_time", p, pert): "documented: NaN when the error never "
        "settles below the threshold"
        for p, pert in (("err", "huge"), ("threshold", "negative"), ("threshold", "zero"))
    },
    ("spacecraft.formation.settling_time", "err", "huge"): "documented: NaN when the error "
    "never settles below the tolerance",
    ("benchmarks.report.fmt", "x", "nan"): "formats a table cell: NaN is printed as 'n/a'",
    ("benchmarks.report.fmt", "x", "inf"): "formats a table cell: inf is printed as such",
    ("benchmarks.scenarios.rest_to_rest", "name", "wrong_type"): "'abc' is a valid name",
    ("benchmarks.cli.build_parser", "prog", "wrong_type"): "'abc' is a valid program name",
    ("benchmarks.cli.program_name", "argv0", "wrong_type"): "'abc' is a valid argv[0]",
    ("benchmarks.unwinding.UnwindingConfig", "sweep_angles_deg", "empty"): "no sweep cases is a "
    "valid configuration (pair and random cases only)",
    ("benchmarks.unwinding.UnwindingConfig", "sweep_angles_deg", "wrong_shape"): "one more angle",
    ("liecontrol.lie.so3.validate", "name", "unknown_name"): "name: the label used in messages",
    ("liecontrol.lie.se3.validate", "name", "unknown_name"): "as so3.validate",
    ("spacecraft.plant.PlantState", "x_act", "wrong_shape"): "(B, n) for an actuator with any "
    "n states; Spacecraft.check_state matches n to the plant",
    ("spacecraft.sensors.TwoVectorAttitude", "noise_std", "wrong_shape"): "a pair of stds, one "
    "per vector, is documented",
    ("spacecraft.payload.RotatingPayload", "mass", "zero"): "a balanced rotor (no CoM offset "
    "effect): only the inertia imbalance acts",
    ("spacecraft.payload.jitter_estimate", "omega_n", "zero"): "documented: no control",
    ("spacecraft.payload.closed_loop_gain", "omega_n", "zero"): "documented: the open loop",
    ("spacecraft.payload.closed_loop_gain", "omega", "empty"): "omega: any array of "
    "frequencies (an empty one gives an empty gain)",
    ("spacecraft.payload.closed_loop_gain", "omega", "wrong_shape"): "as empty",
    **{
        (name, "t", "empty"): "t: scalar or an array of times; an empty array is an empty batch"
        for name in (
            "spacecraft.payload.RotatingPayload.torque",
            "spacecraft.orbit.CircularOrbit.position",
            "spacecraft.orbit.CircularOrbit.lvlh_attitude",
        )
    },
    ("spacecraft.steering.jacobian_singularity_measure", "A", "wrong_shape"): "as pseudo_inverse",
    ("liecontrol.control.finite_time.terminal_gain", "x", "wrong_shape"): "x: elementwise, "
    "a 1-D array of any length",
    ("liecontrol.control.finite_time.angle_decay_rate", "theta", "empty"): "theta: elementwise "
    "h(θ), an empty array of angles gives an empty array of rates",
    ("liecontrol.control.finite_time.angle_decay_rate", "theta", "wrong_shape"): "as empty",
    ("spacecraft.steering.singularity_robust_inverse", "A", "wrong_shape"): "as pseudo_inverse",
    ("spacecraft.steering.saturate_gimbal_rates", "delta_dot", "wrong_shape"): "(..., n), any n",
    **{
        (f"spacecraft.steering.{law}.__call__", p, pert): reason
        for law in (
            "PseudoInverse",
            "SingularityRobust",
            "GeneralizedSingularityRobust",
            "SingularDirectionAvoidance",
        )
        for p, pert, reason in (
            ("A", "wrong_shape", "A is (..., 3, n) for any number n of gimbals"),
        )
    },
    **{
        (f"spacecraft.steering.{law}", p, "zero"): "λ₀ = 0 is the pseudo-inverse and μ = 0 a "
        "constant damping: both are valid laws"
        for law in ("SingularityRobust", "GeneralizedSingularityRobust")
        for p in ("lambda0", "mu")
    },
    ("spacecraft.steering.SingularDirectionAvoidance", "lambda0", "zero"): "λ₀ = 0 is the "
    "pseudo-inverse (finite through the relative floor): a valid law",
}

#: cases the sweep still finds and that are not fixed yet, with the reason. Keys are
#: (qualified name, parameter, perturbation); "*" matches any parameter or perturbation.
KNOWN_GAPS: dict[tuple[str, str, str], str] = {
    ("benchmarks.scenario_files.load_scenarios", "-", "base"): "needs a file on disk: no "
    "example in the table yet",
    ("benchmarks.scenarios.scale_principal_moments", "-", "base"): "the example scale breaks "
    "the triangle inequality; a valid example is still to be chosen",
    **{
        (f"benchmarks.report.{n}", "-", "base"): "no example in the table yet"
        for n in (
            "write_pareto_figure",
            "write_sweep_report",
            "pareto_front",
            "performance",
            "peak_actuator_use",
            "controller_colors",
            "controller_styles",
        )
    },
    ("spacecraft.se3_plant.simulate_pose", "xi0", "huge"): "the controller rejects the first "
    "state (its message names its own argument, xi); the initial rates are not bounded",
    (
        "liecontrol.control.payload_compensation.SmallAnglePIDWithFeedforward",
        "dt_c",
        "huge",
    ): "relational message names payload_frequency",
}

#: modules whose callables must all have an example (elsewhere a missing example is reported
#: by the summary but does not fail the test: their example tables are still being filled)
STRICT_COVERAGE = ("spacecraft", "benchmarks")


# ---------------------------------------------------------------------------------------------
# perturbations
# ---------------------------------------------------------------------------------------------


class _Kind(enum.Enum):
    BOOL = "bool"
    INT = "int"
    FLOAT = "float"
    ARRAY = "array"
    STR = "str"
    OBJECT = "object"
    NONE = "none"


def _is_numeric_seq(v: Any) -> bool:
    if isinstance(v, (list, tuple)) and v:
        try:
            a = np.asarray(v)
        except Exception:
            return False
        return a.dtype.kind in "if" and a.dtype != object
    return False


def _kind(v: Any) -> _Kind:
    if v is None:
        return _Kind.NONE
    if isinstance(v, (bool, np.bool_)):
        return _Kind.BOOL
    if isinstance(v, (int, np.integer)):
        return _Kind.INT
    if isinstance(v, (float, np.floating)):
        return _Kind.FLOAT
    if isinstance(v, np.ndarray) and v.dtype.kind in "if":
        return _Kind.ARRAY
    if _is_numeric_seq(v):
        return _Kind.ARRAY
    if isinstance(v, str):
        return _Kind.STR
    return _Kind.OBJECT


def _like(v: Any, a: np.ndarray) -> Any:
    """``a`` in the container type of ``v`` (list/tuple stay lists/tuples)."""
    if isinstance(v, tuple):
        return tuple(a.tolist()) if a.ndim == 1 else tuple(tuple(r) for r in a.tolist())
    if isinstance(v, list):
        return a.tolist()
    return a


def _with_first(v: Any, value: float) -> Any:
    a = np.array(v, dtype=np.float64)
    a.flat[0] = value
    return _like(v, a)


#: perturbations that are never a valid input
INVALID = frozenset(
    {
        "nan",
        "inf",
        "complex",
        "string",
        "empty",
        "non_integer",
        "unknown_name",
        "empty_str",
        "number_for_str",
        "wrong_type",
    }
)


def perturbations(name: str, value: Any, annotation: str) -> list[tuple[str, Any, bool]]:
    """``(label, bad value, invalid?)`` for one parameter; ``invalid`` means a finite result is
    *meaningless* (only an error is right)."""
    kind = _kind(value)
    pos, nonneg = name in POSITIVE, name in NONNEGATIVE
    out: list[tuple[str, Any, bool]] = []
    if kind is _Kind.BOOL:
        # flags: Python's truthiness convention is not overridden everywhere (not swept)
        return []
    if kind is _Kind.INT:
        v = int(value)
        out += [
            ("nan", math.nan, True),
            ("inf", math.inf, True),
            ("huge", 10**300, False),
            ("non_integer", v + 0.5, True),
            ("string", "abc", True),
            ("complex", complex(v, 0.5), True),
        ]
        if v != 0:
            out.append(("negative", -abs(v), pos or nonneg))
        out.append(("zero", 0, pos))
        return out
    if kind is _Kind.FLOAT:
        v = float(value)
        scalar_only = (
            "ndarray" not in annotation
            and "object" not in annotation
            and ("float" in annotation or "int" in annotation)
        )
        out += [
            ("nan", math.nan, True),
            ("inf", math.inf, True),
            ("huge", 1e300 if v == 0 else v * 1e300, False),
            ("string", "abc", True),
            ("complex", complex(v, 0.5), True),
            ("empty", np.array([]), True),
            ("wrong_shape", np.array([v, v]), scalar_only),
        ]
        if v != 0:
            out.append(("negative", -abs(v), pos or nonneg))
        out.append(("zero", 0.0, pos))
        return out
    if kind is _Kind.ARRAY:
        a = np.array(value, dtype=np.float64)
        big = np.where(a == 0, 1e300, a * 1e300)
        wrong = np.concatenate([a, a[..., :1]], axis=-1) if a.ndim else np.array([a, a])
        out += [
            ("nan", _with_first(value, math.nan), True),
            ("inf", _with_first(value, math.inf), True),
            ("huge", _like(value, big), False),
            ("string", "abc", True),
            ("complex", a + 0.5j, True),
            ("empty", np.array([]), True),
            ("wrong_shape", wrong, True),
        ]
        if np.any(a > 0):
            out.append(("negative", _like(value, -np.abs(a)), pos or nonneg))
        out.append(("zero", _like(value, np.zeros_like(a)), pos))
        return out
    if kind is _Kind.STR and name in FREE_TEXT:
        # a label: any text is valid (only a non-string is wrong)
        return [("unknown_name", "no-such-name", False), ("number_for_str", 3.5, True)]
    if kind is _Kind.STR:
        return [
            ("unknown_name", "no-such-name", True),
            ("empty_str", "", True),
            ("number_for_str", 3.5, True),
        ]
    if kind is _Kind.NONE:
        return [("wrong_type", "abc", True)]
    return [("wrong_type", "abc", True), ("number_for_str", 3.5, True)]


# ---------------------------------------------------------------------------------------------
# checking results
# ---------------------------------------------------------------------------------------------


def _all_finite(obj: Any, depth: int = 0, seen: set | None = None) -> bool:
    """Every float in ``obj`` (arrays, numbers, containers, dataclass fields, instance
    attributes down to depth 3) is finite."""
    if seen is None:
        seen = set()
    if depth > 3 or id(obj) in seen:
        return True
    if isinstance(obj, (bool, np.bool_, str, bytes, type(None))):
        return True
    if isinstance(obj, (int, np.integer)):
        return True
    if isinstance(obj, (float, np.floating, complex, np.complexfloating)):
        return bool(np.isfinite(obj))
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc":
            return bool(np.all(np.isfinite(obj)))
        if obj.dtype == object:
            return all(_all_finite(x, depth + 1, seen) for x in obj.flat)
        return True
    seen.add(id(obj))
    if isinstance(obj, Mapping):
        return all(_all_finite(v, depth + 1, seen) for v in obj.values())
    if isinstance(obj, (list, tuple, set, frozenset)):
        return all(_all_finite(v, depth + 1, seen) for v in obj)
    if isinstance(obj, (Path, type)) or callable(obj) and not hasattr(obj, "__dict__"):
        return True
    if dataclasses.is_dataclass(obj):
        vals = [getattr(obj, f.name, None) for f in dataclasses.fields(obj)]
    else:
        vals = list(getattr(obj, "__dict__", {}).values())
    return all(_all_finite(v, depth + 1, seen) for v in vals)


def _snapshot(obj: Any) -> Any:
    try:
        return copy.deepcopy(obj)
    except Exception:
        return None


def _same(a: Any, b: Any, depth: int = 0) -> bool:
    """``b`` (after the call) equals its snapshot ``a`` (before): arrays, numbers, containers."""
    if depth > 4:
        return True
    if isinstance(a, np.ndarray):
        if not isinstance(b, np.ndarray) or a.shape != b.shape:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        if a.dtype == object:
            return True
        return bool(np.array_equal(a, b))
    if isinstance(a, dict):
        return (
            isinstance(b, dict)
            and a.keys() == b.keys()
            and all(_same(a[k], b[k], depth + 1) for k in a)
        )
    if isinstance(a, list):
        return (
            isinstance(b, list)
            and len(a) == len(b)
            and all(_same(x, y, depth + 1) for x, y in zip(a, b, strict=True))
        )
    return True  # immutables and objects: not compared


class _Timeout(Exception):
    pass


def _on_alarm(signum, frame):  # pragma: no cover - only on a hang
    raise _Timeout()


def _call(fn: Callable, args: dict[str, Any]) -> tuple[str, Any]:
    """``("return", value)`` or ``("raise", exception)``."""
    use_alarm = hasattr(signal, "setitimer") and _main_thread()
    if use_alarm:
        old = signal.signal(signal.SIGALRM, _on_alarm)
        signal.setitimer(signal.ITIMER_REAL, CASE_TIMEOUT_S)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with np.errstate(all="ignore"):
                return "return", fn(**args)
    except _Timeout as exc:
        return "timeout", exc
    except Exception as exc:  # the sweep classifies every exception
        return "raise", exc
    finally:
        if use_alarm:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def _clear(exc: BaseException, param: str, others: frozenset[str] = frozenset()) -> bool:
    try:
        from spacecraft import SimulationDiverged
    except ImportError:  # pragma: no cover
        SimulationDiverged = ()  # noqa: N806
    if isinstance(exc, SimulationDiverged):
        return True
    if not isinstance(exc, (ValueError, TypeError)):
        return False
    msg = str(exc)
    if msg.startswith(param):
        return True
    # a relation between two arguments ("t_final: must be > t0 = 1e+300"): clear when the
    # message starts with another argument's name and names the perturbed one too
    head = msg.split(":", 1)[0]
    return head in others and re.search(rf"\b{re.escape(param)}\b", msg) is not None


# ---------------------------------------------------------------------------------------------
# targets
# ---------------------------------------------------------------------------------------------


@dataclasses.dataclass
class Target:
    """One swept callable: ``make(**args)``; ``qualname`` names it in tables and reports."""

    module: str
    qualname: str
    fn: Callable[..., Any] | None
    params: list[inspect.Parameter]
    overrides: dict[str, Callable[[], Any]]
    build_instance: Callable[[], Any] | None = None  # for methods
    method: str | None = None
    problem: str | None = None  # why no example could be built


@dataclasses.dataclass
class Case:
    module: str
    target: str
    param: str
    perturbation: str
    outcome: str
    detail: str = ""


def _annotation(p: inspect.Parameter) -> str:
    a = p.annotation
    if a is inspect.Parameter.empty:
        return ""
    return a if isinstance(a, str) else getattr(a, "__name__", str(a))


def _example(target: Target, p: inspect.Parameter) -> tuple[bool, Any]:
    """``(found, value)`` for parameter ``p``."""
    if p.name in target.overrides:
        return True, target.overrides[p.name]()
    if p.default is not inspect.Parameter.empty:
        if type(p.default).__name__ == "_HAS_DEFAULT_FACTORY_CLASS" and target.fn is not None:
            # a dataclass field(default_factory=...): the signature shows a sentinel
            field = {f.name: f for f in dataclasses.fields(target.fn)}[p.name]
            return True, field.default_factory()
        return True, copy.deepcopy(p.default)
    if p.name in NAME_EXAMPLES:
        return True, NAME_EXAMPLES[p.name]()
    ann = _annotation(p)
    if ann in ("float",):
        return True, 1.0
    if ann in ("int",):
        return True, 2
    if ann in ("bool",):
        return True, True
    return False, None


def _example_args(target: Target) -> dict[str, Any] | None:
    args: dict[str, Any] = {}
    for p in target.params:
        try:
            found, value = _example(target, p)
        except Exception as exc:
            target.problem = f"building the example for {p.name!r} raised {exc!r}"[:200]
            return None
        if not found:
            target.problem = f"no example for parameter {p.name!r}"
            return None
        args[p.name] = value
    return args


def _bound(target: Target) -> Callable[..., Any]:
    if target.method is None:
        return target.fn
    inst = target.build_instance()
    return getattr(inst, target.method)


def _public_modules() -> list[str]:
    names = []
    for pkg_name in PACKAGES:
        pkg = importlib.import_module(pkg_name)
        names.append(pkg_name)
        for m in pkgutil.walk_packages(pkg.__path__, pkg_name + "."):
            if any(part.startswith("_") for part in m.name.split(".")):
                continue
            names.append(m.name)
    return sorted(names)


def _is_protocol_or_abstract(obj: Any) -> bool:
    return inspect.isclass(obj) and (
        inspect.isabstract(obj) or getattr(obj, "_is_protocol", False) or obj.__name__ == "Actuator"
    )


def _sweepable(obj: Any) -> bool:
    if not callable(obj):
        return False
    if inspect.isclass(obj) and issubclass(obj, BaseException):
        return False  # exception types are raised by the library, not called by users
    if _is_protocol_or_abstract(obj):
        return False
    if isinstance(obj, type(typing.Any)) or getattr(obj, "__module__", "") == "typing":
        return False
    return True


def _signature_params(fn: Callable) -> list[inspect.Parameter]:
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return []
    return [
        p
        for p in sig.parameters.values()
        if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
    ]


def module_targets(module_name: str) -> tuple[list[Target], list[str]]:
    """The targets defined in ``module_name`` (exports re-exported from elsewhere are swept
    where they are defined) and the problems found while collecting them."""
    problems: list[str] = []
    if any(module_name.startswith(prefix) for prefix in NOT_SWEPT_MODULES):
        return [], problems
    try:
        mod = importlib.import_module(module_name)
    except Exception as exc:
        return [], [f"{module_name}: import failed: {exc!r}"]
    targets: list[Target] = []
    for export in getattr(mod, "__all__", ()):
        if not hasattr(mod, export):
            problems.append(f"{module_name}: __all__ names {export!r}, which does not exist")
            continue
        obj = getattr(mod, export)
        if getattr(obj, "__module__", None) != module_name or not _sweepable(obj):
            continue
        qual = f"{module_name}.{export}"
        if qual in NOT_SWEPT:
            continue
        params = _signature_params(obj)
        t = Target(module_name, qual, obj, params, OVERRIDES.get(qual, {}))
        targets.append(t)
        for meth, over in METHODS.get(qual, {}).items():
            fn = getattr(obj, meth)
            mparams = _signature_params(fn)

            def build(t=t):
                return t.fn(**_example_args(t))

            targets.append(Target(module_name, f"{qual}.{meth}", None, mparams, over, build, meth))
    return targets, problems


# ---------------------------------------------------------------------------------------------
# the sweep
# ---------------------------------------------------------------------------------------------


def _args_snapshot(args: dict[str, Any]) -> dict[str, Any]:
    return {k: _snapshot(v) for k, v in args.items()}


def _mutated(before: dict[str, Any], args: dict[str, Any], skip: str | None = None) -> list[str]:
    return [k for k, v in before.items() if k != skip and not _same(v, args[k])]


def sweep_target(target: Target) -> list[Case]:
    """Every case of one target (the base call first)."""
    cases: list[Case] = []
    base = _example_args(target)
    if base is None:
        return [Case(target.module, target.qualname, "-", "base", "no_example", target.problem)]
    try:
        fn = _bound(target)
    except Exception as exc:
        msg = f"instance: {exc!r}"[:200]
        return [Case(target.module, target.qualname, "-", "base", "no_example", msg)]
    before = _args_snapshot(base)
    status, value = _call(fn, base)
    if status != "return":
        msg = f"example call raised {value!r}"[:200]
        return [Case(target.module, target.qualname, "-", "base", "no_example", msg)]
    base_finite = _all_finite(value)
    bad = _mutated(before, base)
    if bad:
        cases.append(Case(target.module, target.qualname, bad[0], "base", "mutated"))
    names = frozenset(q.name for q in target.params)
    for p in target.params:
        ann = _annotation(p)
        for label, bad_value, invalid in perturbations(p.name, base[p.name], ann):
            args = dict(base)
            for k in args:
                if k != p.name and _kind(args[k]) in (_Kind.ARRAY, _Kind.OBJECT):
                    args[k] = _fresh(target, k, base)
            args[p.name] = bad_value
            snap = _args_snapshot(args)
            try:
                fn = _bound(target)
            except Exception as exc:  # pragma: no cover - the base instance built before
                cases.append(
                    Case(target.module, target.qualname, p.name, label, "unclear", repr(exc)[:200])
                )
                continue
            status, value = _call(fn, args)
            if status == "timeout":
                outcome, detail = "hang", f"> {CASE_TIMEOUT_S} s"
            elif status == "raise":
                if _clear(value, p.name, names):
                    outcome, detail = "clear", ""
                else:
                    outcome, detail = "unclear", f"{type(value).__name__}: {value}"[:200]
            elif invalid:
                finite = _all_finite(value) or not base_finite
                outcome = "silent_meaningless" if finite else "silent_nan"
                detail = "accepted"
            else:
                finite = _all_finite(value) or not base_finite
                outcome, detail = ("ok", "") if finite else ("silent_nan", "non-finite output")
            key = (target.qualname, p.name, label)
            if outcome in BAD and key in ACCEPTED:
                outcome, detail = "ok", "accepted: " + ACCEPTED[key]
            changed = _mutated(snap, args)
            if changed:
                cases.append(
                    Case(
                        target.module,
                        target.qualname,
                        changed[0],
                        label,
                        "mutated",
                        f"while perturbing {p.name}",
                    )
                )
            cases.append(Case(target.module, target.qualname, p.name, label, outcome, detail))
    return cases


def _fresh(target: Target, name: str, base: dict[str, Any]) -> Any:
    """A fresh copy of an example argument (a call may legitimately keep a reference)."""
    for p in target.params:
        if p.name == name:
            found, value = _example(target, p)
            if found:
                return value
    return base[name]


#: seconds spent per target by the last sweep (``--details`` prints the slowest)
TIMINGS: dict[str, float] = {}


def sweep_module(module_name: str) -> tuple[list[Case], list[str]]:
    targets, problems = module_targets(module_name)
    cases: list[Case] = []
    for t in targets:
        start = time.perf_counter()
        cases += sweep_target(t)
        TIMINGS[t.qualname] = time.perf_counter() - start
    return cases, problems


def _gap(case: Case) -> str | None:
    for key in (
        (case.target, case.param, case.perturbation),
        (case.target, case.param, "*"),
        (case.target, "*", case.perturbation),
        (case.target, "*", "*"),
    ):
        if key in KNOWN_GAPS:
            return KNOWN_GAPS[key]
    return None


def summarize(cases: list[Case]) -> dict[str, Counter]:
    out: dict[str, Counter] = {}
    for c in cases:
        out.setdefault(c.module, Counter())[c.outcome] += 1
    return out


# ---------------------------------------------------------------------------------------------
# pytest entry points: one test per module (``-k spacecraft``, ``-k liecontrol``, ...)
# ---------------------------------------------------------------------------------------------

try:
    MODULES = _public_modules()
except Exception:  # pragma: no cover - an import error in a package: reported by the tests
    MODULES = list(PACKAGES)


@pytest.mark.parametrize("module_name", MODULES)
def test_public_api_sweep(module_name: str) -> None:
    cases, problems = sweep_module(module_name)
    assert not problems, "\n".join(problems)
    strict = module_name.split(".")[0] in STRICT_COVERAGE
    failing = [
        c
        for c in cases
        if (c.outcome in BAD or (strict and c.outcome == "no_example")) and _gap(c) is None
    ]
    report = "\n".join(
        f"{c.outcome:19s} {c.target}({c.param}={c.perturbation}) {c.detail}" for c in failing
    )
    assert not failing, f"{len(failing)} bad case(s) in {module_name}:\n{report}"


def test_known_gaps_are_still_gaps() -> None:
    """A fixed gap must leave :data:`KNOWN_GAPS` (the table documents only real gaps)."""
    by_target: dict[str, list[Case]] = {}
    modules = {k[0].rsplit(".", 2)[0] for k in KNOWN_GAPS}
    for m in MODULES:
        if any(k[0].startswith(m + ".") for k in KNOWN_GAPS) or m in modules:
            for c in sweep_module(m)[0]:
                by_target.setdefault(c.target, []).append(c)
    stale = []
    for key in KNOWN_GAPS:
        hits = [
            c
            for c in by_target.get(key[0], [])
            if (c.outcome in BAD or c.outcome == "no_example")
            and key[1] in ("*", c.param)
            and key[2] in ("*", c.perturbation)
        ]
        if not hits:
            stale.append(key)
    assert not stale, f"KNOWN_GAPS entries that no longer fail: {stale}"


def test_sweep_detects_each_outcome() -> None:
    """The classifier itself, on hand-made callables (so a green sweep means something)."""

    def good(x: float) -> float:
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise TypeError(f"x: expected a real number, got {type(x).__name__}")
        if not math.isfinite(x) or x <= 0:
            raise ValueError(f"x: must be finite and > 0, got {x}")
        return float(x)

    def silent(x: float) -> float:
        return float(np.real(x)) if not isinstance(x, str) else 0.0

    def unclear(x: float) -> float:
        return 1.0 / float(x)

    def mutating(x: np.ndarray) -> float:
        if isinstance(x, np.ndarray) and x.dtype.kind == "f" and x.size:
            x[...] = 0.0
        return 0.0

    def outcomes(fn, example):
        params = _signature_params(fn)
        t = Target("m", f"m.{fn.__name__}", fn, params, {"x": example})
        return Counter(c.outcome for c in sweep_target(t))

    clean = outcomes(good, lambda: 1.0)
    assert clean["clear"] > 0 and clean["ok"] > 0 and not set(clean) & set(BAD)
    assert outcomes(silent, lambda: 1.0)["silent_meaningless"] > 0
    assert outcomes(silent, lambda: 1.0)["silent_nan"] > 0
    assert outcomes(unclear, lambda: 1.0)["unclear"] > 0
    assert outcomes(mutating, lambda: np.array([1.0, 2.0]))["mutated"] > 0


# ---------------------------------------------------------------------------------------------
# script mode
# ---------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    """``--summary [prefix ...]``: counts per module; ``--details``: every bad case too."""
    argv = sys.argv[1:] if argv is None else argv
    details = "--details" in argv
    prefixes = [a for a in argv if not a.startswith("--")] or list(PACKAGES)
    mods = [m for m in MODULES if any(m == p or m.startswith(p + ".") for p in prefixes)]
    cols = (
        "clear",
        "ok",
        "unclear",
        "silent_nan",
        "silent_meaningless",
        "mutated",
        "hang",
        "no_example",
    )
    print(f"{'module':44s}" + "".join(f"{c[:12]:>13s}" for c in cols))
    total: Counter = Counter()
    bad_cases: list[Case] = []
    for m in mods:
        cases, problems = sweep_module(m)
        cnt = Counter(c.outcome for c in cases)
        total += cnt
        print(f"{m:44s}" + "".join(f"{cnt.get(c, 0):13d}" for c in cols))
        for p in problems:
            print(f"    problem: {p}")
        bad_cases += [c for c in cases if c.outcome in BAD or c.outcome == "no_example"]
    print(f"{'TOTAL':44s}" + "".join(f"{total.get(c, 0):13d}" for c in cols))
    n = sum(total.values())
    if n:
        print(f"cases: {n}; unclear {100 * total['unclear'] / n:.2f} %")
    if details:
        slow = sorted(TIMINGS.items(), key=lambda kv: -kv[1])[:10]
        print("slowest: " + ", ".join(f"{k} {v:.2f} s" for k, v in slow))
        for c in bad_cases:
            gap = _gap(c)
            print(
                f"{c.outcome:19s} {c.target}({c.param}={c.perturbation}) {c.detail}"
                + (f"  [known gap: {gap}]" if gap else "")
            )
    return 0


if __name__ == "__main__":
    with tempfile.TemporaryDirectory():
        raise SystemExit(main())
