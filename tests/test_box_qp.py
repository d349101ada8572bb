"""The IK's box-QP solver: feasible, KKT-optimal, as good as a general solver, warm starts."""

import numpy as np
import pytest
from pydrake.solvers import MathematicalProgram, Solve

from legato_drake.systems.box_qp import solve_box_qp


def _problem(rng, n, rank=None):
    """A random box QP shaped like the IK's: H = J^T J + eps I (J of ``rank`` rows) or a
    well-conditioned H; bounds around zero that cut the unconstrained optimum."""
    if rank is None:
        M = rng.normal(size=(n, n))
        H = M.T @ M + 0.1 * np.eye(n)
    else:
        J = rng.normal(size=(rank, n))
        H = J.T @ J + 1e-6 * np.eye(n)
    g = rng.normal(size=n) * 3.0
    lb = -rng.uniform(0.05, 1.0, n)
    ub = rng.uniform(0.05, 1.0, n)
    return H, g, lb, ub


def _objective(H, g, x):
    return 0.5 * x @ H @ x - g @ x


def _assert_kkt(H, g, lb, ub, x, tol=1e-7):
    assert np.all(x >= lb) and np.all(x <= ub)
    gradient = H @ x - g
    free = (x > lb + 1e-12) & (x < ub - 1e-12)
    scale = 1.0 + np.max(np.abs(g))
    assert np.all(np.abs(gradient[free]) <= tol * scale)
    assert np.all(gradient[(x <= lb) & (lb < ub)] >= -tol * scale)
    assert np.all(gradient[(x >= ub) & (lb < ub)] <= tol * scale)


def _reference(H, g, lb, ub):
    """Drake's general QP solver on the same problem."""
    prog = MathematicalProgram()
    x = prog.NewContinuousVariables(len(g))
    prog.AddQuadraticCost(H, -g, x, is_convex=True)
    prog.AddBoundingBoxConstraint(lb, ub, x)
    result = Solve(prog)
    assert result.is_success()
    return result.GetSolution(x)


@pytest.mark.parametrize("rank", [None, 6])
def test_random_problems_are_solved_to_optimality(rank):
    rng = np.random.default_rng(0)
    for trial in range(60):
        n = int(rng.integers(7, 15)) if rank else int(rng.integers(2, 15))
        H, g, lb, ub = _problem(rng, n, rank)
        x0 = np.linalg.solve(H, g)
        result = solve_box_qp(H, g, lb, ub, x0)
        assert result.optimal, trial
        _assert_kkt(H, g, lb, ub, result.x)
        reference = _reference(H, g, lb, ub)
        assert _objective(H, g, result.x) <= _objective(H, g, reference) + 1e-7


def test_a_warm_start_changes_the_iterations_not_the_solution():
    rng = np.random.default_rng(1)
    for _ in range(30):
        H, g, lb, ub = _problem(rng, 10, rank=6)
        cold = solve_box_qp(H, g, lb, ub, np.linalg.solve(H, g))
        warm = solve_box_qp(H, g, lb, ub, np.zeros(10), active=cold.active)
        assert warm.iterations == 1
        np.testing.assert_allclose(warm.x, cold.x, atol=1e-9)
        # A wrong guess (every variable at its upper bound) still ends at the optimum.
        wrong = solve_box_qp(H, g, lb, ub, np.zeros(10), active=np.ones(10))
        _assert_kkt(H, g, lb, ub, wrong.x)
        np.testing.assert_allclose(wrong.x, cold.x, atol=1e-6)


def test_pinned_and_unbounded_variables():
    """lb == ub fixes a variable (the IK's braking at a limit); infinite bounds never bind."""
    H = np.diag([1.0, 2.0, 3.0])
    g = np.array([5.0, -5.0, 1.0])
    lb = np.array([0.2, -np.inf, -1.0])
    ub = np.array([0.2, np.inf, 1.0])
    result = solve_box_qp(H, g, lb, ub, np.zeros(3))
    np.testing.assert_allclose(result.x, [0.2, -2.5, 1.0 / 3.0], atol=1e-12)
    assert result.optimal and result.active[0] != 0 and result.active[1] == 0


def test_an_interior_optimum_is_the_linear_solve():
    H = np.array([[2.0, 0.5], [0.5, 1.0]])
    g = np.array([0.1, 0.2])
    result = solve_box_qp(H, g, -np.ones(2), np.ones(2), np.zeros(2))
    np.testing.assert_allclose(result.x, np.linalg.solve(H, g), atol=1e-14)
    assert result.iterations == 1 and not result.active.any()
