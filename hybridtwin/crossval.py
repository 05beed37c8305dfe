"""K-fold cross-validation shared by the surrogate, the residual model and the diagnosis."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hybridtwin.metrics import scores

SEARCH_FOLDS = 5  # periods on which a peer's candidate hyperparameters (searches, draws) are compared


def lowest_on_periods(held_out: list[np.ndarray], y) -> tuple[list[float], int]:
    """Each candidate's RMSE against ``y`` of its out-of-period predictions, and the index of the lowest (one
    candidate, nothing held out: [0.0] and 0)."""
    errors = [float(np.sqrt(np.mean((np.asarray(p) - y) ** 2))) for p in held_out] or [0.0]
    return errors, int(np.argmin(errors))


def rows_of(X, rows):
    """``rows`` (positions or a slice) of a table or an array, as the same kind."""
    return X.iloc[rows] if hasattr(X, "iloc") else np.asarray(X)[rows]


def training_subset(n_rows: int, size: int, seed: int) -> np.ndarray:
    """Seeded subset of row positions (all rows when there are fewer), in order."""
    if n_rows <= size:
        return np.arange(n_rows)
    return np.sort(np.random.default_rng(seed).choice(n_rows, size, replace=False))


CV_METRICS = ("rmse", "mae", "bias", "r2")  # the column order of the CV tables


def folds(n_rows: int, n_folds: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Shuffled K-fold (train, test) index pairs; the same seed gives the same split."""
    if n_rows < n_folds:
        raise ValueError(f"{n_rows} rows are fewer than the {n_folds} CV folds")
    from sklearn.model_selection import KFold  # here: the paper's tables splice folds without scikit-learn

    return list(KFold(n_splits=n_folds, shuffle=True, random_state=seed).split(np.arange(n_rows)))


