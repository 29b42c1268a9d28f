"""Reproduce Xu (2014)'s impact slider–crank: Figs. 12–15 and Table 5 (docs/model.md,
'The paper's case').

A thin script over the public API: it runs the ``jaxbearing xu2014`` command
(`jaxbearing.cli`), which simulates 0–0.2 s with and without impact, prints a summary and
Table 5 against the paper, and writes CSV, summary.json and the figures (see `jaxbearing.report`).

    python studies/xu2014.py                    # full run into results/xu2014 (about a minute)
    python studies/xu2014.py --quick            # 0–0.12 s, 10 µs sampling, no timing rerun
    python studies/xu2014.py --out DIR [extra options of `jaxbearing xu2014`]
"""

from __future__ import annotations

import argparse
import sys

QUICK = ["--t1", "0.12", "--samples", "12001", "--no-rerun"]  # covers the first impact and Table 5


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--quick", action="store_true", help="short run for tests: " + " ".join(QUICK)
    )
    parser.add_argument("--out", default="results/xu2014", help="output folder")
    args, extra = parser.parse_known_args(argv)

    from jaxbearing import cli

    return cli.main(["xu2014", "--out", args.out] + (QUICK if args.quick else []) + extra)


if __name__ == "__main__":
    sys.exit(main())
