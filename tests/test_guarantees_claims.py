"""Claims inside their assumptions (issue 25): the finite/fixed-time bounds (a start inside the
tolerance, a torque limit) and the consensus laws' scalar coupling gain."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from liecontrol.control.consensus import (
    AttitudeConsensus,
    CommunicationGraph,
    ConsensusAssumptionWarning,
    LeaderFollowerConsensus,
)
from liecontrol.control.finite_time import (
    BoundNotApplicable,
    FiniteTimeParams,
    FiniteTimeSO3,
    FixedTimeSO3,
    convergence_time_bound,
)

J = np.diag([8.0, 10.0, 12.0])
PRM = FiniteTimeParams(
    k1=0.2, k2=0.2, r=0.5, eps=0.05, c1=0.0, c2=0.1, rho=0.5, eps_s=1e-3, c3=0.1, mu=1.5
)


@pytest.mark.parametrize("s0", [0.0, 1e-4, 0.004, 0.006, 0.01])
def test_bound_is_zero_for_a_start_inside_the_tolerance(s0):
    """θ₀ = 0.005 rad inside tol = 0.01 rad with a small ‖s(0)‖: the comparison angle rises a
    little and falls back without leaving the tolerance — the bound is 0 (it used to raise
    "did not reach")."""
    assert convergence_time_bound(PRM, 0.01, 0.005, s0) == 0.0
    assert convergence_time_bound(PRM, 0.01, 0.0, s0) == 0.0


def test_bound_for_a_start_inside_that_leaves_the_tolerance_is_positive():
    """A large ‖s(0)‖ carries the comparison angle out of the tolerance: a positive bound."""
    t = convergence_time_bound(PRM, 0.01, 0.005, 0.05)
    assert math.isfinite(t) and t > 0.0


def test_fixed_time_bound_not_applicable_with_a_torque_limit():
    """The fixed-time bound assumes unbounded torque: with the actuator's limit it is reported
    as not applicable (nan and a BoundNotApplicable warning), without one it is finite."""
    c = FixedTimeSO3(J, 0.2, 0.2, 0.1, c3=0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        T = c.settling_bound(0.01)
    assert math.isfinite(T) and T > 0.0
    with pytest.warns(BoundNotApplicable, match="^max_torque"):
        assert math.isnan(c.settling_bound(0.01, max_torque=1.0))
    with pytest.warns(BoundNotApplicable):
        assert math.isnan(convergence_time_bound(PRM, 0.01, 1.0, 0.1, max_torque=[1.0, 1.0, 2.0]))
    f = FiniteTimeSO3(J, 0.2, 0.2, 0.1)
    with pytest.warns(BoundNotApplicable):
        assert math.isnan(f.convergence_time_bound(0.01, 1.0, 0.1, max_torque=0.5))
    with pytest.raises(ValueError, match="^max_torque"):
        convergence_time_bound(PRM, 0.01, max_torque=0.0)


def test_finite_time_docs_state_the_assumptions():
    import liecontrol.control.finite_time as ft

    for text in (
        ft.__doc__,
        ft.convergence_time_bound.__doc__,
        FixedTimeSO3.settling_bound.__doc__,
    ):
        assert "unbounded torque" in text


@pytest.mark.parametrize("law", [AttitudeConsensus, LeaderFollowerConsensus])
@pytest.mark.parametrize(
    "k_R",
    [
        [1.0, 2.0, 3.0],
        np.diag([2.0, 2.0, 3.0]),
        [[2.0, 0.5, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 1.0]],
    ],
)
def test_consensus_warns_on_vector_or_matrix_k_R(law, k_R):
    """A vector/matrix k_R breaks the Lyapunov cancellation: ConsensusAssumptionWarning naming
    k_R; the law still runs."""
    g = (
        CommunicationGraph.tree([-1, 0, 1])
        if law is LeaderFollowerConsensus
        else CommunicationGraph.ring(4)
    )
    with pytest.warns(ConsensusAssumptionWarning, match="^k_R"):
        c = law(g, J, k_R, 1.0)
    assert isinstance(c.k_R, np.ndarray)


@pytest.mark.parametrize("k_R", [2.0, [2.0, 2.0, 2.0], 2.0 * np.eye(3)])
def test_consensus_scalar_k_R_accepted_silently(k_R):
    """A scalar (or a multiple of the identity, folded to its scalar) is inside the argument."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = AttitudeConsensus(CommunicationGraph.ring(4), J, k_R, np.diag([1.0, 2.0, 3.0]))
    assert c.k_R == 2.0 and isinstance(c.k_R, float)


def test_consensus_docs_state_the_assumptions():
    import liecontrol.control.consensus as cs

    doc = cs.__doc__
    assert "first-order" in doc and "at rest" in doc and "scalar" in doc
    assert "first-order" in AttitudeConsensus.__doc__ and "tree" in LeaderFollowerConsensus.__doc__
