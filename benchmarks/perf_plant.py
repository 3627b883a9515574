"""What each plant model costs: ``python -m benchmarks.perf_plant [--t-final 300] [--batch 1000]``.

Cumulative cases on the SGCMG-bus spacecraft (SGCMG pyramid, SR steering) under the large-angle
geometric PD at every step, dt = 0.1 s, logging every 60 s:

1. foundation: rigid body + SGCMG + geometric PD;
2. + constant + harmonic torque;
3. + gravity gradient on a circular orbit;
4. + the example rotating payload;
5. + three flexible appendage modes (hybrid coordinates);
6. + sensors in the loop: star tracker (0.5 s) and rate gyro (0.1 s) through
   :class:`spacecraft.simulator.StarTrackerGyro`.

For each: single-spacecraft steps per second and, for a batch of ``--batch`` spacecraft (random
targets), spacecraft-steps per second, both per CPU-second of this process and per wall-second;
best of ``--rounds`` interleaved rounds. Then the per-call cost of each model's hot-path entry at
B = 1 and B = ``--batch``. The BLAS/OpenMP thread counts are set to 1 before numpy is imported
unless the environment sets them, and are printed.
"""

from __future__ import annotations

from benchmarks._perf import pin_blas_threads

pin_blas_threads()  # before numpy is imported

import argparse  # noqa: E402
import time  # noqa: E402
import timeit  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._perf import sgcmg_bus_inertia, sgcmg_bus_pd_loop, thread_settings  # noqa: E402
from liecontrol.lie import so3  # noqa: E402
from spacecraft import (  # noqa: E402
    ROTATING_PAYLOAD_EXAMPLE,
    CircularOrbit,
    ConstantHarmonicTorque,
    FlexibleModes,
    GravityGradientTorque,
    RateGyro,
    RigidBody,
    RotatingPayloadTorque,
    SgcmgActuator,
    SgcmgPyramid,
    SingularityRobust,
    Spacecraft,
    StarTracker,
    StarTrackerGyro,
    SumOfDisturbances,
    simulate,
)

J_BUS = sgcmg_bus_inertia()
#: three appendage modes (two solar-array bending modes and one torsion mode)
MODES = FlexibleModes(
    coupling=np.array([[20.0, 3.0, 1.0], [2.0, 15.0, -3.0], [4.0, -2.0, 12.0]]),
    frequencies=np.array([0.8, 1.9, 3.1]),
    damping=0.005,
)

CASES = (
    "foundation (rigid + SGCMG + PD)",
    "+ constant + harmonic torque",
    "+ gravity gradient",
    "+ rotating payload",
    "+ flexible modes (3)",
    "+ sensors (tracker + gyro)",
)


def _setup(case: int, batch: int, rng: np.random.Generator) -> tuple:
    sources: dict = {}
    if case >= 1:
        sources["constant_harmonic"] = ConstantHarmonicTorque()
    if case >= 2:
        sources["gravity_gradient"] = GravityGradientTorque(J_BUS, CircularOrbit())
    if case >= 3:
        sources["payload"] = RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE])
    plant = Spacecraft(
        RigidBody(J_BUS),
        SgcmgActuator(SgcmgPyramid(h0=300.0), SingularityRobust()),
        SumOfDisturbances(sources) if sources else None,
        MODES if case >= 4 else None,
    )
    ctrl, ref = sgcmg_bus_pd_loop(batch, rng)
    kw: dict = {}
    if case >= 5:
        kw = {
            "sensors": {
                "star_tracker": StarTracker(noise_std=2e-5, period=0.5),
                "gyro": RateGyro(white_std=1e-5, bias_rw_std=1e-7, period=0.1),
            },
            "measurement": StarTrackerGyro(),
            "rng": np.random.default_rng(1),
        }
    return plant, ctrl, ref, plant.initial_state(np.eye(3), batch=batch), kw



def measure(
    case: int, batch: int, t_final: float, dt: float, repeat: int = 1
) -> tuple[float, float]:
    """Best-of-``repeat`` spacecraft-steps per CPU-second of this process and per wall-second
    for cumulative case ``case`` (CPU time is the figure to compare: the machine is shared, and
    other jobs' load would otherwise swamp the differences being measured)."""
    rng = np.random.default_rng(0)
    log_every = max(1, round(60.0 / dt))
    best_cpu = best_wall = np.inf
    for _ in range(repeat):
        plant, ctrl, ref, s0, kw = _setup(case, batch, rng)
        c, w = time.process_time(), time.perf_counter()
        simulate(plant, ctrl, ref, s0, t_final, dt, log_every=log_every, **kw)
        best_cpu = min(best_cpu, time.process_time() - c)
        best_wall = min(best_wall, time.perf_counter() - w)
    n = batch * round(t_final / dt)
    return n / best_cpu, n / best_wall


