"""hybridtwin.paper.tuning: the Optuna study's search space, journal, resumption, workers and warm start."""

import json
import logging
import threading
from pathlib import Path

import numpy as np
import optuna
import pytest

from hybridtwin.crossval import (
    cross_validate,
)
from hybridtwin.paper import residual, tuning
from tests.conftest import says

optuna.logging.set_verbosity(optuna.logging.WARNING)

TABLE4 = {
    "n_estimators",
    "max_depth",
    "learning_rate",
    "subsample",
    "colsample_bytree",
    "min_child_weight",
    "gamma",
    "reg_alpha",
    "reg_lambda",
}


def test_search_space_overrides():
    space = tuning.search_space({"n_estimators": {"low": 5, "high": 20}, "gamma": {"high": 1.0}})
    assert set(space) == TABLE4
    assert space["n_estimators"] == {"low": 5, "high": 20, "type": "int"}
    assert space["gamma"] == {"low": 0.0, "high": 1.0, "type": "float"}
    assert space["learning_rate"] == tuning.DEFAULT_SEARCH_SPACE["learning_rate"]
    # the default is not modified
    assert tuning.DEFAULT_SEARCH_SPACE["n_estimators"] == {"low": 50, "high": 600, "type": "int"}
    assert tuning.search_space(None) == tuning.DEFAULT_SEARCH_SPACE
    with pytest.raises(ValueError):
        tuning.search_space({"max_depth": {"low": 8, "high": 3}})


def test_hyperparameter_table_has_table4_parameters():
    space = tuning.search_space(None)
    params = {name: spec["low"] for name, spec in space.items()}
    table = tuning.hyperparameter_table(params, space)
    assert len(table) == 9
    assert set(table["xgboost_name"]) == TABLE4
    assert table["parameter"].notna().all() and table["parameter"].nunique() == 9
    row = table.set_index("xgboost_name").loc["learning_rate"]
    assert (row["search_low"], row["search_high"], row["log_scale"]) == (0.005, 0.3, True)
    assert table.set_index("xgboost_name").loc["max_depth", "value"] == 2


def test_the_study_tunes_on_a_sample_of_the_support_only_beyond_max_rows_and_says_so():
    inside = np.zeros(1000, bool)
    inside[::2] = True  # 500 in-support parts
    rows, said = tuning.tuning_rows(inside, 1000, seed=3)
    np.testing.assert_array_equal(rows, np.flatnonzero(inside))
    says(said, "CV RMSE", "500 in-support")
    rows, said = tuning.tuning_rows(inside, 200, seed=3)
    assert len(rows) == 200 and inside[rows].all() and np.all(np.diff(rows) > 0)
    np.testing.assert_array_equal(rows, tuning.tuning_rows(inside, 200, seed=3)[0])  # seeded
    assert "a seeded sample of 200 of the 500 in-support" in said and "tuning.max_rows" in said


SMALL_SPACE = tuning.search_space({"n_estimators": {"low": 5, "high": 20}, "max_depth": {"low": 2, "high": 3}})


def _complete(study):
    return sorted(study.get_trials(states=(optuna.trial.TrialState.COMPLETE,)), key=lambda t: t.number)


