"""The densest lattice packing of superballs |x|^2p + |y|^2p + |z|^2p <= 1,
found by searching over all lattices: the independent check of what
`Crystal(lattice: Densest)` builds (docs/crystals.md).

A lattice with basis B packs the superball when every nonzero lattice
vector has norm at least 2 in the superball's own norm (the difference
body of a centrally symmetric body is the body doubled), so the densest
lattice packing minimises det B under those constraints. This searches
the nine entries of B by SLSQP from many random starts, with the
constraints on every combination of coefficients in [-2, 2], and prints
the largest packing fraction found.

    python3 examples/python/densest_lattice_search.py 1.05 1.5 2 3 5

needs numpy and scipy; about two seconds per value of p.
"""

import itertools
import sys
from math import gamma

import numpy as np
from scipy.optimize import minimize

COEFFICIENTS = np.array(
    [n for n in itertools.product(range(-2, 3), repeat=3) if n > (0, 0, 0)], float
)


def superball_volume(p):
    q = 2 * p
    return 8 * gamma(1 + 1 / q) ** 3 / gamma(1 + 3 / q)


def densest(p, starts=60, seed=1):
    q = 2 * p
    rng = np.random.default_rng(seed)

    def half_norms(x):
        vectors = COEFFICIENTS @ x.reshape(3, 3).T
        return (np.abs(vectors) ** q).sum(1) ** (1 / q) / 2 - 1

    best = 0.0
    # Far from admissible, the optimiser's trial steps overflow; those
    # starts end non-finite and are dropped.
    with np.errstate(all="ignore"):
        for _ in range(starts):
            start = 2 * np.eye(3) + rng.normal(0, 0.6, (3, 3))
            if np.linalg.det(start) < 0:
                start[:, 0] *= -1
            found = minimize(
                lambda x: np.linalg.det(x.reshape(3, 3)),
                start.ravel(),
                constraints=[{"type": "ineq", "fun": half_norms}],
                method="SLSQP",
                options={"maxiter": 500, "ftol": 1e-15},
            )
            # Scale until admissible, whatever the last step left.
            shortest = 1 + min(half_norms(found.x).min(), 0)
            volume = abs(np.linalg.det(found.x.reshape(3, 3))) / shortest**3
            if np.isfinite(volume) and volume > 0:
                best = max(best, superball_volume(p) / volume)
    return best


if __name__ == "__main__":
    for p in map(float, sys.argv[1:] or ["1.5", "2", "3", "5"]):
        print(f"p = {p}: densest lattice packing fraction found {densest(p):.10f}")
