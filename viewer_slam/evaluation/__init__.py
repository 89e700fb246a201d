"""Trajectory metrics (ATE, RPE, coverage-aware scores) and reports."""
