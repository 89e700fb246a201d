"""Poses, cameras, trajectories and alignment."""
