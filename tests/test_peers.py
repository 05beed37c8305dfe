"""The established peers on small constructed cases with a known smooth discrepancy."""

import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xgboost as xgb
from sklearn.gaussian_process import GaussianProcessRegressor

from hybridtwin import crossval
from hybridtwin.answers import intervals, regions
from hybridtwin.io import files
from hybridtwin.models import batches, cokriging, peers, registry
from hybridtwin.models.cokriging import CoKriging
from hybridtwin.models.gp_discrepancy import GPDiscrepancy

from .conftest import says

COLUMNS = ["a", "b", "c"]


def simulator(X):
    return 10 * X[:, 0] + 5 * np.sin(3 * X[:, 1])


def plant(X):
    return simulator(X) + 3 * X[:, 2] ** 2 + 2  # the discrepancy: smooth, in an input the simulator ignores


@pytest.fixture(scope="module")
def case():
    rng = np.random.default_rng(0)
    doe = rng.random((40, 3))
    parts = rng.random((1500, 3))
    new = pd.DataFrame(rng.random((300, 3)), columns=COLUMNS)
    return {
        "doe": pd.DataFrame(doe, columns=COLUMNS),
        "y_doe": simulator(doe) + rng.normal(0, 0.05, 40),
        "parts": pd.DataFrame(parts, columns=COLUMNS),
        "y_parts": plant(parts) + rng.normal(0, 0.3, 1500),
        "new": new,
        "truth": plant(new.to_numpy()),
    }


def _rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def test_gp_discrepancy_recovers_a_smooth_discrepancy_and_reloads_exactly(case):
    residual = case["y_parts"] - simulator(case["parts"].to_numpy())
    model = GPDiscrepancy(n_hyper=200, n_fit=600).fit(case["parts"], residual, X_low=case["doe"])
    corrected = simulator(case["new"].to_numpy()) + model.predict(case["new"])
    assert _rmse(corrected, case["truth"]) < 0.1  # the noise is 0.3, the discrepancy up to 5
    assert _rmse(simulator(case["new"].to_numpy()), case["truth"]) > 2
    again = GPDiscrepancy.from_dict(model.to_dict())
    assert np.array_equal(again.predict(case["new"]), model.predict(case["new"]))
    assert np.array_equal(again.predict(case["new"][COLUMNS[::-1]]), model.predict(case["new"]))  # by name


def test_cokriging_recovers_a_smooth_discrepancy_and_reloads_exactly(case):
    # the hyperparameters searched on 100 parts, the model refitted with them on 300 (a superset)
    model = CoKriging(n_high=100, n_fit=300, n_start=2).fit(
        case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
    )
    assert _rmse(model.predict(case["new"]), case["truth"]) < 0.3
    again = CoKriging.from_dict(model.to_dict())  # refitted with the stored hyperparameters, no search
    assert np.array_equal(again.predict(case["new"]), model.predict(case["new"]))
    assert len(model.data_["X_high"]) == 300 and len(model.hyper_rows_) == 100
    assert np.isin(model.hyper_rows_, model.training_rows_).all()
    assert len(model.state_["levels"][-1]["X"]) == 300  # the refit took every part
    searched_only = CoKriging(n_high=100, n_start=2).fit(
        case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
    )
    assert len(searched_only.state_["levels"][-1]["X"]) == 100
    assert model.get_params()["corr"] == "squar_exp"  # SMT's documented kernel


def test_cokriging_predicts_what_smt_predicts_without_smt_and_reads_its_older_files(case):
    model = CoKriging(n_high=100, n_fit=300, n_start=1, n_searches=1).fit(
        case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
    )
    trained = model._refit()  # SMT's model with the chosen hyperparameters on every part
    expected = trained.predict_values(model.standardizer_.transform(case["new"].to_numpy())).ravel()
    # to rounding: the two solve the same kriging systems in another order (1e-8 apart on an AMD EPYC's BLAS)
    assert np.allclose(model.predict(case["new"]), expected, rtol=1e-7, atol=1e-7)
    assert np.ptp(expected) > 1  # a test of the levels' sum, not of a constant
    older = {key: value for key, value in model.to_dict().items() if key != "state"}  # format 1: refitted on load
    assert np.allclose(CoKriging.from_dict(older).predict(case["new"]), expected, rtol=1e-7, atol=1e-7)
    with pytest.raises(ValueError, match="squared-exponential"):  # a kernel the numpy predictor does not evaluate
        CoKriging(n_high=60, n_start=1, n_searches=1, corr="abs_exp").fit(
            case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
        )


