"""Sim: the quasi-static twin — the compliant robot (robot stage) pressed against the sheet force field
(process stage), solved to equilibrium per sample (`quasi_static`, with the Newton and joint-friction solve in
`equilibrium`), its result (`result`) and its flange force sensor (`ft_sensor`).

Takes a commanded path; gives the tool's equilibrium path, the sheet force and the joint states (`SimResult`).
"""
