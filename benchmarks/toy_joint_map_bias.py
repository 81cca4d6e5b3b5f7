"""Scalar toy of the gust fit's bias (not a test): y_i = g (a_i + u_i) + e_i, u_i ~ N(0, s^2) latent.

Joint MAP over (g, u) profiles to sum (y - g a)^2 / (sigma^2 + g^2 s^2), which a larger |g| lowers;
the marginal likelihood adds N log(sigma^2 + g^2 s^2) and is unbiased. Prints the mean and sd of
both estimates of g (truth 1) over replications.

Run: python benchmarks/toy_joint_map_bias.py [--reps 200]
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.optimize import minimize_scalar


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=200)
    a = ap.parse_args()
    rng = np.random.default_rng(0)
    n, s, sigma = 300, 0.7, 0.2
    joint, marginal = [], []
    for _ in range(a.reps):
        x = rng.normal(0, 1, n)
        y = x + rng.normal(0, s, n) + rng.normal(0, sigma, n)

        def profiled(g: float, x=x, y=y) -> float:
            return float(np.sum((y - g * x) ** 2) / (sigma**2 + g**2 * s**2))

        joint.append(minimize_scalar(profiled, bounds=(0.1, 5), method="bounded").x)
        marginal.append(minimize_scalar(lambda g: profiled(g) + n * np.log(sigma**2 + g**2 * s**2),
                                        bounds=(0.1, 5), method="bounded").x)
    print(f"truth g = 1: joint MAP {np.mean(joint):.2f} +- {np.std(joint):.2f}, "
          f"marginal ML {np.mean(marginal):.2f} +- {np.std(marginal):.2f} ({a.reps} replications)")


if __name__ == "__main__":
    main()