@pytest.mark.parametrize("n_inputs", [1, 7, 8, 12, 17, 24, 130])
def test_the_column_sum_adds_as_numpy_does_bit_for_bit(n_inputs):
    rng = np.random.default_rng(n_inputs)
    distances, weights = rng.random((3000, n_inputs)) * 4, rng.random(n_inputs) * 9
    expected = np.sum(weights.reshape(1, -1) * distances, axis=1)
    np.testing.assert_array_equal(cokriging.column_sum(np.asfortranarray(distances), weights), expected)


def test_cokriging_searches_with_smts_kernel_values_and_finds_smts_hyperparameters(case):
    from smt.applications import MFK
    from smt.kernels import PowExp

    fast, _ = cokriging._mfk_class()
    kernel = fast._correlation_class["squar_exp"]([1.0])
    distances = np.random.default_rng(3).random((2000, 12))
    for theta in (np.full(12, 0.5), np.linspace(0.01, 19, 12)):  # the kept column-major copy, a new length scale
        kernel.theta, reference = theta, PowExp(theta)
        np.testing.assert_array_equal(kernel(distances), reference(distances))
    np.testing.assert_array_equal(kernel(distances[:500]), PowExp(kernel.theta)(distances[:500]))  # a new matrix
    column_major = np.asfortranarray(distances)  # numpy adds its rows in another order: SMT's own sum there
    np.testing.assert_array_equal(kernel(column_major), PowExp(kernel.theta)(column_major))
    model = CoKriging(n_high=80, n_start=1, n_searches=1)
    model.fit(case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"])
    # SMT's own MFK and kernel searching the same draw from the same starts end at the same point
    draw = model.hyper_rows_
    X, y = np.asarray(case["parts"], float)[draw], np.asarray(case["y_parts"], float)[draw]
    own = model._train(MFK(**model._options()), model.data_["X_low"], model.data_["y_low"], X, y)
    assert model.hyperparameters_ == [
        np.append(own.optimal_theta[level], own.optimal_noise_all[level]).tolist() for level in range(2)
    ]


def test_cokrigings_likelihood_is_smts_bit_for_bit(case):
    from smt.surrogate_models.krg_based.likelihood_eval import LikelihoodEvaluator

    fast, _ = cokriging._mfk_class()
    compared = []

    def same(ours, theirs):
        np.testing.assert_array_equal(ours[0], theirs[0])
        assert ours[1].keys() == theirs[1].keys()
        for key in ours[1]:
            np.testing.assert_array_equal(ours[1][key], theirs[1][key])
        compared.append(ours[0])

    class Compared(fast):
        """Each likelihood of the search beside SMT's evaluator's; at a level's first step, also far ones."""

        def _reduced_likelihood_function(self, theta):
            ours = super()._reduced_likelihood_function(theta)
            same(ours, LikelihoodEvaluator(self).evaluate(theta))
            if len(compared) == 1 or self._lower[0] is not getattr(self, "_far_checked", None):
                self._far_checked = self._lower[0]
                for far in (np.full(len(theta), 20.0), np.r_[np.full(len(theta) - 1, 1e-6), 0.0]):
                    same(super()._reduced_likelihood_function(far), LikelihoodEvaluator(self).evaluate(far))
            return ours

    mfk = Compared(**CoKriging(n_start=1)._options(seed=1))
    mfk.set_training_values(np.asarray(case["doe"], float), np.asarray(case["y_doe"], float)[:, None], name=0)
    mfk.set_training_values(np.asarray(case["parts"], float)[:80], np.asarray(case["y_parts"], float)[:80, None])
    mfk.train()
    assert len(compared) > 50 and -np.inf in compared  # both levels searched; SMT's failure value compared too


def test_cokriging_searches_as_smt_documents_and_more_starts_find_no_poorer_optimum(case):
    from hybridtwin.io import config

    # three searches of SMT's two own starts and 2 more (Cobyla: with the noise estimated SMT's TNC switches to it),
    # set by the config's peers.cokriging_n_start and cokriging_n_searches
    defaults = config.section_defaults("peers")
    assert defaults["cokriging_n_start"] == CoKriging().n_start == 2
    assert defaults["cokriging_n_searches"] == CoKriging().n_searches == 3
    assert CoKriging().hyper_opt == "Cobyla"
    assert peers.new_peer("cokriging", {"cokriging_n_start": 3}, 0).n_start == 3
    assert peers.new_peer("cokriging", {"cokriging_n_searches": 4}, 0).n_searches == 4
    data = {"X_low": case["doe"], "y_low": case["y_doe"]}
    few, many = (
        CoKriging(n_high=100, n_start=n, n_searches=1).fit(case["parts"], case["y_parts"], **data) for n in (1, 4)
    )
    # the likelihood at the optimum of the high-fidelity level: more starts include the one start's point
    assert many.likelihood_ >= few.likelihood_ - 1e-9


def test_cokriging_keeps_the_search_whose_model_predicts_unseen_periods_best(case):
    """Likelihoods of different draws do not compare; each search's hyperparameters are judged by the RMSE of
    its model on the parts, each predicted by a refit without its period."""
    model = CoKriging(n_high=60, n_fit=300, n_start=1, n_searches=3).fit(
        case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
    )
    assert len(model.searched_) == len(model.search_errors_) == 3
    assert len({round(error, 9) for error in model.search_errors_}) == 3  # the draws lead to different optima
    best = int(np.argmin(model.search_errors_))
    assert model.hyperparameters_ == model.searched_[best]
    y = model.data_["y_high"]
    for hyperparameters, error in zip(model.searched_, model.search_errors_):
        held_out = np.empty(len(y))
        for train, test in crossval.period_folds(len(y), 5):
            refit = model._refit(model.data_["X_high"][train], y[train], hyperparameters)
            held_out[test] = refit.predict_values(model.standardizer_.transform(model.data_["X_high"][test])).ravel()
        assert error == pytest.approx(_rmse(held_out, y), rel=1e-6)
        if hyperparameters == model.hyperparameters_:  # the chosen search's are its out-of-period values there
            period = crossval.periods(len(y), 5)
            assert np.allclose(model.out_of_period(case["parts"].iloc[model.training_rows_], period, period), held_out)
    # each search drew its own parts of the same rows; the chosen draw is kept
    assert np.isin(model.hyper_rows_, model.training_rows_).all() and len(model.hyper_rows_) == 60
    single = CoKriging(n_high=60, n_fit=300, n_start=1, n_searches=1).fit(
        case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
    )
    assert single.hyperparameters_ == model.searched_[0]  # the first search is the single search's


def test_gp_discrepancy_keeps_the_draw_whose_gp_predicts_unseen_periods_best(case):
    """One draw of hyperparameter parts sets an optimum that varies with the draw: each draw's GP (refitted on every
    training part) is judged by the RMSE of its predictions of each period by a refit without it."""
    residual = case["y_parts"] - simulator(case["parts"].to_numpy())
    model = GPDiscrepancy(n_hyper=60, n_fit=300, n_draws=3).fit(case["parts"], residual)
    assert len(model.draw_errors_) == 3 and len({round(error, 9) for error in model.draw_errors_}) == 3
    y = residual[model.training_rows_]
    state = model.gp_.to_dict()
    held_out = model._period_predictions(state, 5)
    assert _rmse(held_out, y) == pytest.approx(min(model.draw_errors_), rel=1e-9)  # the best draw is kept
    period = crossval.periods(len(y), 5)  # its training parts predicted out of period
    assert np.allclose(model.out_of_period(case["parts"].iloc[model.training_rows_], period, period), held_out)
    assert np.isin(model.hyper_rows_, model.training_rows_).all() and len(model.hyper_rows_) == 60
    single = GPDiscrepancy(n_hyper=60, n_fit=300, n_draws=1).fit(case["parts"], residual)
    seeded = [model.training_rows_[crossval.training_subset(300, 60, seed)] for seed in (0, 101, 102)]
    thetas = [single._searched(case["parts"].to_numpy(), residual, rows).gpr_.kernel_.theta.tolist() for rows in seeded]
    assert thetas[0] == single.gp_.gpr_.kernel_.theta.tolist()  # the first draw is the single draw's
    assert model.gp_.gpr_.kernel_.theta.tolist() == thetas[int(np.argmin(model.draw_errors_))]
    assert GPDiscrepancy.from_dict(model.to_dict()).get_params()["n_draws"] == 3
    stored = json.loads((Path(__file__).parent / "data" / "models" / "peer_gp_discrepancy.json").read_text())
    assert "n_draws" not in stored["params"] and GPDiscrepancy.from_dict(stored).get_params()["n_draws"] == 1
    every = GPDiscrepancy(n_hyper=60, n_fit=60, n_draws=3).fit(case["parts"], residual)  # every row in each draw
    assert every.draw_errors_ == [0.0]  # one search: the draws would be alike


def test_a_model_without_an_honest_value_on_a_row_is_not_scored_there():
    rng = np.random.default_rng(3)
    n = 4000
    measured = rng.normal(0, 1, n)
    good = measured + rng.normal(0, 0.1, n)
    trained_on = rng.random(n) < 0.3
    # where a model has no honest value (NaN; a peer beyond its sample of a long log) the row must not count
    peer = np.where(trained_on, np.nan, measured + rng.normal(0, 2.0, n))
    region = np.full(n, "in_support", dtype=object)
    calibration = regions.calibration_rows(n, 10)
    fitted = intervals.RegionIntervals.fit(measured, {"hybrid": good, "gp_discrepancy": peer}, region, calibration, [])
    assert fitted.recommended["in_support"] in ("hybrid", "stack")
    assert len(fitted.calibration["gp_discrepancy"]["in_support"]) == int(np.sum(calibration & ~trained_on))
    lower, upper = fitted.interval("gp_discrepancy", peer, region, 0.9)
    assert np.isnan(lower[trained_on]).all() and np.isfinite(lower[~trained_on]).all()


def _peer_frames(case, in_support):
    parts = case["parts"]
    surrogate = simulator(parts.to_numpy())
    residuals = pd.DataFrame(
        {
            "measured": case["y_parts"],
            "pred_surrogate": surrogate,
            "residual_approx": case["y_parts"] - surrogate,
            "in_support": in_support,
        }
    )
    return case["doe"].assign(y=case["y_doe"]), residuals


def test_on_a_large_log_a_peer_predicts_a_seeded_sample_of_rows_and_its_training_parts_out_of_period(case):
    parts = case["parts"]
    doe, residuals = _peer_frames(case, np.arange(len(parts)) % 2 == 0)
    settings = {"gp_n_hyper": 100, "gp_n_fit": 200, "max_predicted": 1000}
    fit = peers.fit_peer("gp_discrepancy", doe, parts, residuals, COLUMNS, "y", settings, seed=0, n_folds=5)
    predicted = np.isfinite(fit.production["pred_gp_discrepancy"].to_numpy())
    assert predicted.sum() == 1000
    # from only the rows it reads (in support, and predicted), indexed by their rows, as the step reads a long log
    read = peers.rows_read(residuals, settings, 0)
    assert len(read) < len(parts)
    again = peers.fit_peer("gp_discrepancy", doe, parts.iloc[read], residuals, COLUMNS, "y", settings, 0, 5)
    pd.testing.assert_frame_equal(again.production, fit.production)  # and seeded
    honest = fit.production["pred_gp_discrepancy_oof"].to_numpy()
    inside = residuals["in_support"].to_numpy(bool)
    trained = np.flatnonzero(inside)[fit.model.training_rows_]
    assert np.array_equal(np.flatnonzero(np.isfinite(honest)), np.union1d(np.flatnonzero(predicted), trained))
    final = fit.production["pred_gp_discrepancy"].to_numpy()
    assert np.array_equal(honest[predicted & ~inside], final[predicted & ~inside])  # never trained there
    assert not np.allclose(honest[predicted & inside], final[predicted & inside])  # out of period in support
    # without a limit every row is predicted, and the sample's values are the same
    full = peers.fit_peer(
        "gp_discrepancy", doe, parts, residuals, COLUMNS, "y", {**settings, "max_predicted": 10**6}, 0, 5
    )
    assert np.isfinite(full.production["pred_gp_discrepancy"]).all()
    np.testing.assert_allclose(
        full.production["pred_gp_discrepancy"].to_numpy()[predicted], fit.production["pred_gp_discrepancy"][predicted]
    )
    np.testing.assert_allclose(full.production["pred_gp_discrepancy_oof"].to_numpy()[predicted], honest[predicted])


@pytest.mark.parametrize("kind", registry.PEER_NAMES)
def test_in_support_a_peer_is_scored_by_models_that_never_saw_the_part_s_period(case, kind):
    """Every in-support part, trained on or not, is predicted by the peer refitted without the training parts of
    its period (as the hybrid is scored): the final model has seen its neighbours in time."""
    doe, residuals = _peer_frames(case, np.arange(len(case["parts"])) % 3 != 0)
    settings = {"gp_n_hyper": 60, "gp_n_fit": 150, "cokriging_n_high": 150, "cokriging_n_start": 2}
    fit = peers.fit_peer(kind, doe, case["parts"], residuals, COLUMNS, "y", settings, seed=4, n_folds=3)
    inside = np.flatnonzero(residuals["in_support"])
    trained = inside[fit.model.training_rows_]
    honest = fit.production[f"pred_{kind}_oof"].to_numpy()
    final = fit.production[f"pred_{kind}"].to_numpy()
    assert len(trained) == 150 and fit.n_train == 150
    outside = np.setdiff1d(np.arange(len(final)), inside)
    assert np.array_equal(honest[outside], final[outside])  # never trained there: the final model
    # each period by hand: the final model's hyperparameters on the other periods' training parts only
    model = fit.model
    period = np.arange(len(inside)) * 3 // len(inside)  # three stretches of consecutive in-support parts
    training_period = period[model.training_rows_]
    for k in range(3):
        rows, train = inside[period == k], np.flatnonzero(training_period != k)
        assert len(rows) > np.sum(training_period == k)  # more than its training parts
        if isinstance(model, GPDiscrepancy):
            gp = model.gp_.gpr_
            by_hand = GaussianProcessRegressor(gp.kernel_, normalize_y=True, optimizer=None)
            by_hand.fit(gp.X_train_[train], residuals["residual_approx"].to_numpy()[trained[train]])
            Z = model.gp_.standardizer_.transform(case["parts"].iloc[rows])
            expected = simulator(case["parts"].to_numpy()[rows]) + by_hand.predict(Z)
        else:
            state = {key: value for key, value in model.to_dict().items() if key != "state"}  # refitted on load
            high = {key: model.data_[key][train] for key in ("X_high", "y_high")}
            state["data"] = {**state["data"], **high}
            expected = CoKriging.from_dict(state).predict(case["parts"].iloc[rows])
        np.testing.assert_allclose(honest[rows], expected, rtol=1e-9, atol=1e-9)
        assert not np.allclose(honest[rows], final[rows])  # the final model, which saw their period, differs
    if isinstance(model, GPDiscrepancy):  # the rows that chose the hyperparameters are training rows
        assert np.isin(model.hyper_rows_, model.training_rows_).all() and len(model.hyper_rows_) == 60
    again = type(model).from_dict(model.to_dict())
    assert np.array_equal(again.training_rows_, model.training_rows_)
    X = case["parts"].iloc[inside]
    np.testing.assert_array_equal(
        again.out_of_period(X, period, training_period), model.out_of_period(X, period, training_period)
    )


def test_threads_share_the_rows_and_give_the_same_answers(case):
    models = {
        "gp_discrepancy": GPDiscrepancy(n_hyper=100, n_fit=300).fit(case["parts"], case["y_parts"], X_low=case["doe"]),
        "cokriging": CoKriging(n_high=100, n_start=2).fit(
            case["parts"], case["y_parts"], X_low=case["doe"], y_low=case["y_doe"]
        ),
    }
    X, surrogate = case["parts"].iloc[:1250], np.arange(1250.0)  # 13 batches of 100 rows, the last of 50
    alone = peers.predictions_at(models, X, surrogate, n_jobs=1)
    shared = peers.predictions_at(models, X, surrogate, n_jobs=3)
    for kind in models:
        assert np.array_equal(shared[kind], alone[kind]), kind
    np.testing.assert_allclose(alone["gp_discrepancy"], surrogate + models["gp_discrepancy"].predict(X))
    assert batches.BATCH_ROWS == 100
    assert [(c.start, c.stop) for c in batches.chunks(1250, 2)] == [(0, 700), (700, 1250)]
    assert [(c.start, c.stop) for c in batches.chunks(250, 5)] == [(0, 100), (100, 200), (200, 250)]
    assert batches.chunks(0, 2) == []


def test_a_long_log_predicted_a_stretch_of_parts_at_a_time_gets_the_whole_matrix_answers(monkeypatch):
    from hybridtwin.io.files import table_of

    rng = np.random.default_rng(9)
    frame = pd.DataFrame(rng.normal(size=(2500, 3)), columns=["a", "b", "c"]).assign(coil="C1")
    model = xgb.XGBRegressor(n_estimators=20, max_depth=3, random_state=0).fit(frame[["b", "c"]], rng.normal(size=2500))
    whole = model.predict(frame[["b", "c"]].to_numpy(float))
    monkeypatch.setattr(files, "ROWS_AT_ONCE", 1000)  # three stretches, the last of 500
    assert np.array_equal(batches.by_parts(model.predict, frame, ["b", "c"]), whole)
    assert len(batches.by_parts(model.predict, frame.iloc[:0], ["b", "c"])) == 0
    # a table of per-part columns keeps them as they are: no stacked copy of them all
    columns = {"x": np.arange(5.0), "y": np.ones(5)}
    assert np.shares_memory(table_of(columns)["x"].to_numpy(), columns["x"])


def test_the_comparison_scores_every_model_on_the_same_held_out_parts_by_hand():
    rng = np.random.default_rng(8)
    n = 1000
    inside = np.arange(n) % 3 == 0
    test = (np.arange(n) // 100) % 2 == 1  # the odd blocks
    truth = rng.normal(0, 5, n)
    measured = truth + rng.normal(0, 1, n)
    predictions = {model: truth + rng.normal(0, 1 + k, n) for k, model in enumerate(registry.COMPARED)}
    predictions["gp_discrepancy"][::7] = np.nan  # a peer without an honest value on some parts
    predictions["hybrid_unfiltered"] = np.where(np.arange(n) % 5 == 0, np.nan, truth)  # not compared: its gaps
    # do not take rows from the others
    matched_measured = np.array([1.0, 2.0, 3.0])
    matched = {"hybrid": np.array([1.5, 2.0, 3.0]), "cokriging": np.array([1.0, 2.0, 4.0])}
    fits = {"gp_discrepancy": {"n_train": 700}, "cokriging": {"n_train": 300}}
    table = peers.comparison_table(
        measured, predictions, inside, test, matched_measured, matched, fits, truth=truth, noise=2.0
    ).set_index("model")
    assert table.index.tolist() == list(registry.COMPARED)
    scored = test & np.isfinite(predictions["gp_discrepancy"])  # the rows every model has a value on
    for model in registry.COMPARED:
        error, miss = measured - predictions[model], truth - predictions[model]
        row = table.loc[model]
        assert row["rmse_in_support_cv"] == pytest.approx(np.sqrt(np.mean(error[scored & inside] ** 2)))
        assert row["rmse_out_of_support"] == pytest.approx(np.sqrt(np.mean(error[scored & ~inside] ** 2)))
        assert row["rmse_truth_in_support_cv"] == pytest.approx(np.sqrt(np.mean(miss[scored & inside] ** 2)))
        assert row["rmse_truth_out_of_support"] == pytest.approx(np.sqrt(np.mean(miss[scored & ~inside] ** 2)))
        assert row["out_of_support_over_noise"] == pytest.approx(row["rmse_out_of_support"] / 2.0)
    assert table.loc["hybrid", "rmse_matched"] == pytest.approx(np.sqrt(0.25 / 3))
    assert table.loc["cokriging", "rmse_matched"] == pytest.approx(np.sqrt(1 / 3))
    assert np.isnan(table.loc["stack", "rmse_matched"])  # no matched prediction given: not scored there
    assert (table["n_in_support"] == (scored & inside).sum()).all()
    assert (table["n_out_of_support"] == (scored & ~inside).sum()).all() and (table["n_matched"] == 3).all()
    assert table.loc["gp_discrepancy", "n_train"] == 700 and table.loc["cokriging", "n_train"] == 300
    assert np.isnan(table.loc["hybrid", "n_train"])
    assert table["evaluated_on"].str.endswith("truth = the demo's noise-free plant").all()
    says(table["evaluated_on"].iloc[0], "test rows", "odd blocks", "even blocks", "the same rows for every model")
    says(table["evaluated_on"].iloc[0], "fewer than half of a side's rows", "in support out of period for every model")
    says(table["evaluated_on"].iloc[0], "from models never trained there", "matched cases never used for fitting")
    assert "hybrid_unfiltered" not in table.index
    without = {m: p for m, p in predictions.items() if m != "cokriging"}
    plain = peers.comparison_table(measured, without, inside, test, matched_measured, matched, fits)
    assert "cokriging" not in plain["model"].tolist() and len(plain) == len(registry.COMPARED) - 1
    assert "rmse_truth_out_of_support" not in plain and not plain["evaluated_on"].str.contains("truth").any()


@pytest.mark.parametrize("kind", registry.PEER_NAMES)
def test_a_peer_is_its_seeds_and_its_stored_form_reloads_by_column_name(case, kind):
    import json

    doe, residuals = _peer_frames(case, np.arange(len(case["parts"])) % 2 == 0)
    settings = {"gp_n_hyper": 60, "gp_n_fit": 150, "cokriging_n_high": 150, "cokriging_n_start": 2}
    fit = peers.fit_peer(kind, doe, case["parts"], residuals, COLUMNS, "y", settings, seed=3, n_folds=3)
    again = peers.fit_peer(kind, doe, case["parts"], residuals, COLUMNS, "y", settings, seed=3, n_folds=3)
    np.testing.assert_array_equal(again.production.to_numpy(), fit.production.to_numpy())
    assert fit.fit_seconds > 0
    # the training parts are the seed's (the GP's one seed on, so that its rows differ from co-kriging's)
    offset = 1 if isinstance(fit.model, GPDiscrepancy) else 0
    assert np.array_equal(fit.model.training_rows_, crossval.training_subset(750, 150, 3 + offset))
    data = json.loads(json.dumps(fit.model.to_dict()))
    assert data["format"] == ("hybridtwin.GPDiscrepancy/1" if offset else "hybridtwin.CoKriging/2")
    assert data["inputs"] == COLUMNS and data["training_rows"] == fit.model.training_rows_.tolist()
    loaded = peers.load_peer(kind, data)
    assert type(loaded) is type(fit.model)
    np.testing.assert_array_equal(loaded.predict(case["new"][COLUMNS[::-1]]), fit.model.predict(case["new"]))
    with pytest.raises(ValueError, match=f"^unknown peer 'kriging'; one of {', '.join(registry.PEER_NAMES)}$"):
        peers.fit_peer("kriging", doe, case["parts"], residuals, COLUMNS, "y", settings, seed=3, n_folds=5)


@pytest.mark.skipif(not hasattr(__import__("os"), "sched_setaffinity"), reason="no CPU affinity on this platform")
def test_the_peers_threads_default_to_the_cores_this_process_may_use():
    # a process allowed one core of the machine's several runs one thread, whatever the machine has
    import subprocess
    import sys

    script = (
        "import os; os.sched_setaffinity(0, {0}); "
        "from hybridtwin.models import batches; print(batches.available_cores())"
    )
    assert subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout == "1\n"


def test_a_model_missing_on_far_regions_does_not_empty_the_comparisons_out_of_support_side():
    # the stack has no weights in the far bins of a small plant: the other models are still scored on every test
    # part out of the support, and the stack on its own ones there (the defect: 0 out-of-support rows)
    inside = np.r_[np.ones(10, bool), np.zeros(10, bool)]
    test = np.ones(20, bool)
    valued = {"hybrid": np.ones(20, bool), "gp_discrepancy": np.arange(20) % 5 != 0, "stack": np.arange(20) < 13}
    rows = peers.shared_rows(valued, inside, test)
    outside_rows = {m: np.flatnonzero(r & ~inside).tolist() for m, r in rows.items()}
    # out of support the stack covers 3 of 10 parts: the others share the 8 where the GP has a value
    assert outside_rows["hybrid"] == outside_rows["gp_discrepancy"] == [11, 12, 13, 14, 16, 17, 18, 19]
    assert outside_rows["stack"] == [11, 12]
    # in support every model covers at least half: the rows all three share
    assert np.flatnonzero(rows["hybrid"] & inside).tolist() == [1, 2, 3, 4, 6, 7, 8, 9]


def test_models_valued_on_exactly_half_of_a_side_set_its_shared_rows_and_a_side_without_test_rows_is_skipped():
    inside = np.r_[np.ones(4, bool), np.zeros(4, bool)]
    valued = {"hybrid": np.ones(8, bool), "half": np.array([1, 1, 0, 0, 1, 1, 0, 0], bool)}
    rows = peers.shared_rows(valued, inside, np.ones(8, bool))
    assert rows["hybrid"].tolist() == rows["half"].tolist() == [1, 1, 0, 0, 1, 1, 0, 0]  # half is broad enough
    # no test row in support: the out-of-support side is still scored
    rows = peers.shared_rows(valued, inside, ~inside)
    assert rows["hybrid"].tolist() == [0, 0, 0, 0, 1, 1, 0, 0]
    # no model valued on half a side: each on its own rows there
    sparse = {"a": np.array([1, 0, 0, 0, 1, 0, 0, 0], bool), "b": np.array([0, 1, 0, 0, 0, 0, 0, 0], bool)}
    rows = peers.shared_rows(sparse, inside, np.ones(8, bool))
    assert rows["a"].tolist() == sparse["a"].tolist() and rows["b"].tolist() == sparse["b"].tolist()


@pytest.mark.parametrize("kind", registry.PEER_NAMES)
def test_a_fitted_peer_predicts_the_measured_value_and_its_fit_time_is_part_of_the_call(case, kind):
    parts = case["parts"]
    doe, residuals = _peer_frames(case, np.arange(len(parts)) % 2 == 0)
    settings = {"gp_n_hyper": 60, "gp_n_fit": 150, "cokriging_n_high": 150, "cokriging_n_start": 1}
    start = time.perf_counter()
    fit = peers.fit_peer(kind, doe, parts, residuals, COLUMNS, "y", {**settings, "cokriging_n_searches": 1}, 3, 3)
    assert 0 < fit.fit_seconds < time.perf_counter() - start
    truth, simulated = plant(parts.to_numpy()), simulator(parts.to_numpy())
    for column in (f"pred_{kind}", f"pred_{kind}_oof"):  # the plant's values, not its discrepancy alone
        assert _rmse(fit.production[column], truth) < 0.25 * _rmse(simulated, truth)


def _campaign_plant(seed: int):
    """500 parts of 25 coils (three per-coil properties) in five campaigns that hold nine settings: the residual a
    smooth function of two properties plus noise of twice its spread; new parts near the logged ones."""
    rng = np.random.default_rng(seed)
    columns = [f"x{j}" for j in range(12)]
    properties = rng.uniform(-1, 1, (25, 3))
    coil = np.repeat(np.arange(25), 20)
    settings = np.repeat(rng.uniform(-1, 1, (5, 9)), 100, axis=0)
    X = np.column_stack([properties[coil], settings]) + rng.normal(0, 0.02, (500, 12))

    def discrepancy(X):
        return 0.8 * X[:, 0] + 0.4 * X[:, 1] ** 2

    residual = discrepancy(X) + rng.normal(0, 0.7, len(X))
    doe = pd.DataFrame(rng.uniform(-1.2, 1.2, (67, 12)), columns=columns)
    new = X + rng.normal(0, 0.05, X.shape)
    return pd.DataFrame(X, columns=columns), residual, doe, pd.DataFrame(new, columns=columns), discrepancy(new)


def test_gp_discrepancy_searches_its_likelihood_from_a_noisy_start():
    # from the simulator's small noise the search stopped in a poorer optimum here: 0.32 against the truth
    seed, at_most = 4, 0.15
    parts, residual, doe, new, truth = _campaign_plant(seed)
    model = GPDiscrepancy(n_hyper=500, n_fit=500).fit(parts, residual, X_low=doe)
    assert _rmse(model.predict(new), truth) < at_most
