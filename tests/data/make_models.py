"""Make tests/data/models/ again: the workflow on tests/data/models.yaml in a scratch folder, its models copied.

python tests/data/make_models.py
"""

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

with tempfile.TemporaryDirectory() as scratch:
    command = ["snakemake", "-s", str(ROOT / "Snakefile"), "-d", scratch, "--configfile", str(HERE / "models.yaml")]
    subprocess.run([sys.executable, "-m", *command, "--cores", "2", "--quiet"], check=True)
    shutil.rmtree(HERE / "models", ignore_errors=True)
    shutil.copytree(Path(scratch) / "results" / "models", HERE / "models")
    production = Path(scratch) / "results" / "demo" / "production.csv"
    shutil.copy(production, HERE / "production_head.csv")
    lines = (HERE / "production_head.csv").read_text().splitlines()
    (HERE / "production_head.csv").write_text("\n".join(lines[:401]) + "\n")  # the first 400 parts
