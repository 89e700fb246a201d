"""Runs over a sequence (a pipeline's, or an estimate file's replay), driven, diagnosed, scored
and reported by one service (:mod:`.service`) that ``record`` and ``benchmark`` share.

This layer joins the pipelines to the evaluation and the diagnosis: they stay ignorant of each other.
"""
