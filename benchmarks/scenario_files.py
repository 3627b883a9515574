"""Scenarios from TOML (``tomllib``) or YAML (when PyYAML is importable) files.

A file holds one or more ``[[scenario]]`` tables and an optional ``[defaults]`` table whose keys
apply to every scenario (a scenario's own keys win)::

    [defaults]
    duration = 300.0          # [s]
    dt = 0.1                  # plant step [s]
    control_period = 0.1      # [s]

    [[scenario]]
    name = "slew-120-x"
    description = "rest-to-rest 120° about body x"
    tags = ["manoeuvre"]
    quaternion_sign = 1       # −1: hand chart controllers the −q start

    [scenario.initial]        # errors relative to the reference at t0
    angle_deg = 120.0         # with `axis`, or rotvec / rotvec_deg, or quaternion [w, x, y, z]
    axis = [1.0, 0.0, 0.0]
    rate_deg_s = [0.0, 0.0, 0.0]   # or rate [rad/s]

    [scenario.reference]      # kind: constant | earth-pointing | constant-rate |
    kind = "constant"         #   eigenaxis-profile
    rotvec_deg = [0.0, 0.0, 0.0]   # (constant-rate: rate_deg_s; earth-pointing: n [rad/s];
                                   #  eigenaxis-profile: slew_rotvec_deg, the start relative
                                   #  to rotvec, and max_rate, max_accel, max_jerk in rad/s^k)

    [[scenario.disturbance]]  # any number; name: constant-harmonic | gravity-gradient |
    name = "constant-harmonic"  # constant | rotating-payload | aerodynamic | solar-pressure |
    scale = 1.0                 # residual-dipole; other keys: the model's parameters
                                # (benchmarks.scenarios.DisturbanceSpec)

    [scenario.spacecraft]     # optional; preset = "sgcmg-bus" (default) or "payload-bus",
    preset = "sgcmg-bus"      #   then any SpacecraftSpec field: inertia, actuator, h0, ...
                              # wheels: wheel_coulomb_friction, wheel_viscous_friction,
                              #   wheel_stribeck_torque/_speed, wheel_torque_lsb
                              # sgcmg: cmg_model = "momentum" | "full"; full model keys
                              #   cmg_wheel_spin_inertia, cmg_wheel_transverse_inertia,
                              #   cmg_gimbal_inertia, gimbal_servo_bandwidth,
                              #   gimbal_servo_damping, gimbal_torque_limit,
                              #   gimbal_gyro_feedforward
                              #   (preset "mini-cmg-3u": a 3U CubeSat with mini-CMGs)

    [scenario.uncertainty]
    inertia_scale = [1.2, 1.2, 0.8]   # true principal moments = nominal × scale

    [scenario.proximity]      # makes it an SE(3) scenario (ProximitySpec fields; *_deg allowed)

    attitude_tolerance_deg = 0.1   # success needs θ ≤ this over the final 10 % (and settling)
    position_tolerance_m = 0.1     # the same for the SE(3) position error

    [scenario.sensors]        # optional: the controller sees sensors (SensorSpec fields)
    attitude_noise_arcsec = 10.0
    estimator = "mekf"        # none | mekf | ukf
    cross_boresight_arcsec = 2.0     # boresight model instead of attitude_noise_arcsec,
    boresight_arcsec = 16.0          #   roll about `boresight` = [0, 0, 1] (body axes)
    star_tracker_latency = 0.1       # [s], a multiple of dt
    star_tracker_outages = [[100.0, 120.0]]   # [s]; random: outage_rate [1/s], outage_duration
    gyro_scale_factor = 1e-4         # also gyro_misalignment [rad], gyro_quantization [rad/s],
    gyro_bandwidth = 20.0            #   gyro_bandwidth [Hz]
    compute_delay = 0.1              # [s] measurement → actuation, a multiple of dt

    [[scenario.keep_out]]            # repeatable: a pointing cone to stay out of
    body_axis = [0.0, 0.0, 1.0]      # boresight, body axes
    inertial_direction = [1.0, 0.0, 0.0]
    half_angle_deg = 30.0
    [[scenario.keep_in]]             # repeatable, same keys: a cone to stay inside

    [scenario.orbit]                 # circular orbit of the attitude plant
    altitude_km = 530.0              # an earth-pointing reference's n follows from it unless set
    inclination_deg = 97.5
    raan_deg = 0.0
    [scenario.momentum_management]   # needs CMGs or wheels (magnetorquers: [scenario.orbit])
    kind = "magnetorquer"            # or "thrusters" (spacecraft.thrusters) or "none"
    max_dipole = 200.0               # A·m² per rod
    gain = 0.001                     # k [1/s] of m = k (Δh × B)/‖B‖² / τ = −k Δh (thrusters)
    # kind = "thrusters" only: thrust [N], arm [m] (default layout: six couples), isp [s],
    #   min_on_time [s] (>= dt), pulse_period [s], deadband [N·m·s], or a custom layout:
    #   positions = [[x, y, z], ...] [m] and directions = [[dx, dy, dz], ...]
    [scenario.detumble]              # a detumble scenario (plant "magnetorquer"; needs the orbit,
    threshold_deg_s = 1.0            #   initial rotvec 0, the tumble as initial rate; no
    gain = 5e-5                      #   disturbance, sensors, cones or faults): k [N·m·s],
    max_dipole = 0.2                 #   also duty_cycle, rod_power, magnetometer_noise,
    seed = 3                         #   magnetometer_bias, gyro_noise, rate_range_deg_s
    [scenario.sun_acquisition]       # safe-mode Sun acquisition (plant "sun-safe"; needs the
    eclipse = "damp"                 #   orbit and an "ideal" actuator; initial rotvec/rate: the
    threshold_deg = 5.0              #   inertial start): also normals, fov_half_angle_deg,
    seed = 1                         #   sensor_noise, sensor_threshold, min_intensity,
                                     #   sensor_period, allow_gaps, gyro_noise, gyro_bias,
                                     #   gyro_bias_walk, window_s, body_axis, gravity_gradient,
                                     #   rate_range_deg_s

    [scenario.dispersion]            # the members' spread (benchmarks.dispersion; 1-sigma)
    attitude_angle_deg = 2.0         # also attitude_axis_deg, rate_deg_s, inertia_moments,
    inertia_moments = 0.05           #   inertia_axes_deg, cmg_h0, cmg_beta_deg,
    seed = 0                         #   disturbance_scale, position_m, sensor_seeds
    [[scenario.requirement]]         # repeatable (none: benchmarks.requirements defaults)
    metric = "rpe_deg"               # a benchmarks.requirements.REQUIREMENT_METRICS key
    limit = 0.01                     # in the metric's unit
    sense = "max"                    # max: value <= limit; min: value >= limit
    window_s = 10.0                  # RPE/PDE window [s]

    [[scenario.fault]]               # repeatable: an actuator fault (spacecraft.faults)
    kind = "cmg-gimbal-stuck"        # or wheel-failed | actuator-efficiency | actuator-bias
    unit = 2                         # 0-based gimbal / wheel / body axis; must exist
    time = 100.0                     # [s], within [0, duration]
    # efficiency = 0.5               # actuator-efficiency only, in [0, 1]
    # bias = 0.001                   # actuator-bias only: rad/s (CMG), N·m (wheel, ideal)
    # (top level) reconfiguration = "detector"   # or "oracle": the exact fault time

Angles may be given in radians (``rotvec``, ``rate``) or degrees (``rotvec_deg``, ``angle_deg``,
``rate_deg_s``). Every error names the file and the offending key, e.g.
``path: my.toml: scenario[1].reference.kind: unknown reference kind 'lvlh' ...``; unknown keys
list the valid ones. :func:`scenario_to_dict` writes the same schema (radians), so a catalogue
scenario survives a round trip.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from liecontrol.control.constrained import KeepInCone, KeepOutCone

from .dispersion import DispersionSpec
from .requirements import Requirement
from .scenarios import (
    MINI_CMG_SPACECRAFT,
    PAYLOAD_SPACECRAFT,
    SGCMG_SPACECRAFT,
    DetumbleSpec,
    DisturbanceSpec,
    MomentumManagementSpec,
    OrbitSpec,
    ProximitySpec,
    ReferenceSpec,
    Scenario,
    SensorSpec,
    SpacecraftSpec,
    SunAcquisitionSpec,
    UncertaintySpec,
)

try:  # Python ≥ 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10 needs the tomli backport
    try:
        import tomli as tomllib
    except ModuleNotFoundError:
        tomllib = None

__all__ = [
    "ScenarioFileError",
    "load_scenarios",
    "scenarios_from_dict",
    "scenario_from_dict",
    "scenario_to_dict",
]

_PRESETS = {
    "sgcmg-bus": SGCMG_SPACECRAFT,
    "payload-bus": PAYLOAD_SPACECRAFT,
    "mini-cmg-3u": MINI_CMG_SPACECRAFT,
}
_TOP_KEYS = (
    "name",
    "description",
    "tags",
    "duration",
    "dt",
    "control_period",
    "quaternion_sign",
    "initial",
    "reference",
    "disturbance",
    "spacecraft",
    "uncertainty",
    "proximity",
    "attitude_tolerance_deg",
    "position_tolerance_m",
    "sensors",
    "keep_out",
    "keep_in",
    "orbit",
    "momentum_management",
    "fault",
    "reconfiguration",
    "dispersion",
    "requirement",
    "detumble",
    "sun_acquisition",
)
_REQUIREMENT_KEYS = ("metric", "limit", "sense", "window_s", "name")
_FAULT_KEYS = ("kind", "unit", "time", "efficiency", "bias")
_CONE_KEYS = ("body_axis", "inertial_direction", "half_angle_deg")


class ScenarioFileError(ValueError):
    """A malformed scenario file; the message names the file and the offending key."""


class _Bad(Exception):
    def __init__(self, key: str, msg: str) -> None:
        super().__init__(msg)
        self.key = key
        self.msg = msg


def _check_keys(table: Any, valid: tuple[str, ...], where: str) -> Mapping[str, Any]:
    if not isinstance(table, Mapping):
        raise _Bad(where, f"expected a table, got {type(table).__name__}")
    for k in table:
        if k not in valid:
            raise _Bad(
                f"{where}.{k}" if where else str(k), f"unknown key; valid: {', '.join(valid)}"
            )
    return table


def _vec3(v: Any, key: str, scale: float = 1.0) -> tuple[float, float, float]:
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise _Bad(key, f"expected 3 numbers, got {v!r}") from None
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise _Bad(key, f"expected 3 finite numbers, got {v!r}")
    return tuple(float(x) * scale for x in a)


def _number(v: Any, key: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _Bad(key, f"expected a number, got {v!r}")
    return float(v)


def _construct(cls: type, kwargs: dict[str, Any], where: str) -> Any:
    """``cls(**kwargs)``; a ``ValueError`` naming a field is re-raised at ``where.field``."""
    try:
        return cls(**kwargs)
    except ValueError as exc:
        msg = str(exc)
        head, _, rest = msg.partition(":")
        field = head.split(".")[0].strip()
        if rest and (field in kwargs or field in {f.name for f in dataclasses.fields(cls)}):
            raise _Bad(f"{where}.{head.strip()}" if where else head.strip(), rest.strip()) from None
        raise _Bad(where, msg) from None
    except TypeError as exc:
        raise _Bad(where, str(exc)) from None


def _angle_pair(t: Mapping[str, Any], where: str, rad: str, deg: str) -> tuple | None:
    if rad in t and deg in t:
        raise _Bad(f"{where}.{deg}", f"give either {rad} [rad] or {deg}, not both")
    if rad in t:
        return _vec3(t[rad], f"{where}.{rad}")
    if deg in t:
        return _vec3(t[deg], f"{where}.{deg}", math.pi / 180.0)
    return None


def _initial(t: Any, where: str) -> dict[str, Any]:
    t = _check_keys(
        t, ("rotvec", "rotvec_deg", "angle_deg", "axis", "quaternion", "rate", "rate_deg_s"), where
    )
    out: dict[str, Any] = {}
    forms = [k for k in ("rotvec", "rotvec_deg", "angle_deg", "quaternion") if k in t]
    if len(forms) > 1:
        raise _Bad(f"{where}.{forms[1]}", f"give one attitude form, got {', '.join(forms)}")
    if "axis" in t and "angle_deg" not in t:
        raise _Bad(f"{where}.axis", "axis needs angle_deg")
    if "angle_deg" in t:
        ang = _number(t["angle_deg"], f"{where}.angle_deg")
        axis = np.array(_vec3(t.get("axis", (1.0, 0.0, 0.0)), f"{where}.axis"))
        n = np.linalg.norm(axis)
        if n == 0:
            raise _Bad(f"{where}.axis", "must be non-zero")
        out["initial_rotvec"] = tuple(math.radians(ang) * axis / n)
    elif "quaternion" in t:
        try:
            q = np.asarray(t["quaternion"], dtype=np.float64)
        except (TypeError, ValueError):
            raise _Bad(f"{where}.quaternion", "expected 4 numbers [w, x, y, z]") from None
        if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-12:
            raise _Bad(f"{where}.quaternion", f"expected a non-zero [w, x, y, z], got {q.tolist()}")
        q = q / np.linalg.norm(q)
        out["initial_rotvec"] = tuple(Rotation.from_quat([*q[1:], q[0]]).as_rotvec())
        # a quaternion with w < 0 is the −q start of the same attitude
        out["quaternion_sign"] = -1 if q[0] < 0 else 1
    else:
        rv = _angle_pair(t, where, "rotvec", "rotvec_deg")
        if rv is not None:
            out["initial_rotvec"] = rv
    rate = _angle_pair(t, where, "rate", "rate_deg_s")
    if rate is not None:
        out["initial_rate"] = rate
    return out


def _reference(t: Any, where: str) -> ReferenceSpec:
    t = _check_keys(
        t,
        ("kind", "rotvec", "rotvec_deg", "n", "rate", "rate_deg_s", "slew_rotvec")
        + ("slew_rotvec_deg", "max_rate", "max_accel", "max_jerk"),
        where,
    )
    kw: dict[str, Any] = {}
    if "kind" in t:
        kw["kind"] = t["kind"]
    slew = _angle_pair(t, where, "slew_rotvec", "slew_rotvec_deg")
    if slew is not None:
        kw["slew_rotvec"] = slew
    for key in ("max_rate", "max_accel", "max_jerk"):
        if key in t:
            kw[key] = _number(t[key], f"{where}.{key}")
    rv = _angle_pair(t, where, "rotvec", "rotvec_deg")
    if rv is not None:
        kw["rotvec"] = rv
    rate = _angle_pair(t, where, "rate", "rate_deg_s")
    if rate is not None:
        kw["rate"] = rate
    if "n" in t:
        kw["n"] = _number(t["n"], f"{where}.n")
    return _construct(ReferenceSpec, kw, where)


def _disturbances(t: Any, where: str) -> tuple[DisturbanceSpec, ...]:
    items = t if isinstance(t, list) else [t]
    out = []
    for i, d in enumerate(items):
        w = f"{where}[{i}]"
        if isinstance(d, str):
            d = {"name": d}
        if not isinstance(d, Mapping):
            raise _Bad(w, f"expected a table or a name, got {d!r}")
        if "name" not in d:
            raise _Bad(f"{w}.name", "missing (constant-harmonic, gravity-gradient, constant, ...)")
        params = {k: _number(v, f"{w}.{k}") for k, v in d.items() if k != "name"}
        try:
            out.append(DisturbanceSpec(d["name"], tuple(params.items())))
        except ValueError as exc:
            head, _, rest = str(exc).partition(":")
            key = f"{w}.name" if head.strip() == "name" else w
            raise _Bad(key, rest.strip() or str(exc)) from None
    return tuple(out)


def _spacecraft(t: Any, where: str) -> SpacecraftSpec:
    fields = tuple(f.name for f in dataclasses.fields(SpacecraftSpec))
    t = _check_keys(t, ("preset",) + fields, where)
    preset = t.get("preset", "sgcmg-bus")
    if preset not in _PRESETS:
        raise _Bad(f"{where}.preset", f"unknown preset {preset!r}; valid: {', '.join(_PRESETS)}")
    kw = {k: v for k, v in t.items() if k != "preset"}
    base = _PRESETS[preset]
    try:
        return dataclasses.replace(base, **kw)
    except (ValueError, TypeError) as exc:  # field checks name the field (flags: TypeError)
        head, _, rest = str(exc).partition(":")
        raise _Bad(f"{where}.{head.strip()}", rest.strip()) from None


def _proximity(t: Any, where: str) -> ProximitySpec:
    fields = tuple(f.name for f in dataclasses.fields(ProximitySpec))
    deg = ("dock_rotvec_deg", "initial_rotvec_deg")
    t = _check_keys(t, fields + deg, where)
    kw: dict[str, Any] = {}
    for k, v in t.items():
        if k in deg:
            kw[k[: -len("_deg")]] = _vec3(v, f"{where}.{k}", math.pi / 180.0)
        else:
            kw[k] = v
    return _construct(ProximitySpec, kw, where)


def scenario_from_dict(
    table: Mapping[str, Any], defaults: Mapping[str, Any] | None = None, where: str = "scenario"
) -> Scenario:
    """One :class:`Scenario` from a table of the file schema (module docstring); ``defaults``
    fill missing keys. Raises :class:`ScenarioFileError` (``where.key: problem``)."""
    if not isinstance(table, Mapping):
        raise TypeError(f"table: expected a table (mapping), got {type(table).__name__}")
    if defaults is not None and not isinstance(defaults, Mapping):
        raise TypeError(f"defaults: expected a table (mapping), got {type(defaults).__name__}")
    if not isinstance(where, str):
        raise TypeError(f"where: expected a location label (string), got {type(where).__name__}")
    try:
        return _scenario(table, defaults or {}, where)
    except _Bad as bad:
        raise ScenarioFileError(f"{bad.key}: {bad.msg}") from None


def _scenario(table: Any, defaults: Mapping[str, Any], where: str) -> Scenario:
    _check_keys(defaults, _TOP_KEYS, "defaults")
    t = dict(defaults)
    t.update(_check_keys(table, _TOP_KEYS, where))
    if "name" not in t:
        raise _Bad(f"{where}.name", "missing")
    kw: dict[str, Any] = {"name": t["name"], "description": t.get("description", t["name"])}
    if not isinstance(kw["name"], str):
        raise _Bad(f"{where}.name", f"expected a string, got {kw['name']!r}")
    for k in ("duration", "dt"):
        if k in t:
            kw[k] = _number(t[k], f"{where}.{k}")
    if "control_period" in t:
        cp = t["control_period"]
        kw["control_period"] = (
            None if cp in (None, "none") else _number(cp, f"{where}.control_period")
        )
    if "tags" in t:
        tags = t["tags"]
        if not isinstance(tags, list) or not all(isinstance(x, str) for x in tags):
            raise _Bad(f"{where}.tags", f"expected a list of strings, got {tags!r}")
        kw["tags"] = tuple(tags)
    if "initial" in t:
        kw.update(_initial(t["initial"], f"{where}.initial"))
    if "quaternion_sign" in t:
        kw["quaternion_sign"] = t["quaternion_sign"]
    if "reconfiguration" in t:
        kw["reconfiguration"] = t["reconfiguration"]
    if "reference" in t:
        kw["reference"] = _reference(t["reference"], f"{where}.reference")
    if "disturbance" in t:
        kw["disturbances"] = _disturbances(t["disturbance"], f"{where}.disturbance")
    if "spacecraft" in t:
        kw["spacecraft"] = _spacecraft(t["spacecraft"], f"{where}.spacecraft")
    if "uncertainty" in t:
        u = _check_keys(t["uncertainty"], ("inertia_scale",), f"{where}.uncertainty")
        kw["uncertainty"] = _construct(UncertaintySpec, dict(u), f"{where}.uncertainty")
    if "proximity" in t:
        kw["proximity"] = _proximity(t["proximity"], f"{where}.proximity")
    for k in ("attitude_tolerance_deg", "position_tolerance_m"):
        if k in t:
            kw[k] = _number(t[k], f"{where}.{k}")
    if "sensors" in t:
        fields = tuple(f.name for f in dataclasses.fields(SensorSpec))
        st = _check_keys(t["sensors"], fields, f"{where}.sensors")
        kw["sensors"] = _construct(SensorSpec, dict(st), f"{where}.sensors")
    for k, cls in (("keep_out", KeepOutCone), ("keep_in", KeepInCone)):
        if k in t:
            kw[k] = _cones(t[k], cls, f"{where}.{k}")
    for k, cls in (
        ("orbit", OrbitSpec),
        ("momentum_management", MomentumManagementSpec),
        ("detumble", DetumbleSpec),
        ("sun_acquisition", SunAcquisitionSpec),
    ):
        if k in t:
            fields = tuple(f.name for f in dataclasses.fields(cls))
            kw[k] = _construct(cls, dict(_check_keys(t[k], fields, f"{where}.{k}")), f"{where}.{k}")
    if "fault" in t:
        kw["faults"] = _faults(t["fault"], kw, f"{where}.fault")
    if "dispersion" in t:
        fields = tuple(f.name for f in dataclasses.fields(DispersionSpec))
        dt = _check_keys(t["dispersion"], fields, f"{where}.dispersion")
        kw["dispersion"] = _construct(DispersionSpec, dict(dt), f"{where}.dispersion")
    if "requirement" in t:
        reqs = t["requirement"]
        if not isinstance(reqs, list):
            raise _Bad(f"{where}.requirement", "expected [[scenario.requirement]] tables")
        kw["requirements"] = tuple(
            _construct(
                Requirement,
                dict(_check_keys(r, _REQUIREMENT_KEYS, f"{where}.requirement[{i}]")),
                f"{where}.requirement[{i}]",
            )
            for i, r in enumerate(reqs)
        )
    ref_t = t.get("reference")
    n_given = isinstance(ref_t, Mapping) and "n" in ref_t
    if "orbit" in kw and "reference" in kw and kw["reference"].kind == "earth-pointing":
        if not n_given:  # the Earth-pointing rate follows from the orbit unless set
            kw["reference"] = dataclasses.replace(kw["reference"], n=kw["orbit"].n)
    return _construct(Scenario, kw, where)


def _faults(t: Any, kw: Mapping[str, Any], where: str) -> tuple:
    """``[[scenario.fault]]`` tables → faults, checked against the scenario's actuator (the unit
    must exist) and duration (the time must lie in the run)."""
    from spacecraft.faults import check_faults, make_fault

    items = t if isinstance(t, list) else [t]
    out = []
    for i, f in enumerate(items):
        w = f"{where}[{i}]"
        f = _check_keys(f, _FAULT_KEYS, w)
        for k in ("kind", "unit", "time"):
            if k not in f:
                raise _Bad(f"{w}.{k}", "missing")
        if isinstance(f["unit"], bool) or not isinstance(f["unit"], int):
            raise _Bad(f"{w}.unit", f"expected an integer, got {f['unit']!r}")
        args = {k: f[k] for k in ("efficiency", "bias") if k in f}
        for k, v in args.items():
            _number(v, f"{w}.{k}")
        try:
            out.append(make_fault(f["kind"], f["unit"], _number(f["time"], f"{w}.time"), **args))
        except ValueError as exc:
            head, _, rest = str(exc).partition(":")
            raise _Bad(f"{w}.{head.strip()}", rest.strip()) from None
    defaults = {x.name: x for x in dataclasses.fields(Scenario)}
    sp = kw.get("spacecraft", defaults["spacecraft"].default_factory())
    duration = kw.get("duration", defaults["duration"].default)
    pyramid = sp.actuator == "wheels" and sp.wheel_layout == "pyramid"
    n = 4 if sp.actuator == "sgcmg" or pyramid else 3
    try:
        return check_faults(out, sp.actuator, n, duration, name="fault")
    except ValueError as exc:
        head, _, rest = str(exc).partition(":")
        raise _Bad(f"{where}{head.strip()[len('fault'):]}", rest.strip()) from None


def _cones(t: Any, cls: type, where: str) -> tuple:
    items = t if isinstance(t, list) else [t]
    out = []
    for i, c in enumerate(items):
        w = f"{where}[{i}]"
        c = _check_keys(c, _CONE_KEYS, w)
        for k in _CONE_KEYS:
            if k not in c:
                raise _Bad(f"{w}.{k}", "missing")
        kw = {
            "body_axis": _vec3(c["body_axis"], f"{w}.body_axis"),
            "inertial_direction": _vec3(c["inertial_direction"], f"{w}.inertial_direction"),
            "half_angle_deg": _number(c["half_angle_deg"], f"{w}.half_angle_deg"),
        }
        out.append(_construct(cls, kw, w))
    return tuple(out)


def scenarios_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> list[Scenario]:
    """Scenarios of a parsed file (``{"defaults": {...}, "scenario": [{...}, ...]}``)."""
    if not isinstance(data, Mapping):
        raise TypeError(f"data: expected a table (mapping), got {type(data).__name__}")
    if not isinstance(source, str):
        raise TypeError(f"source: expected a file label (string), got {type(source).__name__}")
    try:
        _check_keys(data, ("defaults", "scenario"), "")
        items = data.get("scenario")
        if items is None:
            raise _Bad("scenario", "no [[scenario]] table found")
        if isinstance(items, Mapping):
            items = [items]
        if not isinstance(items, list):
            raise _Bad("scenario", f"expected a list of tables, got {type(items).__name__}")
        defaults = data.get("defaults", {})
        out = []
        for i, tab in enumerate(items):
            where = f"scenario[{i}]"
            if isinstance(tab, Mapping) and isinstance(tab.get("name"), str):
                where += f" ({tab['name']})"
            out.append(_scenario(tab, defaults, where))
    except _Bad as bad:
        raise ScenarioFileError(f"path: {source}: {bad.key}: {bad.msg}") from None
    names = [s.name for s in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ScenarioFileError(f"path: {source}: scenario: duplicate names {dup}")
    return out


def load_scenarios(path: str | Path) -> list[Scenario]:
    """Scenarios of a ``.toml`` file, or a ``.yaml``/``.yml`` file when PyYAML is importable."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioFileError(f"path: {path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".toml":
        if tomllib is None:  # pragma: no cover - Python 3.10 without tomli
            raise ScenarioFileError(f"path: {path}: reading TOML on Python 3.10 needs tomli")
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except tomllib.TOMLDecodeError as exc:
            raise ScenarioFileError(f"path: {path}: invalid TOML: {exc}") from None
    elif suffix in (".yaml", ".yml"):
        try:
            import yaml
        except ImportError:
            raise ScenarioFileError(
                f"path: {path}: YAML scenario files need PyYAML (pip install pyyaml); "
                "TOML works without it"
            ) from None
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
        except yaml.YAMLError as exc:
            raise ScenarioFileError(f"path: {path}: invalid YAML: {exc}") from None
    else:
        raise ScenarioFileError(f"path: {path}: unknown format {suffix!r}; use .toml or .yaml")
    return scenarios_from_dict(data, str(path))


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """The file-schema table of ``scenario`` (radians; TOML/YAML-serialisable)."""
    if not isinstance(scenario, Scenario):
        raise TypeError(f"scenario: expected Scenario, got {type(scenario).__name__}")
    s = scenario
    out: dict[str, Any] = {
        "name": s.name,
        "description": s.description,
        "tags": list(s.tags),
        "duration": s.duration,
        "dt": s.dt,
        "quaternion_sign": s.quaternion_sign,
        "initial": {"rotvec": list(s.initial_rotvec), "rate": list(s.initial_rate)},
        "reference": {
            "kind": s.reference.kind,
            "rotvec": list(s.reference.rotvec),
            "n": s.reference.n,
            "rate": list(s.reference.rate),
            **(
                {
                    "slew_rotvec": list(s.reference.slew_rotvec),
                    "max_rate": s.reference.max_rate,
                    "max_accel": s.reference.max_accel,
                    "max_jerk": s.reference.max_jerk,
                }
                if s.reference.kind == "eigenaxis-profile"
                else {}
            ),
        },
        "disturbance": [{"name": d.name, **d.kwargs} for d in s.disturbances],
        "spacecraft": {
            f.name: _plain(getattr(s.spacecraft, f.name))
            for f in dataclasses.fields(SpacecraftSpec)
            if getattr(s.spacecraft, f.name) is not None
        },
        "uncertainty": {"inertia_scale": list(s.uncertainty.inertia_scale)},
    }
    out["attitude_tolerance_deg"] = s.attitude_tolerance_deg
    out["position_tolerance_m"] = s.position_tolerance_m
    if s.sensors is not None:
        out["sensors"] = {
            f.name: _plain(getattr(s.sensors, f.name))
            for f in dataclasses.fields(SensorSpec)
            if getattr(s.sensors, f.name) is not None  # TOML has no null: unset keys are left out
        }
    if s.control_period is not None:
        out["control_period"] = s.control_period
    for k in ("keep_out", "keep_in"):
        if getattr(s, k):
            out[k] = [
                {
                    "body_axis": list(c.body_axis),
                    "inertial_direction": list(c.inertial_direction),
                    "half_angle_deg": c.half_angle_deg,
                }
                for c in getattr(s, k)
            ]
    if s.orbit is not None:
        out["orbit"] = {f.name: getattr(s.orbit, f.name) for f in dataclasses.fields(OrbitSpec)}
    if s.momentum_management is not None:
        mm = s.momentum_management
        out["momentum_management"] = {
            f.name: getattr(mm, f.name)
            for f in dataclasses.fields(MomentumManagementSpec)
            if getattr(mm, f.name) is not None  # unset thruster keys: their defaults
        }
    if s.faults:
        out["fault"] = [f.as_dict() for f in s.faults]
        out["reconfiguration"] = s.reconfiguration
    if s.dispersion is not None:
        out["dispersion"] = {
            f.name: getattr(s.dispersion, f.name) for f in dataclasses.fields(DispersionSpec)
        }
    if s.requirements:
        out["requirement"] = [
            {
                k: getattr(r, k)
                for k in _REQUIREMENT_KEYS
                if getattr(r, k) is not None
            }
            for r in s.requirements
        ]
    if s.detumble is not None:
        out["detumble"] = {
            f.name: _plain(getattr(s.detumble, f.name)) for f in dataclasses.fields(DetumbleSpec)
        }
    if s.sun_acquisition is not None:
        out["sun_acquisition"] = {
            f.name: _plain(getattr(s.sun_acquisition, f.name))
            for f in dataclasses.fields(SunAcquisitionSpec)
        }
    if s.proximity is not None:
        out["proximity"] = {
            f.name: _plain(getattr(s.proximity, f.name))
            for f in dataclasses.fields(ProximitySpec)
            if getattr(s.proximity, f.name) is not None
        }
    return out


def _plain(v: Any) -> Any:
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v
