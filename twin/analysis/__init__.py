"""Analysis: what is done with runs — replay on the twin, identification of K_R and K_q, offline compensation,
the check of a compensated run, and the discrepancy workflow.

Takes runs and a twin; gives stiffnesses, compensated paths, gains, verdicts and augmented models.
"""
