"""The Optuna study of the XGBoost residual model's hyperparameters (the paper's Table 4), by K-fold CV RMSE.

The study lives in a journal file (or an RDB URL) outside the workflow's declared outputs, named by a
fingerprint of the data and the settings: an interrupted run resumes the same study and keeps its finished
trials, while a run on enriched data starts a fresh study (warm-started from the last one's best).
"""

from __future__ import annotations

import hashlib
import json
import logging
import random
import time
from pathlib import Path

import numpy as np
import optuna
import pandas as pd

from hybridtwin.crossval import folds, training_subset
from hybridtwin.metrics import rmse
from hybridtwin.paper.residual import fitted_booster, make_model, training_matrix

log = logging.getLogger(__name__)


# The nine hyperparameters of the paper's Table 4: name -> (low, high, kind)
DEFAULT_SEARCH_SPACE: dict[str, dict] = {
    "n_estimators": {"low": 50, "high": 600, "type": "int"},
    "max_depth": {"low": 2, "high": 10, "type": "int"},
    "learning_rate": {"low": 0.005, "high": 0.3, "type": "float", "log": True},
    "subsample": {"low": 0.5, "high": 1.0, "type": "float"},
    "colsample_bytree": {"low": 0.5, "high": 1.0, "type": "float"},
    "min_child_weight": {"low": 1, "high": 10, "type": "int"},
    "gamma": {"low": 0.0, "high": 5.0, "type": "float"},
    "reg_alpha": {"low": 0.001, "high": 10.0, "type": "float", "log": True},
    "reg_lambda": {"low": 0.001, "high": 10.0, "type": "float", "log": True},
}


PARAMETER_LABELS = {
    "n_estimators": "Number of boosting rounds",
    "max_depth": "Maximum tree depth",
    "learning_rate": "Shrinkage factor",
    "subsample": "Row sampling ratio",
    "colsample_bytree": "Feature sampling ratio",
    "min_child_weight": "Minimum child weight",
    "gamma": "Minimum split loss",
    "reg_alpha": "L1 regularization",
    "reg_lambda": "L2 regularization",
}


def suggest(trial: optuna.Trial, space: dict[str, dict]) -> dict:
    params = {}
    for name, spec in space.items():
        if spec["type"] == "int":
            params[name] = trial.suggest_int(
                name, int(spec["low"]), int(spec["high"]), log=bool(spec.get("log", False))
            )
        else:
            params[name] = trial.suggest_float(
                name, float(spec["low"]), float(spec["high"]), log=bool(spec.get("log", False))
            )
    return params


def fingerprint(*parts) -> str:
    """Short hash of arrays and settings: names the study, so new data means a new study."""
    digest = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            digest.update(np.ascontiguousarray(part, dtype=float).tobytes())
        else:
            digest.update(json.dumps(part, sort_keys=True, default=str).encode())
    return digest.hexdigest()[:16]


# finished trials before the median pruner may stop a trial after its first fold
PRUNE_AFTER = 2

# seconds after which a journal lock left by a killed worker is taken over
LOCK_GRACE_S = 30


def open_storage(storage: str):
    """A journal file path (default) or an RDB URL such as sqlite:///optuna.db or postgresql://..."""
    if "://" in storage:
        return open_database(storage)
    Path(storage).parent.mkdir(parents=True, exist_ok=True)
    backend = optuna.storages.journal.JournalFileBackend(str(Path(storage).resolve()), lock_obj=journal_lock(storage))
    return optuna.storages.JournalStorage(backend)


# tries at opening a database whose tables another worker is creating at that moment
DATABASE_TRIES = 5


def open_database(url: str, tries: int = DATABASE_TRIES) -> optuna.storages.RDBStorage:
    """Optuna's storage in the database at ``url``; the first to open an empty database creates its tables.

    Workers opening an empty database at the same moment race to create them, and the losers fail on a
    duplicate (seen on PostgreSQL; Optuna's issue 1092): a worker that fails tries again, and then finds them.
    """
    from sqlalchemy.exc import SQLAlchemyError  # Optuna's own dependency

    for attempt in range(1, tries + 1):
        try:
            return optuna.storages.RDBStorage(url)
        except SQLAlchemyError as error:
            if attempt == tries:
                raise
            log.warning("opening the study's database failed (%s), trying again", type(error).__name__)
            time.sleep(attempt * random.uniform(0.5, 1.5))  # apart from the other losers


def journal_lock(storage: str) -> optuna.storages.journal.JournalFileSymlinkLock:
    """The lock that workers sharing a journal file take while writing to it."""
    # Absolute: the lock is a symlink to the journal, and a relative target dangles, so a lock left by
    # a killed worker would never be recognised as stale and the next run would wait forever.
    return optuna.storages.journal.JournalFileSymlinkLock(str(Path(storage).resolve()), grace_period=LOCK_GRACE_S)


