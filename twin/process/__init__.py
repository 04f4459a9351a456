"""Process: what the tool does to the sheet — the ideal tool path and its generators (`path`), FE force
histories (loader with a declared symmetry, stand-in generator) and the stateful sheet force field (`field`, on
the formed profile of `formed_profile` and the per-pass tables of `pass_tables`).

Takes path parameters and an FE export; gives the commanded path U_ID and the force on the tool at any position.
"""