def period_folds(n_rows: int, n_folds: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """K folds of consecutive rows (a log in time order: K periods), (train, test) index pairs.

    A row's out-of-fold prediction then comes from a model that never saw its period: its campaign, its coil,
    its hour; the error of a period the model has not seen is the error the next production period meets.
    """
    period = periods(n_rows, n_folds)
    return [(np.flatnonzero(period != k), np.flatnonzero(period == k)) for k in range(n_folds)]


def periods(n_rows: int, n_folds: int) -> np.ndarray:
    """Each row's period (0..K-1) among ``n_rows`` in time order: the test folds of :func:`period_folds`."""
    if n_rows < n_folds:
        raise ValueError(f"{n_rows} rows are fewer than the {n_folds} CV folds")
    return np.arange(n_rows) * n_folds // n_rows


def out_of_period(refit_without, X: np.ndarray, period: np.ndarray, training_period: np.ndarray) -> np.ndarray:
    """Each row of ``X`` predicted by a model that never saw its period: ``refit_without(keep)`` is the model
    refitted (its hyperparameters held) on the training rows where ``keep``, as a function of rows;
    ``period``: each row's period, ``training_period``: each training row's."""
    out = np.empty(len(X))
    for k in np.unique(period):
        rows = period == k
        out[rows] = refit_without(training_period != k)(X[rows])
    return out


def in_support_out_of_period(model, inside, training_rows: np.ndarray, n_folds: int, rows=None) -> np.ndarray:
    """``model.out_of_period`` at ``rows`` (default: all) of ``inside``, the in-support parts in time order that
    the model was fitted on (``training_rows``: its training parts among them): each part predicted by the model
    refitted without the training parts of its period, the ``n_folds`` periods the hybrid's CV uses."""
    period = periods(len(inside), n_folds)
    rows = np.arange(len(inside)) if rows is None else np.asarray(rows)
    asked = rows_of(inside, rows)
    return model.out_of_period(asked, period[rows], period[np.asarray(training_rows)])


def ids_of(splits, n_rows: int) -> np.ndarray:
    """Each row's fold (1..K) in ``splits``: written beside out-of-fold predictions so that a later step
    scores on the very same split."""
    ids = np.zeros(n_rows, int)
    for fold, (_, test) in enumerate(splits, start=1):
        ids[test] = fold
    return ids


def fold_ids(n_rows: int, n_folds: int, seed: int) -> np.ndarray:
    """Each row's fold (1..n_folds) in :func:`folds`' split: written beside out-of-fold predictions so that
    a later step scores on the very same split."""
    ids = np.zeros(n_rows, int)
    for fold, (_, test) in enumerate(folds(n_rows, n_folds, seed), start=1):
        ids[test] = fold
    return ids


def splits_of(fold_ids) -> list[tuple[np.ndarray, np.ndarray]]:
    """The (train, test) index pairs of written fold ids, in fold order: :func:`folds`' split again."""
    ids = np.asarray(fold_ids, int)
    return [(np.flatnonzero(ids != fold), np.flatnonzero(ids == fold)) for fold in np.unique(ids)]


def written_splits(written: pd.DataFrame, rows) -> list[tuple[np.ndarray, np.ndarray]]:
    """The split written beside out-of-fold predictions (columns ``row``, ``fold``), for ``rows`` in that
    order; a table written for other rows is an error, not a silently different split."""
    if not np.array_equal(written["row"].to_numpy(int), np.asarray(rows, int)):
        raise ValueError("the written folds belong to other rows than these: rerun the residual CV")
    return splits_of(written["fold"])


def cross_validate(
    estimator, X, y, n_folds: int, seed: int, after_fold=None, splits=None
) -> tuple[pd.DataFrame, np.ndarray]:
    """Per-fold metrics and out-of-fold predictions. Each fold fits a fresh clone on its train rows only.

    ``splits``: the (train, test) pairs (default: shuffled K-fold of ``seed``); ``after_fold(rows)``, if given,
    sees the per-fold metrics so far after each fold (to stop early).
    """
    from sklearn.base import clone

    X, y = np.asarray(X, float), np.asarray(y, float)
    oof = np.empty_like(y)
    rows = []
    # an estimator that fits on a sample of its rows gets only those (on ten million parts, not a copy of eight)
    fit_rows = getattr(estimator, "fit_rows", None)
    for fold, (train, test) in enumerate(splits or folds(len(y), n_folds, seed), start=1):
        fitted_on = train if fit_rows is None else train[fit_rows(len(train))]
        model = clone(estimator).fit(X[fitted_on], y[fitted_on])
        oof[test] = model.predict(X[test])
        n_train = getattr(model, "n_fitted_", len(train))  # a model that fits on a sample of its rows says so
        rows.append(
            {"fold": fold, "n_train": n_train, "n_test": len(test), **scores(y[test], oof[test], names=CV_METRICS)}
        )
        if after_fold is not None:
            after_fold(rows)
    return pd.DataFrame(rows), oof


def cv_table(per_fold: pd.DataFrame, y, oof, model: str, evaluated_on: str) -> pd.DataFrame:
    """One-row summary: mean and std over folds, and the pooled out-of-fold scores."""
    row = {"model": model, "n": len(y), "folds": len(per_fold)}
    for metric in CV_METRICS:
        row[f"cv_{metric}_mean"] = float(per_fold[metric].mean())
        row[f"cv_{metric}_std"] = float(per_fold[metric].std(ddof=1)) if len(per_fold) > 1 else 0.0
    row.update({f"pooled_{name}": value for name, value in scores(y, oof, names=("r2", "rmse", "mae")).items()})
    row["evaluated_on"] = evaluated_on
    return pd.DataFrame([row])


def splice_out_of_fold(final, rows, oof) -> np.ndarray:
    """Final-model predictions with the out-of-fold ones put in at the rows the model was trained on,
    so that no row is scored by a model that saw it."""
    spliced = np.asarray(final, float).copy()
    spliced[np.asarray(rows, int)] = np.asarray(oof, float)
    return spliced


def capped_note(max_train_rows: int | None, n_rows: int) -> str:
    """How a table says that its residual models were fitted on a sample ('' when they were not)."""
    if max_train_rows is None or n_rows <= max_train_rows:
        return ""
    return (
        f"; each model fitted on a seeded sample of at most {max_train_rows:,} of its training rows "
        "(residual_model.max_train_rows)"
    )