def test_tune_writes_journal_and_resumes(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    journal = tmp_path / "j.log"
    # no trial pruned: each is complete, with its value
    kwargs = dict(n_folds=3, seed=0, storage=str(journal), space=SMALL_SPACE, prune_after=10)
    first = tuning.tune(X, y, n_trials=3, **kwargs)
    assert journal.exists() and journal.stat().st_size > 0
    before = [(t.number, t.params, t.value) for t in _complete(first)]
    assert len(before) == 3
    for _, params, value in before:
        assert set(params) == TABLE4 and 5 <= params["n_estimators"] <= 20 and value > 0

    resumed = tuning.tune(X, y, n_trials=5, **kwargs)
    assert resumed.study_name == first.study_name
    after = _complete(resumed)
    assert len(after) == 5
    assert [(t.number, t.params, t.value) for t in after[:3]] == before
    # the resumed trials explore new points instead of replaying the first ones with a restarted sampler
    assert len({json.dumps(t.params, sort_keys=True) for t in after}) == 5
    # the resumed study is read back from the journal, not from memory
    names = optuna.study.get_all_study_names(tuning.open_storage(str(journal)))
    assert names == [first.study_name]

    # asking again for trials already finished runs nothing new
    assert len(_complete(tuning.tune(X, y, n_trials=4, **kwargs))) == 5

    best = tuning.best_params(resumed, SMALL_SPACE)
    assert best == min(after, key=lambda t: (t.value, t.number)).params

    other = tuning.tune(X, y + 1, n_trials=1, **kwargs)
    assert other.study_name != first.study_name
    assert len(_complete(other)) == 1
    assert sorted(optuna.study.get_all_study_names(tuning.open_storage(str(journal)))) == sorted(
        [first.study_name, other.study_name]
    )


def test_tune_takes_over_a_lock_left_by_a_killed_worker(tiny_residual_data, tmp_path, monkeypatch):
    """A worker killed while writing leaves Optuna's lock link behind; the next run must not wait forever."""
    X, y = tiny_residual_data
    monkeypatch.chdir(tmp_path)  # a relative journal path, as in the config
    monkeypatch.setattr(tuning, "LOCK_GRACE_S", 2)
    journal = Path("results/optuna/journal.log")
    tuning.tune(X, y, n_trials=1, n_folds=3, seed=0, storage=str(journal), space=SMALL_SPACE)
    assert tuning.journal_lock(str(journal)).acquire()  # and never released, as by a killed worker
    finished = []
    worker = threading.Thread(
        target=lambda: finished.append(
            tuning.tune(X, y, n_trials=2, n_folds=3, seed=0, storage=str(journal), space=SMALL_SPACE)
        ),
        daemon=True,
    )
    worker.start()
    worker.join(timeout=60)
    assert finished and len(_complete(finished[0])) == 2, "the stale lock was never released"


def test_tune_fresh_study_is_deterministic(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    runs = [
        tuning.tune(X, y, n_trials=2, n_folds=3, seed=1, storage=str(tmp_path / f"{i}.log"), space=SMALL_SPACE)
        for i in range(2)
    ]
    assert [(t.params, t.value) for t in _complete(runs[0])] == [(t.params, t.value) for t in _complete(runs[1])]


def test_tune_objective_is_cv_rmse(tiny_residual_data, tmp_path):
    X, y = tiny_residual_data
    # the folds' training matrices are built once and shared by the trials: the values stay the CV's, bit for bit
    study = tuning.tune(X, y, n_trials=3, n_folds=3, seed=0, storage=str(tmp_path / "j.log"), space=SMALL_SPACE)
    for trial in _complete(study):
        per_fold, _ = cross_validate(residual.make_model(trial.params, 0), X, y, 3, 0)
        assert trial.value == per_fold["rmse"].mean()


def test_tuning_logs_every_trial_with_the_best_so_far(tmp_path, caplog):
    rng = np.random.default_rng(0)
    X = rng.random((200, 3))
    y = X[:, 0] + rng.normal(0, 0.1, 200)
    space = tuning.search_space({"n_estimators": {"low": 10, "high": 20}})
    with caplog.at_level(logging.INFO, logger="hybridtwin.paper.tuning"):
        tuning.tune(X, y, n_trials=4, n_folds=3, seed=1, storage=str(tmp_path / "journal.log"), space=space)
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("tuning: trial")]
    assert [line.split(",")[1].split(":")[0].strip() for line in lines] == [f"{i} of 4" for i in range(1, 5)]
    assert all("best so far" in line for line in lines)


def test_tuning_workers_sample_apart_and_each_takes_the_warm_start(tmp_path):
    rng = np.random.default_rng(0)
    X = rng.random((200, 3))
    y = X[:, 0] + rng.normal(0, 0.1, 200)
    space = tuning.search_space({"n_estimators": {"low": 10, "high": 20}})

    def study(storage, worker=0, data=(X, y), seed=1, n_trials=1, warm_start=0):
        return tuning.tune(
            *data,
            n_trials=n_trials,
            n_folds=3,
            seed=seed,
            storage=str(tmp_path / storage),
            space=space,
            worker=worker,
            warm_start=warm_start,
        )

    # the same study's seed in two workers would try the same parameters first
    assert study("a.log").trials[0].params != study("b.log", worker=1).trials[0].params
    assert study("c.log").trials[0].params == study("d.log").trials[0].params
    # an earlier study (another seed, 4 trials); on new data whichever worker opens the study first
    # tries the earlier best first
    new_data = (X, y + 0.01)
    for storage, worker in (("e.log", 0), ("f.log", 1)):
        earlier = study(storage, seed=7, n_trials=4)
        best = min(earlier.trials, key=lambda t: t.value).params
        cold = study(f"cold-{storage}", worker=worker, data=new_data).trials[0].params
        warm = study(storage, worker=worker, data=new_data, warm_start=1).trials[0].params
        assert warm == best and cold != best


def test_a_study_on_new_data_starts_from_the_earlier_studys_best_trials(tmp_path):
    rng = np.random.default_rng(0)
    X = rng.random((150, 3))
    y = X[:, 0] + rng.normal(0, 0.1, 150)
    space = tuning.search_space({"n_estimators": {"low": 10, "high": 20}})
    journal = str(tmp_path / "journal.log")
    first = tuning.tune(X, y, n_trials=6, n_folds=3, seed=1, storage=journal, space=space)
    best = sorted(
        (t for t in first.trials if t.state == optuna.trial.TrialState.COMPLETE), key=lambda t: (t.value, t.number)
    )[:3]
    enriched = np.vstack([X, rng.random((10, 3))])
    second = tuning.tune(
        enriched,
        np.append(y, rng.random(10)),
        n_trials=4,
        n_folds=3,
        seed=1,
        storage=journal,
        space=space,
        warm_start=3,
    )
    assert second.study_name != first.study_name
    assert [t.params for t in second.trials[:3]] == [t.params for t in best]
    cold = tuning.tune(
        enriched[:-1],
        np.append(y, rng.random(9)),
        n_trials=2,
        n_folds=3,
        seed=1,
        storage=str(tmp_path / "other.log"),
        space=space,
        warm_start=3,
    )
    assert cold.trials[0].params != best[0].params  # nothing earlier in its storage: a cold start


def test_a_worker_that_loses_the_race_to_create_the_database_tables_tries_again(monkeypatch, tmp_path):
    # two workers opening an empty PostgreSQL database at once: one fails on a duplicate (tests/test_optuna_postgres.py)
    from sqlalchemy.exc import IntegrityError

    opened = []

    def storage(url):
        opened.append(url)
        if len(opened) == 1:
            raise IntegrityError("CREATE TYPE studydirection", {}, Exception("duplicate key value"))
        return "the storage"

    monkeypatch.setattr(optuna.storages, "RDBStorage", storage)
    monkeypatch.setattr(tuning.time, "sleep", lambda seconds: None)
    assert tuning.open_storage("postgresql://optuna@host/db") == "the storage"
    assert opened == ["postgresql://optuna@host/db"] * 2

    # a database that never opens stops the worker after its tries, with the database's own error
    def never(url):
        opened.append(url)
        raise IntegrityError("CREATE TYPE studydirection", {}, Exception("duplicate key value"))

    opened.clear()
    monkeypatch.setattr(optuna.storages, "RDBStorage", never)
    with pytest.raises(IntegrityError):
        tuning.open_database("postgresql://optuna@host/db", tries=3)
    assert len(opened) == 3
    # a journal file is no database
    assert isinstance(tuning.open_storage(str(tmp_path / "journal.log")), optuna.storages.JournalStorage)


def test_a_trial_worse_than_the_first_two_stops_after_its_first_fold(tiny_residual_data, tmp_path):
    # measured on nine plants to cost nothing (docs/benchmarks.md): pruning after two trials, not five
    X, y = tiny_residual_data
    storage = str(tmp_path / "j.log")
    name = f"residual-{tuning.fingerprint(X, y, SMALL_SPACE, 3, 0)}"
    study = tuning.open_study(name, storage, seed=0, worker=0)
    good = {"n_estimators": 20, "max_depth": 3, "learning_rate": 0.3, "subsample": 1.0, "colsample_bytree": 1.0}
    good |= {"min_child_weight": 1, "gamma": 0.0, "reg_alpha": 0.001, "reg_lambda": 0.001}
    for params in (good, good | {"max_depth": 2}, good | {"n_estimators": 5, "learning_rate": 0.005}):
        study.enqueue_trial(params)
    trials = tuning.tune(X, y, n_trials=3, n_folds=3, seed=0, storage=storage, space=SMALL_SPACE).trials
    assert [t.state.name for t in trials] == ["COMPLETE", "COMPLETE", "PRUNED"]
    assert list(trials[2].intermediate_values) == [0]
