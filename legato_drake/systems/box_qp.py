"""A dense primal active-set solver for the IK's small box-constrained QPs.

    minimize  1/2 x^T H x - g^T x    subject to  lb <= x <= ub

with ``H`` symmetric positive definite and n up to a few dozen: the shape of both stages of
``WholeBodyIK`` (its joint velocity bounds are a box). A general solver pays for its
generality at every call (OSQP through ``MathematicalProgram`` costs 0.1-1 ms here, and stops
at a tolerance); this one exploits the shape. Its working set is the set of variables fixed
at a bound; each iteration minimizes over the free variables (one linear solve), then steps
there or to the first bound in the way (Nocedal & Wright, *Numerical Optimization*,
Algorithm 16.3). It ends at the exact optimum of its final working set. Warm started with the
previous solve's active set (the IK's bounds change little in 10 ms), it typically takes one
or two iterations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_TOLERANCE = 1e-13
"""Bound violations and multipliers below this, relative to the largest linear term (the
IK's second stage holds its task by a 1e6 penalty: its terms reach 1e6), count as zero."""

_GUESSES = 6
"""Primal-dual updates tried before the primal active-set method takes over."""


@dataclass
class BoxQpResult:
    """The solution, its active set and how it was found."""

    x: np.ndarray
    active: np.ndarray
    """Per variable: -1 at its lower bound, +1 at its upper bound, 0 free (a warm start)."""
    optimal: bool
    """False only where the iteration limit stopped it: ``x`` is then feasible, not optimal."""
    iterations: int


def _signs(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The ``active`` vector of a working set (a pinned variable, both, reads -1)."""
    return np.where(lower, -1, np.where(upper, 1, 0))


def _working_set_minimizer(H: np.ndarray, g: np.ndarray, lower: np.ndarray,
                           upper: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> np.ndarray:
    """The minimizer with the ``lower``/``upper`` variables at their bounds."""
    x = np.where(lower, lb, np.where(upper, ub, 0.0))
    free = np.flatnonzero(~(lower | upper))
    if free.size:
        rows = H[free]
        # x is zero on the free variables, so rows @ x is what the fixed ones contribute.
        x[free] = np.linalg.solve(rows[:, free], g[free] - rows @ x)
    return x


def solve_box_qp(H: np.ndarray, g: np.ndarray, lb: np.ndarray, ub: np.ndarray,
                 x0: np.ndarray, active: np.ndarray | None = None,
                 max_iterations: int = 60) -> BoxQpResult:
    """Solves the QP of the module doc. ``active`` (a previous result's, else the variables
    ``x0`` leaves its box by) is the first guess of the working set.

    First up to ``_GUESSES`` primal-dual active-set updates (Hintermueller, Ito & Kunisch
    2002: fix what the last minimizer put out of bounds, free what pulls away from its
    bound; they change many variables at once and usually end in one or two), then, where
    those have not settled, the primal active-set method from the clipped last iterate,
    which cannot cycle on a strictly convex QP and ends at its exact optimum."""
    lb, ub = np.asarray(lb, dtype=float), np.asarray(ub, dtype=float)
    pinned = lb >= ub
    tolerance = _TOLERANCE * (1.0 + float(np.max(np.abs(g))))
    if active is None:
        lower, upper = (x0 < lb) | pinned, (x0 > ub) | pinned
    else:
        lower = ((active < 0) & np.isfinite(lb)) | pinned
        upper = ((active > 0) & np.isfinite(ub)) | pinned
    x = x0
    for iteration in range(1, _GUESSES + 1):
        x = _working_set_minimizer(H, g, lower, upper, lb, ub)
        gradient = H @ x - g
        free = ~(lower | upper)
        new_lower = (free & (x < lb - tolerance)) | (lower & (gradient > -tolerance)) | pinned
        new_upper = (free & (x > ub + tolerance)) | (upper & (gradient < tolerance)) | pinned
        if np.array_equal(new_lower, lower) and np.array_equal(new_upper, upper):
            return BoxQpResult(np.minimum(np.maximum(x, lb), ub),
                               _signs(lower, upper), True, iteration)
        lower, upper = new_lower, new_upper
    return _primal_active_set(H, g, lb, ub, x, pinned, tolerance, max_iterations)


def _primal_active_set(H: np.ndarray, g: np.ndarray, lb: np.ndarray, ub: np.ndarray,
                       x0: np.ndarray, pinned: np.ndarray, tolerance: float,
                       max_iterations: int) -> BoxQpResult:
    """Nocedal & Wright's Algorithm 16.3 from ``x0`` clipped into the box."""
    x = np.minimum(np.maximum(x0, lb), ub)
    lower, upper = (x <= lb) | pinned, (x >= ub) | pinned
    at_minimizer = False
    for iteration in range(1, max_iterations + 1):
        if not at_minimizer:
            step = _working_set_minimizer(H, g, lower, upper, lb, ub) - x
            # Move toward the working set's minimizer until a free variable meets its bound
            # (steps within rounding of zero block nothing).
            moving = ~(lower | upper) & (np.abs(step) > 1e-14 * (1.0 + np.abs(x)))
            to_bound = np.full(x.shape, np.inf)
            rising, falling = moving & (step > 0), moving & (step < 0)
            to_bound[rising] = (ub[rising] - x[rising]) / step[rising]
            to_bound[falling] = (lb[falling] - x[falling]) / step[falling]
            blocking = int(np.argmin(to_bound))
            if to_bound[blocking] >= 1.0:
                x, at_minimizer = x + step, True
            else:
                x = x + max(float(to_bound[blocking]), 0.0) * step
                if step[blocking] > 0:
                    x[blocking], upper[blocking] = ub[blocking], True
                else:
                    x[blocking], lower[blocking] = lb[blocking], True
                continue
        # At the working set's minimizer: the fixed variables' multipliers decide. At a lower
        # bound the objective must not fall as x_i rises (gradient >= 0); at an upper bound,
        # as it falls (gradient <= 0). A variable with lb == ub stays fixed.
        gradient = H @ x - g
        wrong = np.where(lower & ~pinned, -gradient, 0.0) + \
            np.where(upper & ~pinned, gradient, 0.0)
        worst = int(np.argmax(wrong))
        if wrong[worst] <= tolerance:
            return BoxQpResult(x, _signs(lower, upper), True,
                               iteration + _GUESSES)
        lower[worst] = upper[worst] = False
        at_minimizer = False
    return BoxQpResult(x, _signs(lower, upper), False,
                       max_iterations + _GUESSES)
