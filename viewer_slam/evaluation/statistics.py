"""Per-pose error series and their summary statistics."""

from dataclasses import dataclass

import numpy as np


@dataclass
class ErrorSeries:
    """One error per pose (or pose pair), stamped with the estimate's timestamps."""

    timestamps: np.ndarray
    errors: np.ndarray

    def stats(self) -> dict[str, float | int]:
        """rmse, mean, median, std (population, as TUM and evo), min, max and n."""
        errors = self.errors
        return {
            "rmse": float(np.sqrt(np.mean(errors**2))),
            "mean": float(np.mean(errors)),
            "median": float(np.median(errors)),
            "std": float(np.std(errors)),
            "min": float(np.min(errors)),
            "max": float(np.max(errors)),
            "n": int(len(errors)),
        }


def stats_or_none(series: ErrorSeries | None) -> dict[str, float | int] | None:
    return None if series is None or len(series.errors) == 0 else series.stats()
