"""Trajectory metrics (ATE, RPE, coverage-aware scores) and reports."""

from .coverage import Coverage
from .evaluation import Evaluation, evaluate
from .statistics import ErrorSeries

__all__ = ["Coverage", "ErrorSeries", "Evaluation", "evaluate"]
