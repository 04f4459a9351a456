"""Base: utilities every stage uses — atomic CSV/JSON I/O with precise errors (`csvio`), interpolation of
sampled signals (`signals`) and the lookup of shipped models and data (`resources`).

Takes files and arrays; gives validated arrays and paths. Imports nothing of the project but `twin.errors`.
"""
