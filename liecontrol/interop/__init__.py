"""Interoperability with the tools users already have.

* :mod:`~liecontrol.interop.basilisk` — Basilisk's attitude conventions ([BN] = Rᵀ, σ_B/N,
  Euler parameters, PRV, Euler-set names "321" ⇄ "ZYX");
* :mod:`~liecontrol.interop.twist_order` — (ω, v) ⇄ (v, ω) reordering of twists and 6×6 blocks
  for jaxlie, Sophus and spatialmath;
* :mod:`~liecontrol.interop.python_control` — the rigid-body attitude plant as a
  ``control.NonlinearIOSystem`` and its linearisation (needs the optional ``control`` package,
  extra ``[interop]``).

scipy's ``Rotation`` / ``RigidTransform`` need no module: ``SO3.from_scipy`` / ``as_scipy`` and
``SE3.from_scipy`` / ``as_scipy``, and every attitude argument accepts a ``Rotation`` directly.
See ``docs/conventions.md``.
"""

from . import basilisk, python_control, twist_order

__all__ = ["basilisk", "twist_order", "python_control"]
