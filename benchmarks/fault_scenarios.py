"""The actuator-fault scenario family of the ``full`` suite (:mod:`spacecraft.faults`).

Each fault kind during a 90° rest-to-rest slew (the fault strikes 30 s in, while the body is
still turning fast, ~70° from the target) and during fine pointing (holding the orbit-frame
attitude against the constant + harmonic disturbance of Wu, Huang, Wei & Guo's ADRC study; the
fault strikes at 100 s):

=========================  ==========================  ========================================
scenario                   spacecraft                  fault
=========================  ==========================  ========================================
fault-gimbal-stuck-*       SGCMG pyramid               gimbal 1 stuck
fault-wheel-failed-*       four-wheel pyramid, 1 N·m   wheel 0 failed (coasts)
fault-efficiency-*         SGCMG pyramid               gimbal 0 at 30 % effectiveness
fault-bias-*               SGCMG pyramid               gimbal 2 rate bias 1 mrad/s (≈ 0.3 N·m)
=========================  ==========================  ========================================

The runner tells the steering which units are lost (stuck gimbal, failed wheel: the SGCMG
steering switches to the singularity-robust inverse over the three remaining gimbals, the
wheels redistribute over the remaining three); an efficiency loss or a bias is not known to it
and must be rejected by the controller. Every run of the family carries the verdict flag
``fault-injected``. :func:`fault_scenarios` builds them; importing this module registers them
in the ``full`` suite (:func:`benchmarks.scenarios.register_scenario`).
"""

from __future__ import annotations

import dataclasses

from spacecraft.faults import ActuatorBias, ActuatorFault, EfficiencyLoss, GimbalStuck, WheelFailed

from .scenarios import (
    CONSTANT_HARMONIC_DISTURBANCE,
    PYRAMID_WHEEL_SPACECRAFT,
    SCENARIOS,
    Scenario,
    register_scenario,
    rest_to_rest,
)

__all__ = [
    "FAULT_WHEEL_SPACECRAFT",
    "SLEW_FAULT_TIME",
    "POINTING_FAULT_TIME",
    "fault_scenarios",
    "register_fault_scenarios",
]

#: The four-wheel pyramid bus of the wheel-failure pair: the rotating-payload bus with 1 N·m
#: wheels (with 0.2 N·m the three remaining wheels could not deliver the 90° slew's torque).
FAULT_WHEEL_SPACECRAFT = dataclasses.replace(
    PYRAMID_WHEEL_SPACECRAFT, name="payload-bus-pyramid-1nm", wheel_max_torque=1.0
)
#: Fault time of the slews [s]: mid-manoeuvre.
SLEW_FAULT_TIME = 30.0
#: Fault time of the fine-pointing runs [s]: after the initial transient has settled.
POINTING_FAULT_TIME = 100.0


def _pair(
    stem: str, what: str, spacecraft: object, make: type[ActuatorFault], **kw: float
) -> tuple[Scenario, Scenario]:
    unit = int(kw.pop("unit"))
    slew = rest_to_rest(
        90.0,
        name=f"fault-{stem}-slew-90",
        description=f"90° slew; {what} at {SLEW_FAULT_TIME:g} s",
        spacecraft=spacecraft,
        faults=(make(unit, SLEW_FAULT_TIME, **kw),),
        tags=("manoeuvre", "fault"),
    )
    pointing = Scenario(
        name=f"fault-{stem}-pointing",
        description="hold the orbit-frame attitude against the constant + harmonic "
        f"disturbance; {what} at {POINTING_FAULT_TIME:g} s",
        spacecraft=spacecraft,
        disturbances=(CONSTANT_HARMONIC_DISTURBANCE,),
        faults=(make(unit, POINTING_FAULT_TIME, **kw),),
        tags=("stabilisation", "fault"),
    )
    return slew, pointing


def fault_scenarios() -> tuple[Scenario, ...]:
    """The eight scenarios of the family (module docstring), slew and pointing per fault."""
    from .scenarios import SGCMG_SPACECRAFT

    return (
        *_pair("gimbal-stuck", "CMG gimbal 1 sticks", SGCMG_SPACECRAFT, GimbalStuck, unit=1),
        *_pair(
            "wheel-failed", "wheel 0 fails (coasts)", FAULT_WHEEL_SPACECRAFT, WheelFailed, unit=0
        ),
        *_pair(
            "efficiency",
            "CMG gimbal 0 drops to 30 % effectiveness",
            SGCMG_SPACECRAFT,
            EfficiencyLoss,
            unit=0,
            efficiency=0.3,
        ),
        *_pair(
            "bias",
            "CMG gimbal 2 gets a 1 mrad/s rate bias (≈ 0.3 N·m)",
            SGCMG_SPACECRAFT,
            ActuatorBias,
            unit=2,
            bias=1e-3,
        ),
    )


def register_fault_scenarios() -> None:
    """Add :func:`fault_scenarios` to the catalogue and the ``full`` suite (idempotent)."""
    for sc in fault_scenarios():
        if sc.name not in SCENARIOS:
            register_scenario(sc, suites=("full",))


register_fault_scenarios()
