"""Pose-graph optimisation with GTSAM."""
