"""The tuning study in PostgreSQL (``tuning.storage: postgresql://...``), as a cluster of several nodes keeps it.

Two tuning workers, each its own process, share one study on a PostgreSQL server the test starts and
stops: Debian's ``postgresql`` package, with the ``psycopg2`` driver of requirements-slurm.txt. Skipped
where either is absent.
"""

import glob
import os
import pwd
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.workflow


def server_folder() -> Path | None:
    """The folder of PostgreSQL's pg_ctl and initdb (Debian keeps them off the PATH, in /usr/lib/postgresql)."""
    found = [shutil.which("pg_ctl"), *sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"), reverse=True)]
    return next((Path(path).resolve().parent for path in found if path), None)


@pytest.fixture
def postgres():
    """The URL of a database on a PostgreSQL server of the test's own: a Unix socket in a folder of its own,
    no TCP port; stopped and deleted at the end."""
    binaries = server_folder()
    if binaries is None:
        pytest.skip("no PostgreSQL server here (Debian: apt-get install postgresql)")
    pytest.importorskip("psycopg2", reason="no psycopg2 (pip install -r requirements-slurm.txt)")
    as_server = []
    if os.geteuid() == 0:  # PostgreSQL refuses to run as root: as its own user
        try:
            pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("running as root, and no postgres user to run the server as")
        as_server = ["runuser", "-u", "postgres", "--"]
    folder = Path(tempfile.mkdtemp(prefix="optuna-postgres-"))
    if as_server:
        shutil.chown(folder, "postgres")
    data, started = folder / "data", False

    def run(*command):
        subprocess.run([*as_server, *map(str, command)], check=True, capture_output=True, timeout=120)

    try:
        run(binaries / "initdb", "-D", data, "-U", "optuna", "-A", "trust")
        options = f"-k {folder} -c listen_addresses=''"  # a socket in its own folder, no network
        run(binaries / "pg_ctl", "-D", data, "-l", folder / "server.log", "-o", options, "-w", "start")
        started = True
        yield f"postgresql://optuna@/postgres?host={folder}"
    finally:
        if started:
            run(binaries / "pg_ctl", "-D", data, "-m", "fast", "-w", "stop")
        shutil.rmtree(folder, ignore_errors=True)


def test_two_tuning_workers_share_one_study_in_postgresql(postgres):
    import optuna

    from hybridtwin.paper import tuning

    space = {"n_estimators": {"low": 5, "high": 30, "type": "int"}, "max_depth": {"low": 2, "high": 4, "type": "int"}}
    script = (
        "import sys, numpy as np\n"
        "from hybridtwin.paper import tuning\n"
        "rng = np.random.default_rng(0); X = rng.normal(size=(300, 3)); y = X[:, 0] + rng.normal(0, .1, 300)\n"
        f"tuning.tune(X, y, n_trials=8, n_folds=3, seed=3, storage=sys.argv[1], space={space!r},\n"
        "            worker=int(sys.argv[2]))\n"
    )
    # the same data, space, folds and seed: both workers join one study, each sampling with its own seed
    workers = [subprocess.Popen([sys.executable, "-c", script, postgres, str(worker)]) for worker in range(2)]
    assert all(worker.wait(timeout=300) == 0 for worker in workers)

    storage = tuning.open_storage(postgres)
    (summary,) = optuna.study.get_all_study_summaries(storage)
    study = optuna.load_study(study_name=summary.study_name, storage=storage)
    trials = study.get_trials()
    assert len(trials) >= 8
    assert [t.number for t in trials] == list(range(len(trials))), "no trial number lost"
    assert all(t.state in tuning.FINISHED for t in trials), "every trial of both workers finished"
    assert set(tuning.best_params(study, space, 8)) == set(space)
    storage.engine.dispose()  # before the server stops
