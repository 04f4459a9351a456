"""Discrepancy: where the twin and a run disagree, which effects explain it, and what is left.

Modules, in data-flow order: `residuals` (noise from the data, folds), `context` (the linearised replay),
`families` (effect families with vector parameters, one registry), `fitting` (joint least squares,
uncertainties, held-out error), `significance`, `selection` (forward selection, BIC, ambiguity),
`effect_model` (the named families as the twin's effects, replayed and refitted), `carry` (the named families
carried into the twin stage by stage, the instruments' on their own where the effects' form fails), `floor` (what a
learned cell leaves on its own clean runs, and what each family takes of it), `consistency` (whether
the named families account for every stream's gap, leaving no structure), `signature` (the remainder in words),
`search` (the workflow), `summary` (its JSON document). Notes: docs/discrepancy.md.
"""
