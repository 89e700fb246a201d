"""The discrete Bayes filter of loop closure detection (Labbé & Michaud, T-RO 2013).

The state is which Working Memory location the current one revisits, or the virtual
"new place" hypothesis (id -1). The transition model spreads a location's belief over its
graph neighbours (RTAB-Map's Bayes/PredictionLC) and lets the virtual place keep 90 %; the
likelihood comes from tf-idf scores normalised by their mean and spread, so only a
location scoring well above the rest raises its belief.
"""

import numpy as np

NEW_PLACE = -1
# Bayes/PredictionLC: the virtual place's share, then a location's share for neighbours at
# graph distance 0, 1, 2, ...
PREDICTION_LC = (0.1, 0.36, 0.30, 0.16, 0.062, 0.0151, 0.00255, 0.000324, 2.5e-05, 1.3e-06, 4.8e-08, 1.5e-09)
VIRTUAL_PLACE_STAYS = 0.9


def likelihood(scores: np.ndarray) -> tuple[np.ndarray, float]:
    """Likelihood of each location and of the new place from tf-idf scores:
    ``(s - std) / mean`` for scores above mean + std, 1 otherwise; new place ``mean / std + 1``."""
    mean, std = float(scores.mean()), float(scores.std())
    if mean <= 0 or std <= 0:
        return np.ones(len(scores)), 1.0
    return np.where(scores >= mean + std, (scores - std) / mean, 1.0), mean / std + 1.0


class BayesFilter:
    """Posterior over location ids plus :data:`NEW_PLACE`. Locations join with no belief;
    a location that leaves the candidates (to Long-Term Memory) takes its belief with it."""

    def __init__(self):
        self.posterior: dict[int, float] = {NEW_PLACE: 1.0}

    def update(self, candidates: list[int], chain_position: np.ndarray, chain: np.ndarray,
               location_likelihood: np.ndarray, new_place_likelihood: float) -> dict[int, float]:
        """One predict-update step over ``candidates``.

        ``chain`` labels the odometry chain (map session) of each candidate and
        ``chain_position`` its order in it; neighbours are candidates of the same chain
        ``d`` positions apart.
        """
        previous = np.array([self.posterior.get(c, 0.0) for c in candidates])
        previous_new = self.posterior.get(NEW_PLACE, 0.0)
        distance = np.abs(chain_position[:, None] - chain_position[None, :])
        coefficients = np.asarray(PREDICTION_LC[1:])
        near = (distance < len(coefficients)) & (chain[:, None] == chain[None, :])
        transition = np.where(near, coefficients[np.minimum(distance, len(coefficients) - 1)], 0.0)
        transition *= (1.0 - PREDICTION_LC[0]) / transition.sum(axis=0, keepdims=True)
        prior = transition @ previous + (1.0 - VIRTUAL_PLACE_STAYS) / len(candidates) * previous_new
        prior_new = VIRTUAL_PLACE_STAYS * previous_new + PREDICTION_LC[0] * previous.sum()
        belief = np.append(prior * location_likelihood, prior_new * new_place_likelihood)
        belief /= belief.sum()
        self.posterior = dict(zip(candidates, belief[:-1].tolist()))
        self.posterior[NEW_PLACE] = float(belief[-1])
        return self.posterior
