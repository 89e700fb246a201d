"""Trajectory metrics (ATE, RPE, coverage-aware scores): pure, on geometry alone."""

from .coverage import Coverage
from .evaluation import Evaluation, evaluate
from .statistics import ErrorSeries

__all__ = ["Coverage", "ErrorSeries", "Evaluation", "evaluate"]