def tune(
    X,
    y,
    *,
    n_trials: int,
    n_folds: int,
    seed: int,
    storage: str,
    space: dict | None = None,
    study_prefix: str = "residual",
    n_jobs: int = 1,
    warm_start: int = 0,
    worker: int = 0,
    prune_after: int = PRUNE_AFTER,
) -> optuna.Study:
    """Run (or resume) the TPE study until it holds ``n_trials`` finished trials.

    ``warm_start``: a new study (new data, say an enriched DoE) first tries the best ``warm_start``
    parameter sets of the latest earlier study in the same storage, instead of starting from scratch.
    ``worker``: one of several processes sharing the study; each samples with its own seed (the same
    seed would have them try the same parameters). Every worker enqueues the warm start, each set once
    (whichever worker opens the study first, the earlier best are tried). ``prune_after``: finished trials
    before the pruner may stop one.
    """
    space = space or DEFAULT_SEARCH_SPACE
    X, y = np.asarray(X, float), np.asarray(y, float)
    name = f"{study_prefix}-{fingerprint(X, y, space, n_folds, seed)}"
    warm = warm_start and (study_prefix, space, warm_start)
    study = open_study(name, storage, seed, worker, warm, prune_after)
    done = _complete(study)
    if done < n_trials:
        # the callback stops every worker sharing the study once enough trials have finished
        study.optimize(
            cv_objective(X, y, space, n_folds, seed, n_jobs),
            n_trials=n_trials - done,
            callbacks=[optuna.study.MaxTrialsCallback(n_trials, states=FINISHED), progress(n_trials)],
        )
    return study


def open_study(
    name: str, storage: str, seed: int, worker: int, warm=None, prune_after: int = PRUNE_AFTER
) -> optuna.Study:
    """The study ``name`` in ``storage``, created or resumed, with a sampler seeded for this worker and the trials
    already made; ``warm``: (prefix, space, n) to enqueue the best ``n`` parameter sets of the latest earlier study."""
    opened = open_storage(storage)
    study = optuna.create_study(
        study_name=name,
        storage=opened,
        direction="minimize",
        sampler=optuna.samplers.TPESampler(seed=_sampler_seed(seed, worker, 0)),
        load_if_exists=True,
        pruner=optuna.pruners.MedianPruner(n_startup_trials=prune_after, n_warmup_steps=0),
    )
    if warm:
        prefix, space, n = warm
        for params in earlier_best(opened, name, prefix, space, n):
            study.enqueue_trial(params, skip_if_exists=True)
    done = _complete(study)
    if done:
        log.info("resuming study %s with %d finished trial(s)", name, done)
    if study.trials:
        # a sampler restarted with the same seed would replay the first trials' parameters
        study.sampler = optuna.samplers.TPESampler(seed=_sampler_seed(seed, worker, len(study.trials)))
    return study


def cv_objective(X, y, space: dict, n_folds: int, seed: int, n_jobs: int):
    """A trial's value: the K-fold CV RMSE of its parameters (what :func:`~hybridtwin.crossval.cross_validate` gives
    the residual model, to the last bit); a trial whose running CV RMSE is worse than the median of earlier trials
    stops early.

    Each fold's training matrix (XGBoost's quantile sketch of its rows, which depends on the rows alone) is built
    once, at the first trial, and shared by every trial: rebuilt per trial and fold it was 2 s of the demo's 31.
    """
    splits = folds(len(y), n_folds, seed)
    matrices = []

    def objective(trial: optuna.Trial) -> float:
        if not matrices:
            matrices.extend(training_matrix(X[train], y[train], n_jobs) for train, _ in splits)
        model = make_model(suggest(trial, space), seed, n_jobs)
        errors = []
        for step, ((_, test), matrix) in enumerate(zip(splits, matrices)):
            errors.append(rmse(y[test], fitted_booster(model, matrix).inplace_predict(X[test])))
            trial.report(float(np.mean(errors)), step)
            if trial.should_prune():
                raise optuna.TrialPruned()
        return float(np.mean(errors))

    return objective


def _sampler_seed(seed: int, worker: int, n_trials: int) -> int:
    """The first worker's seed as it always was (seed + trials already in the study); other workers' seeds
    drawn from (seed, worker, trials), so that no two workers, resumed or not, share one."""
    if worker == 0:
        return seed + n_trials
    return int(np.random.SeedSequence([seed, worker, n_trials]).generate_state(1)[0])


