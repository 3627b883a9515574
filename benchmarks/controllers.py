"""Registry of benchmark controllers by name (SPEC §6, §8).

A factory takes the scenario's :class:`benchmarks.scenarios.SpacecraftSpec` and returns a fresh
:class:`liecontrol.control.AttitudeController`. The registry is a plain dict so later issues add
entries (ADRC, MPC, chart-based adapters, ...) with :func:`register`.

Gain rule (one rule for every geometric PD so the comparison is fair): the closed loop linearised
about ``R = R_d`` is ``J δθ̈ + K_Ω δθ̇ + K_R S δθ = 0`` with ``S = s I`` the error function's
slope (``s = 1`` log, ``½`` large-angle, ``½(tr G − g_max)`` trace); choosing

    K_R = ω_n² J / s,     K_Ω = 2 ζ ω_n J

(:func:`liecontrol.control.geometric_pd.gains_from_bandwidth` with ``matrix=True``) gives every
axis the same natural frequency ω_n and damping ratio ζ for all three error functions. The
defaults ω_n = 0.03 rad/s, ζ = 0.9 keep the 179° slew's peak body momentum (linear estimate
≈ 0.37 ω_n θ₀ âᵀJâ ≈ 0.035 rad/s × 13 600 kg·m² ≈ 470 N·m·s about the slew axis; measured with the
log error 2.1 °/s ≈ 500 N·m·s) inside the 4 × 300 N·m·s pyramid's momentum envelope (the
singularity measure never falls below its initial 0.77 in the quick suite), and settle a small
error to 0.1° in ≈ 5/(ζ ω_n) ≈ 3 min. Away from the
linear region the three error functions differ (that is the point of the comparison): the
trace and large-angle errors are bounded, so large errors are corrected more slowly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from liecontrol._validation import check_positive
from liecontrol.control import AttitudeController

from .scenarios import SpacecraftSpec

__all__ = [
    "GainRule",
    "DEFAULT_GAIN_RULE",
    "ControllerFactory",
    "CONTROLLERS",
    "QUICK_CONTROLLERS",
    "register",
    "make_controller",
    "available_controllers",
    "geometric_pd_factory",
]

ControllerFactory = Callable[[SpacecraftSpec], AttitudeController]


@dataclass(frozen=True)
class GainRule:
    """Linearised closed-loop natural frequency ``omega_n`` [rad/s] and damping ratio ``zeta``."""

    omega_n: float = 0.03
    zeta: float = 0.9

    def __post_init__(self) -> None:
        object.__setattr__(self, "omega_n", check_positive(self.omega_n, "omega_n"))
        object.__setattr__(self, "zeta", check_positive(self.zeta, "zeta"))


DEFAULT_GAIN_RULE = GainRule()


def geometric_pd_factory(error: str, rule: GainRule = DEFAULT_GAIN_RULE) -> ControllerFactory:
    """Factory of a :class:`~liecontrol.control.geometric_pd.GeometricPD` with error function
    ``error`` and gains from ``rule`` (see the module docstring); the controller is given the
    plant's true inertia."""

    def make(spacecraft: SpacecraftSpec) -> AttitudeController:
        from liecontrol.control.geometric_pd import GeometricPD, gains_from_bandwidth

        J = spacecraft.J
        k_R, k_Omega = gains_from_bandwidth(J, rule.omega_n, rule.zeta, error=error, matrix=True)
        return GeometricPD(J, k_R, k_Omega, error=error)

    make.__doc__ = f"GeometricPD(error={error!r}), ω_n={rule.omega_n} rad/s, ζ={rule.zeta}"
    return make


#: All registered controllers, by name.
CONTROLLERS: dict[str, ControllerFactory] = {
    "geometric-pd-trace": geometric_pd_factory("trace"),
    "geometric-pd-log": geometric_pd_factory("log"),
    "geometric-pd-large-angle": geometric_pd_factory("large_angle"),
}

#: The controllers of the quick suite.
QUICK_CONTROLLERS: tuple[str, ...] = (
    "geometric-pd-trace",
    "geometric-pd-log",
    "geometric-pd-large-angle",
)


def register(name: str, factory: ControllerFactory, *, replace: bool = False) -> None:
    """Add a controller factory under ``name``."""
    if not callable(factory):
        raise ValueError("factory: must be callable as factory(spacecraft) -> controller")
    if name in CONTROLLERS and not replace:
        raise ValueError(f"name: controller {name!r} is already registered")
    CONTROLLERS[name] = factory


def available_controllers() -> list[str]:
    return sorted(CONTROLLERS)


def make_controller(name: str, spacecraft: SpacecraftSpec) -> AttitudeController:
    """A fresh controller ``name`` for ``spacecraft``; unknown names list the valid ones."""
    try:
        factory = CONTROLLERS[name]
    except KeyError:
        raise ValueError(
            f"name: unknown controller {name!r}; valid controllers: "
            f"{', '.join(available_controllers())}"
        ) from None
    return factory(spacecraft)
