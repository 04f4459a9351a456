"""Discrepancy: where the twin and a run disagree — residuals normalised by noise estimated from the data,
candidate effects fitted over twin replays, held-out selection, and the augmented model.

Takes a run and a twin; gives a verdict (`none`, named effects, or `unexplained`) and a model file.
"""