def micro_costs(batch: int, number: int = 200, repeat: int = 7) -> dict[str, float]:
    """Per-call time [µs] of each model's hot-path entry at batch size ``batch`` (minimum over
    ``repeat`` timings of ``number`` calls: robust to other load on a shared machine).

    A plant step evaluates the disturbance sources and the body/modal accelerations 4 times
    (RK stages); the sensors and the measurement hook at most once.
    """
    rng = np.random.default_rng(0)
    R = so3.exp(0.3 * rng.normal(size=(batch, 3)))
    w = 0.01 * rng.normal(size=(batch, 3))
    tau = rng.normal(size=(batch, 3))
    body = RigidBody(J_BUS)
    flex = Spacecraft(body, SgcmgActuator(), modes=MODES)
    q = 0.01 * rng.normal(size=(batch, 3))
    tracker = StarTracker(noise_std=2e-5, period=0.5)
    gyro = RateGyro(white_std=1e-5, bias_rw_std=1e-7, period=0.1)
    gyro.reset(batch, rng)
    hook = StarTrackerGyro()
    outputs = {"star_tracker": tracker.measure(0.0, R, w, rng), "gyro": w}
    from liecontrol.control.base import AttitudeState

    truth = AttitudeState(R=R, omega=w, h=np.zeros((batch, 3)))
    calls = {
        "rigid body ω̇": lambda: body.angular_acceleration_unchecked(w, tau),
        "constant + harmonic torque": lambda: ConstantHarmonicTorque()(1.0, R, w),
        "gravity gradient": lambda: GravityGradientTorque(J_BUS, CircularOrbit())(1.0, R, w),
        "rotating payload": lambda: RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE])(1.0, R, w),
        "flexible (ω̇, q̈), 3 modes": lambda: MODES.accelerations(
            w, q, q, tau, flex.body.J, flex._Js_inv
        ),
        "star tracker sample": lambda: tracker.measure(0.0, R, w, rng),
        "gyro sample": lambda: gyro.measure(1.0, R, w, rng),
        "StarTrackerGyro hook": lambda: hook(0.0, outputs, truth),
    }
    # the constructors are inside the lambdas for the sources: time them out separately
    sources = {
        "constant + harmonic torque": ConstantHarmonicTorque(),
        "gravity gradient": GravityGradientTorque(J_BUS, CircularOrbit()),
        "rotating payload": RotatingPayloadTorque([ROTATING_PAYLOAD_EXAMPLE]),
    }
    # environment torques on a 2 × 2 × 3 m box, 0.15 m centre-of-pressure offset
    from spacecraft import surface_forces as sf

    bus = sf.box_plates([2.0, 2.0, 3.0], [0.0, 0.0, 0.15])
    sources["aerodynamic (6 plates)"] = sf.AerodynamicTorque(bus, CircularOrbit())
    sources["solar pressure (6 plates)"] = sf.SolarPressureTorque(bus, CircularOrbit())
    sources["residual dipole"] = sf.ResidualDipoleTorque([0.5, 0.0, 0.0], CircularOrbit())
    for name, src in sources.items():
        calls[name] = lambda src=src: src(1.0, R, w)
    # momentum management: the field (a new time: 2 of the 4 RK stages per step), the torque
    # m × B at an already evaluated time (the other 2) and the dipole law (once per step)
    from spacecraft.geomagnetic import TiltedDipoleField
    from spacecraft.momentum import CrossProductDumping, Magnetorquers

    orbit = CircularOrbit()
    field = TiltedDipoleField()
    dumping = CrossProductDumping(orbit, magnetorquers=Magnetorquers(3000.0))
    h = 100.0 * rng.normal(size=(batch, 3))
    m = dumping.dipole(1.0, R, h)
    calls["geomagnetic field (tilted dipole)"] = lambda: field.inertial(1.0, orbit.position(1.0))
    calls["magnetorquer torque m × B"] = lambda: dumping.torque(1.0, R, m)
    calls["cross-product dipole law"] = lambda: dumping.dipole(1.0, R, h)
    timer = timeit.Timer
    return {
        name: 1e6 * min(timer(f, timer=time.process_time).repeat(repeat, number)) / number
        for name, f in calls.items()
    }


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--t-final", type=float, default=200.0, help="single-run length [s]")
    p.add_argument("--batch-t-final", type=float, default=30.0, help="batch-run length [s]")
    p.add_argument("--dt", type=float, default=0.1)
    p.add_argument("--batch", type=int, default=1000)
    p.add_argument("--rounds", type=int, default=3, help="best of this many interleaved rounds")
    a = p.parse_args(argv)
    print(f"threads: {thread_settings()}")
    # rounds interleave the cases, so a load change on a shared machine hits all of them;
    # columns: [CPU, wall] throughput, best over the rounds
    one = np.zeros((len(CASES), 2))
    many = np.zeros((len(CASES), 2))
    for _ in range(a.rounds):
        for case in range(len(CASES)):
            one[case] = np.maximum(one[case], measure(case, 1, a.t_final, a.dt))
            many[case] = np.maximum(many[case], measure(case, a.batch, a.batch_t_final, a.dt))
    print(
        f"{'case':34s} {'1 s/c steps/s':>14s} {'cost':>7s} {a.batch:>6d}-batch sc-steps/s"
        f"        {'(wall: 1 s/c, batch)':>22s}"
    )
    for case, name in enumerate(CASES):
        print(
            f"{name:34s} {one[case, 0]:14.0f} {one[0, 0] / one[case, 0]:6.2f}x"
            f" {many[case, 0]:13.0f} ({many[0, 0] / many[case, 0]:4.2f}x)"
            f"   ({one[case, 1]:7.0f}, {many[case, 1]:9.0f})"
        )
    print("per CPU-second of this process; cost: time per step relative to the foundation")
    print("(cumulative models); wall-clock figures in parentheses")
    print()
    small, large = micro_costs(1), micro_costs(a.batch, number=20)
    print(f"{'model entry (per call)':34s} {'B = 1 [µs]':>12s} {f'B = {a.batch} [µs]':>16s}")
    for name in small:
        print(f"{name:34s} {small[name]:12.1f} {large[name]:16.1f}")


if __name__ == "__main__":
    main()
