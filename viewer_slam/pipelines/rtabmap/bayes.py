"""The discrete Bayes filter of loop closure detection (Labbé & Michaud, T-RO 2013).

The state is which Working Memory location the current one revisits, or the virtual
place (id -1: "a new place"). As RTAB-Map's BayesFilter does, the prediction spreads each
location's belief over its graph neighbours by Bayes/PredictionLC (loop closure links
join a location's own margin), the virtual place keeps Bayes/VirtualPlacePriorThr of its
belief, and the likelihood comes from the tf-idf scores normalised by the mean and
standard deviation of the non-zero ones (Rtabmap::adjustLikelihood). The loop closure
hypothesis is the location of highest posterior, valued at the sum of all loop closure
probabilities, ``1 - P(virtual place)``.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

VIRTUAL_PLACE = -1
# Bayes/PredictionLC: the virtual place's share of a location's belief, then the location's
# own share and its neighbours' at graph margins 1, 2, ...
PREDICTION_LC = (
    0.1,
    0.36,
    0.30,
    0.16,
    0.062,
    0.0151,
    0.00255,
    0.000324,
    2.5e-05,
    1.3e-06,
    4.8e-08,
    1.2e-09,
    1.9e-11,
    2.2e-13,
    1.7e-15,
    8.5e-18,
    2.9e-20,
    6.9e-23,
)
VIRTUAL_PLACE_PRIOR = 0.9  # Bayes/VirtualPlacePriorThr
PREDICTION_MARGINS = len(PREDICTION_LC) - 1
LIKELIHOOD_EPSILON = 1e-4  # Rtabmap::adjustLikelihood's epsilon
NORMALISATION_TOLERANCE = 1e-4  # BayesFilter::normalize leaves a column alone this close to its target

# neighbours(location) -> {location: graph margin}, the location itself at margin 0
Neighbourhood = Callable[[int], dict[int, int]]


def adjusted_likelihood(scores: np.ndarray) -> tuple[np.ndarray, float]:
    """Rtabmap::adjustLikelihood: each location's likelihood and the virtual place's.

    With ``mean`` and ``std`` (sample standard deviation) of the non-zero scores, a score
    above ``mean + std`` becomes ``(score - (std - 1e-4)) / mean`` and every other one 1.
    The virtual place gets ``mean / std + 1`` whenever some score is non-zero and ``std`` is
    above 1e-4, whether or not a score stands out (0.23.8 takes the maximum over every
    location, as its debug line "mean=…, stdDev=…, max=…" shows), and 2 otherwise.
    """
    scores = np.asarray(scores, float)
    nonzero = scores[scores > 0]
    mean = float(nonzero.mean()) if len(nonzero) else 0.0
    std = float(nonzero.std(ddof=1)) if len(nonzero) > 1 else 0.0
    high = (scores > mean + std) & (mean != 0)
    location = np.where(high, (scores - (std - LIKELIHOOD_EPSILON)) / (mean or 1.0), 1.0)
    virtual = mean / std + 1.0 if std > LIKELIHOOD_EPSILON and len(nonzero) else 2.0
    return location, virtual


def prediction_matrix(ids: Sequence[int], neighbours: Neighbourhood) -> np.ndarray:
    """BayesFilter::generatePrediction over ``[VIRTUAL_PLACE, *ids]``: column ``j`` is how
    the belief of state ``j`` spreads to the states of each row.

    A location gives PREDICTION_LC[0] to the virtual place and PREDICTION_LC[m + 1] to each
    candidate ``m`` links away; the share of neighbours that are not candidates stays on the
    location itself, and a column that sums to more than ``1 - PREDICTION_LC[0]`` is scaled
    down to it. Locations joined by a loop closure (margin 0) share one column pattern.
    """
    size = len(ids) + 1
    index = {location: i + 1 for i, location in enumerate(ids)}
    matrix = np.zeros((size, size))
    matrix[0, 0] = VIRTUAL_PLACE_PRIOR if size > 1 else 1.0
    matrix[1:, 0] = (1.0 - VIRTUAL_PLACE_PRIOR) / max(size - 1, 1)
    spread = 1.0 - PREDICTION_LC[0]
    total = sum(PREDICTION_LC)
    floor = min(PREDICTION_LC)
    done: set[int] = set()
    for location in ids:
        if location in done:
            continue
        margins = {i: m for i, m in neighbours(location).items() if i in index}
        for same_place in [i for i, m in margins.items() if m == 0]:
            column = index[same_place]
            for other, margin in margins.items():
                matrix[index[other], column] = PREDICTION_LC[margin + 1]
            added = matrix[1:, column].sum()
            if added < total - PREDICTION_LC[0]:
                matrix[column, column] += total - PREDICTION_LC[0] - added
                added = total - PREDICTION_LC[0]
            if abs(added - spread) > NORMALISATION_TOLERANCE:
                matrix[1:, column] *= spread / added
                matrix[1:, column][matrix[1:, column] < floor] = 0.0
            matrix[0, column] = PREDICTION_LC[0]
            done.add(same_place)
    return matrix


@dataclass
class Hypothesis:
    """The location of highest posterior and the sum of all loop closure probabilities."""

    location: int
    value: float


def highest_hypothesis(posterior: dict[int, float]) -> Hypothesis | None:
    """Rtabmap::process: the location of highest posterior (the newest among equals), valued
    ``1 - P(virtual place)``; None when no location has any belief."""
    best, best_value = None, 0.0
    for location in sorted(posterior, reverse=True):
        if location != VIRTUAL_PLACE and posterior[location] > best_value:
            best, best_value = location, posterior[location]
    if best is None:
        return None
    return Hypothesis(best, 1.0 - posterior.get(VIRTUAL_PLACE, 0.0))


class BayesFilter:
    """Posterior over location ids plus :data:`VIRTUAL_PLACE`. As BayesFilter::updatePosterior,
    the first update starts from a belief of 1 in every state (the virtual place and each
    candidate alike: nothing is known yet); later, a location joins with no belief, and one
    that leaves the candidates (to Long-Term Memory) takes its belief with it."""

    def __init__(self):
        self.posterior: dict[int, float] = {}

    def update(
        self, ids: Sequence[int], neighbours: Neighbourhood, location_likelihood: np.ndarray, virtual_likelihood: float
    ) -> dict[int, float]:
        """One predict-update step over the candidate locations ``ids``."""
        states = [VIRTUAL_PLACE, *ids]
        previous = np.array([self.posterior.get(state, 0.0) if self.posterior else 1.0 for state in states])
        belief = prediction_matrix(ids, neighbours) @ previous
        belief *= np.append(virtual_likelihood, location_likelihood)
        if belief.sum() > 0:
            belief /= belief.sum()
        self.posterior = dict(zip(states, belief.tolist()))
        return self.posterior
