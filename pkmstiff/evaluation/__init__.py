"""Evaluation layer: the quantity registry, workspace sections, evaluation requests with one statistics function,
exports and parameter sweeps."""
