"""Per-rule cost of a finished run, from Snakemake's benchmark files, as a Markdown table.

snakemake --cores 2 && python benchmarks/workflow_timing.py results/benchmarks
"""

import sys
from pathlib import Path

import pandas as pd


def main(folder: str = "results/benchmarks") -> None:
    rows = []
    for path in sorted(Path(folder).glob("*.tsv")):
        bench = pd.read_csv(path, sep="\t")
        rows.append({"rule": path.stem, "seconds": bench["s"].iloc[-1], "max_rss_mb": bench["max_rss"].iloc[-1]})
    table = pd.DataFrame(rows).sort_values("seconds", ascending=False)
    print("| rule | wall time [s] | peak memory [MB] |\n|---|---:|---:|")
    for row in table.itertuples():
        print(f"| {row.rule} | {row.seconds:.1f} | {row.max_rss_mb:.0f} |")
    print(f"| **sum of rules** | {table['seconds'].sum():.1f} | |")


if __name__ == "__main__":
    main(*sys.argv[1:])