def progress(n_trials: int):
    """An Optuna callback that logs each finished trial with its CV RMSE and the best so far."""

    def report(study: optuna.Study, trial: optuna.trial.FrozenTrial) -> None:
        finished = _complete(study)
        if trial.state == optuna.trial.TrialState.PRUNED:
            value = (
                trial.intermediate_values[max(trial.intermediate_values)] if trial.intermediate_values else float("nan")
            )
            outcome = (
                f"stopped early at fold {max(trial.intermediate_values, default=0) + 1} (running CV RMSE {value:.4g})"
            )
        elif trial.state == optuna.trial.TrialState.COMPLETE:
            outcome = f"CV RMSE {trial.value:.4g}"
        else:
            outcome = trial.state.name.lower()
        try:
            best = f"best so far {study.best_value:.4g} (trial {study.best_trial.number})"
        except ValueError:
            best = "no complete trial yet"
        log.info(
            "tuning: trial %d finished, %d of %d: %s; %s",
            trial.number,
            min(finished, n_trials),
            n_trials,
            outcome,
            best,
        )

    return report


FINISHED = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)


def _inside(params: dict, space: dict) -> bool:
    return set(params) == set(space) and all(space[k]["low"] <= v <= space[k]["high"] for k, v in params.items())


def earlier_best(storage, name: str, prefix: str, space: dict, n: int) -> list[dict]:
    """The best ``n`` completed parameter sets (inside ``space``) of the latest other study named ``prefix-*``."""
    earlier = [
        s
        for s in optuna.get_all_study_summaries(storage, include_best_trial=False)
        if s.study_name.startswith(f"{prefix}-") and s.study_name != name and s.datetime_start is not None
    ]
    if not earlier:
        return []
    latest = max(earlier, key=lambda s: s.datetime_start)
    trials = optuna.load_study(study_name=latest.study_name, storage=storage).get_trials(
        deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,)
    )
    ranked = sorted((t for t in trials if _inside(t.params, space)), key=lambda t: (t.value, t.number))
    log.info(
        "warm start from study %s: its best %d of %d trials first", latest.study_name, min(n, len(ranked)), len(trials)
    )
    return [dict(t.params) for t in ranked[:n]]


def _complete(study: optuna.Study) -> int:
    """Finished trials: completed or stopped early by the pruner."""
    return len(study.get_trials(deepcopy=False, states=FINISHED))


def best_params(study: optuna.Study, space: dict | None = None, n_trials: int | None = None) -> dict:
    """Best of the first ``n_trials`` finished trials (by number), ties broken by trial number.

    A study run earlier with more trials thus gives the same answer as a fresh one.
    """
    space = space or DEFAULT_SEARCH_SPACE
    trials = sorted(study.get_trials(deepcopy=False, states=FINISHED), key=lambda t: t.number)
    trials = [t for t in (trials[:n_trials] if n_trials else trials) if t.state == optuna.trial.TrialState.COMPLETE]
    best = min(trials, key=lambda trial: (trial.value, trial.number))
    return {name: best.params[name] for name in space}


def search_space(overrides: dict | None) -> dict[str, dict]:
    """The default space with the config's per-parameter overrides applied."""
    space = {name: dict(spec) for name, spec in DEFAULT_SEARCH_SPACE.items()}
    for name, spec in (overrides or {}).items():
        space[name].update(spec)
        if space[name]["low"] > space[name]["high"]:
            raise ValueError(f"tuning.search_space.{name}: low {spec['low']} is above high {spec['high']}")
    return space


def tuning_rows(in_support, max_rows: int, seed: int) -> tuple[np.ndarray, str]:
    """The parts the study tunes on (every in-support part, or a seeded sample of ``max_rows``), and how
    Table 4 says so."""
    inside = np.flatnonzero(np.asarray(in_support, bool))
    rows = inside[training_subset(len(inside), max_rows, seed)]
    if len(rows) == len(inside):
        return rows, f"K-fold CV RMSE on the {len(inside):,} in-support production parts"
    return rows, (
        f"K-fold CV RMSE on a seeded sample of {len(rows):,} of the {len(inside):,} in-support production parts "
        "(tuning.max_rows)"
    )


def hyperparameter_table(params: dict, space: dict, tuned_on: str = "") -> pd.DataFrame:
    """Table 4: the chosen hyperparameters with the searched ranges, and the data they were tuned on."""
    return pd.DataFrame(
        [
            {
                "parameter": PARAMETER_LABELS[name],
                "xgboost_name": name,
                "value": params[name],
                "search_low": space[name]["low"],
                "search_high": space[name]["high"],
                "log_scale": bool(space[name].get("log", False)),
                "tuned_on": tuned_on,
            }
            for name in space
        ]
    )


def trials_table(study: optuna.Study) -> pd.DataFrame:
    trials = sorted(study.get_trials(deepcopy=False, states=FINISHED), key=lambda t: t.number)
    return pd.DataFrame(
        [
            {
                "trial": t.number,
                "state": t.state.name.lower(),
                # a pruned trial shows its running CV RMSE when it was stopped
                "cv_rmse": t.value if t.value is not None else t.intermediate_values[max(t.intermediate_values)],
                **t.params,
            }
            for t in trials
        ]
    )
