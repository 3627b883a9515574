"""Attitude estimation: the UKF family of Wang et al. 2015 and manifold filters.

See ``docs/estimators.md``. All filters share the interface of :class:`Filter`
(``predict(u, dt)``, ``update(z)``, ``x``, ``P``, ``S``, ``innovation``, ``diagnostics``).
"""

from .base import Filter, psd_sqrt
from .cholesky import NotPositiveDefiniteError, cholupdate, nearest_pd_sqrt, tria
from .istsrukf import ISTSRUKF
from .manifold_ukf import ManifoldUKF
from .mekf import MEKF, numerical_error_transition
from .models import (
    GyroAttitudeModel,
    GyrolessAttitudeModel,
    euler_rpy_from_quaternion,
    euler_rpy_jacobian,
    wrap_angle,
)
from .srukf import SRUKF
from .stukf import STUKF, FadingState, StrongTrackingParams, fading_factors
from .ukf import UKF
from .unscented import UTWeights, sigma_points, unscented_transform, ut_weights

__all__ = [
    "Filter",
    "psd_sqrt",
    "NotPositiveDefiniteError",
    "cholupdate",
    "nearest_pd_sqrt",
    "tria",
    "UKF",
    "SRUKF",
    "STUKF",
    "ISTSRUKF",
    "ManifoldUKF",
    "MEKF",
    "numerical_error_transition",
    "StrongTrackingParams",
    "FadingState",
    "fading_factors",
    "GyrolessAttitudeModel",
    "GyroAttitudeModel",
    "euler_rpy_from_quaternion",
    "euler_rpy_jacobian",
    "wrap_angle",
    "UTWeights",
    "ut_weights",
    "sigma_points",
    "unscented_transform",
]
