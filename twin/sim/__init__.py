"""Sim: the quasi-static twin — the compliant robot (robot stage) pressed against the sheet force field
(process stage), solved to equilibrium per sample, and its flange force sensor.

Takes a commanded path; gives the tool's equilibrium path, the sheet force and the joint states (`SimResult`).
"""
