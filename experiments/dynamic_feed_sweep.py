"""Feed sweep of the quasi-static twin against the dynamic MuJoCo plant (docs/dynamic-plant.md).

Run: `.venv/bin/python experiments/dynamic_feed_sweep.py [OUT.png]` (default docs/figures/feed_sweep.png).
Prints the Markdown table and the feed at which the quasi-static assumption breaks.
"""

from __future__ import annotations

import sys

from twin.analysis.replay import replay
from twin.lab.dynamic.sweep import breaking_feed, feed_sweep, sweep_table, write_sweep_figure


def main() -> int:
    out = sys.argv[1] if len(sys.argv) > 1 else "docs/figures/feed_sweep.png"
    rows = feed_sweep(replay, seed=7, progress=sys.stderr)
    print(sweep_table(rows))
    feed = breaking_feed(rows)
    print(f"quasi-static assumption breaks at: {feed if feed is not None else 'none of these'} m/min")
    print(f"figure: {write_sweep_figure(rows, out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
