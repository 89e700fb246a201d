"""SLAM pipelines and the events they emit."""
