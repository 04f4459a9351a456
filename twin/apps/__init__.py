"""Apps: the end-to-end jobs built from the stages — the thesis demo, its report and the benchmark.

Takes an output folder; gives reports, figures, recordings and benchmark ratios.
"""
