"""Runs over a sequence (a pipeline's, or an estimate file's replay), scored and reported.

This layer joins the pipelines to the evaluation: both stay ignorant of each other.
"""
