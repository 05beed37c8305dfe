"""The co-kriging peer: AR1 multi-fidelity co-kriging (SMT's MFK), the simulations as low fidelity and in-support
parts' measured values as high fidelity.

The hyperparameters are searched by SMT's likelihood, with SMT's documented kernel (squared exponential) and
length-scale bounds (Cobyla, to which SMT's default TNC switches when the noise is estimated), ``n_searches`` times:
each search on its own seeded draw of ``n_high`` of the ``n_fit`` parts, from ``n_start`` starts beyond SMT's own
two. Which optimum a search ends in depends on its draw (on the bi-fidelity functions one search of 10 starts came
out up to 6 times the plain SMT MFK's truth-RMSE in support, another draw of the same plant near it), and the
likelihoods of different draws do not compare: each search's hyperparameters are judged by the error of the model on
the ``n_fit`` parts, each part predicted without its period (:data:`~hybridtwin.crossval.SEARCH_FOLDS` periods of
consecutive parts). The chosen search's predictions there are also its out-of-fold values on those periods, so its
score on its own parts is the best of ``n_searches`` and slightly optimistic. The best hyperparameters are held
while the model is refitted on all ``n_fit`` parts (one likelihood evaluation per level): campaigns are narrow, and
each one's discrepancy is better known from more of its parts. It stores its training data and hyperparameters as
JSON with the trained AR1 model's predictor (:func:`ar1_state`), which :func:`ar1_mean` evaluates in numpy: a
reloaded model predicts without SMT, its import or a refit.

The searches evaluate SMT's squared-exponential kernel with the same additions in the same order over a
column-major copy of the distances (:func:`column_sum`), and SMT's likelihood with its correlation matrix built in
one pass (:func:`reduced_likelihood`): the same likelihoods, bit for bit, in about two thirds of the time.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from scipy import linalg
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from hybridtwin.crossval import SEARCH_FOLDS, lowest_on_periods, out_of_period, periods, training_subset
from hybridtwin.models.batches import batched
from hybridtwin.paper.gate import DoEStandardizer, input_matrix, input_names, remember_inputs, restore_inputs

# the longest row numpy sums in running sums of eight (its pairwise block); it recurses on longer ones
_PAIRWISE_BLOCK = 128


def column_sum(columns: np.ndarray, weights: np.ndarray, work: np.ndarray | None = None) -> np.ndarray:
    """``np.sum(weights * columns, axis=1)`` with the same additions in the same order (numpy adds a row of up
    to 128 in eight running sums, then the rest one by one), over a column-major matrix: each column is read
    once and the result equals numpy's bit for bit. ``work``: a column-major scratch of the rows by 9, reused
    from call to call (a fresh vector of a megabyte costs a page fault per page); the sum is its first column."""
    rows, n = columns.shape
    if n > _PAIRWISE_BLOCK:  # numpy recurses on longer rows
        return np.sum(weights * np.ascontiguousarray(columns), axis=1)
    work = np.empty((rows, 9), order="F") if work is None else work

    def weighted(j: int, out: np.ndarray = work[:, 8]) -> np.ndarray:
        return np.multiply(columns[:, j], weights[j], out=out)

    if n < 8:  # a short row is added one by one
        total = weighted(0, work[:, 0])
        for j in range(1, n):
            np.add(total, weighted(j), out=total)
        return total
    running = [weighted(j, work[:, j]) for j in range(8)]
    blocks_end = n - n % 8
    for j in range(8, blocks_end):  # each further block of eight: each running sum takes its column
        np.add(running[j % 8], weighted(j), out=running[j % 8])
    a, b, c, d, e, f, g, h = running
    left = np.add(np.add(a, b, out=a), np.add(c, d, out=c), out=a)
    total = np.add(left, np.add(np.add(e, f, out=e), np.add(g, h, out=g), out=e), out=a)
    for j in range(blocks_end, n):  # the rest one by one
        np.add(total, weighted(j), out=total)
    return total


def _mfk_class():
    from smt.applications import MFK
    from smt.kernels import PowExp

    class SquaredExponential(PowExp):
        """SMT's kernel with the same values, 3 times faster on the likelihood's pairwise distances: it keeps a
        column-major copy of the distance matrix it is given (the same array at every step of a search). A matrix
        seen once (a refit's single likelihood evaluation) gets SMT's own sum: its copy would cost more."""

        _seen = _source = _columns = _work = None

        def __call__(self, d, grad_ind=None, hess_ind=None, derivative_params=None):
            # numpy adds a row of a column-major matrix in another order: SMT's own sum there (it passes C order)
            derivative = grad_ind is not None or hess_ind is not None or derivative_params is not None
            if derivative or not d.flags.c_contiguous or len(self.theta) != d.shape[1]:
                return super().__call__(d, grad_ind, hess_ind, derivative_params)
            if d is not self._source and d is not self._seen:
                self._seen = d
                return super().__call__(d)
            if d is not self._source:
                self._seen, self._source, self._columns = None, d, np.asfortranarray(d)
                self._work = np.empty((len(d), 9), order="F")
            total = column_sum(self._columns, self.theta, self._work)
            result = np.negative(total)
            return np.exp(result, out=result).reshape(-1, 1)

    class FastMFK(MFK):
        _correlation_class = {**MFK._correlation_class, "squar_exp": SquaredExponential}
        _lower = (None, None)  # (SMT's pairs of training points, the flat positions of their lower-triangle cells)

        def _reduced_likelihood_function(self, theta):
            if not self.is_continuous or self.options["is_ri"] or self.options["use_het_noise"]:
                return super()._reduced_likelihood_function(theta)
            pairs, positions = self._lower
            if pairs is not self.ij:
                pairs, positions = self.ij, self.ij[:, 1] * self.nt + self.ij[:, 0]
                self._lower = (pairs, positions)
            return reduced_likelihood(self, theta, positions)

    class FixedMFK(FastMFK):
        """SMT's MFK trained with given hyperparameters: one likelihood evaluation per level, no search."""

        def __init__(self, fixed, **options):
            super().__init__(**options)
            self._fixed = [np.asarray(level, float) for level in fixed]

        def _run_optimization(self, D):
            # the state MFK's own search sets up before it evaluates the likelihood
            self.D = self._componentwise_distance(D)
            self.noise0 = np.array(self._noise0)
            theta = self._fixed[self._lvl]
            value, par = self._reduced_likelihood_function(theta=theta)
            return value, par, theta

    return FastMFK, FixedMFK


def reduced_likelihood(model, theta, lower: np.ndarray):
    """SMT's reduced likelihood (``LikelihoodEvaluator.evaluate``: a continuous kriging, no reinterpolation, one
    noise level) with the same values bit for bit, the correlation matrix built in one pass: its diagonal and its
    lower triangle (``lower``: the flat positions of SMT's pairs of points there), the only part LAPACK's lower
    Cholesky reads. SMT's fill of both triangles by pairs of indices took as long as the factorization."""
    nugget, noise, tmp_var = model.options["nugget"], model.noise0, theta
    if model._eval_noise:
        nugget = 0
        theta, noise = tmp_var[0:-1], tmp_var[-1]
    model.corr.theta = theta
    try:
        r = model.corr(model.D).reshape(-1, 1)
    except FloatingPointError:
        return -np.inf, {}
    if np.isnan(r).any():
        return -np.inf, {}
    R = np.zeros((model.nt, model.nt))
    R.flat[:: model.nt + 1] = 1.0 + nugget + noise
    np.put(R, lower, r[:, 0])
    p, q = model._get_pq()
    try:
        C = linalg.cholesky(R, lower=True)
    except (linalg.LinAlgError, ValueError):
        return -np.inf, {}
    # from here SMT's generalized least squares, line for line
    Ft = linalg.solve_triangular(C, model.F, lower=True)
    Q, G = linalg.qr(Ft, mode="economic")
    sv = linalg.svd(G, compute_uv=False)
    if sv[-1] / sv[0] < 1e-10:
        return model._likelihood_evaluator.evaluate(tmp_var)  # SMT's own handling of an ill-conditioned trend
    Yt = linalg.solve_triangular(C, model.y_norma, lower=True)
    beta = linalg.solve_triangular(G, np.dot(Q.T, Yt))
    rho = Yt - np.dot(Ft, beta)
    detR = (np.diag(C) ** (2.0 / model.nt)).prod()
    sigma2 = (rho**2.0).sum(axis=0) / (model.nt - p - q)
    value = -(model.nt - p - q) * np.log10(sigma2.sum()) - model.nt * np.log10(detR)
    par = {
        "sigma2": sigma2 * model.y_std**2.0,
        "beta": beta,
        "gamma": linalg.solve_triangular(C.T, rho),
        "C": C,
        "Ft": Ft,
        "G": G,
        "Q": Q,
    }
    value += model._reduced_log_prior(theta)
    model._likelihood_evaluator._update_best_iteration(value, tmp_var)
    return min(value, 1e15), par


def ar1_state(mfk) -> dict:
    """What a trained SMT MFK (continuous inputs, constant trends, squared-exponential kernel) predicts its mean
    from: its input and output scaling, and per level the training inputs, length scales and kriging weights."""
    kind = (mfk.options["corr"], mfk.options["poly"], mfk.options["rho_regr"])
    if kind != ("squar_exp", "constant", "constant"):
        raise ValueError(f"co-kriging's predictor takes a squared-exponential kernel and constant trends, not {kind}")
    levels = [
        {
            "X": mfk.X_norma_all[level].tolist(),
            "theta": np.ravel(mfk.optimal_theta[level]).tolist(),
            "beta": np.ravel(mfk.optimal_par[level]["beta"]).tolist(),
            "gamma": np.ravel(mfk.optimal_par[level]["gamma"]).tolist(),
        }
        for level in range(mfk.nlvl)
    ]
    scaling = {key: np.ravel(getattr(mfk, key)).tolist() for key in ("X_offset", "X_scale", "y_mean", "y_std")}
    return {**scaling, "levels": levels}


def _as_arrays(state: dict) -> dict:
    """The stored predictor's lists as arrays, converted once rather than per batch of rows."""
    scaling = {key: np.asarray(value, float) for key, value in state.items() if key != "levels"}
    return {**scaling, "levels": [{key: np.asarray(v, float) for key, v in level.items()} for level in state["levels"]]}


def ar1_mean(state: dict, X: np.ndarray) -> np.ndarray:
    """SMT's MFK mean prediction (``_predict_intermediate_values``), evaluated in numpy: level 0 is a kriging of
    the simulations; each next level is rho times the level below plus its own kriging of the difference."""
    X = (np.asarray(X, float) - state["X_offset"]) / np.asarray(state["X_scale"])
    mean = None
    for level in state["levels"]:
        scale = np.sqrt(level["theta"])  # exp(-sum theta (x - x')^2) as a squared distance of scaled inputs
        here, there = X * scale, np.asarray(level["X"]) * scale
        squared = (here**2).sum(1)[:, None] + (there**2).sum(1)[None, :] - 2 * here @ there.T
        kriging = np.exp(-np.maximum(squared, 0.0)) @ np.asarray(level["gamma"])
        beta = level["beta"]
        mean = beta[0] + kriging if mean is None else beta[0] * mean + beta[1] + kriging
    return mean * state["y_std"][0] + state["y_mean"][0]


class CoKriging(RegressorMixin, BaseEstimator):
    """AR1 co-kriging: ``fit(X_high, y_high, X_low=DoE inputs, y_low=simulated)``; ``predict`` gives the target.

    ``theta_low``: the length-scale parameters' lower bound, SMT's own; the discrepancy's often sit there (a
    near-constant discrepancy), and raising it extrapolated worse (benchmarks/results/cokriging_theta_dev.md)."""

    def __init__(
        self,
        n_high: int = 500,
        n_fit: int | None = None,
        n_start: int = 2,
        n_searches: int = 3,
        corr: str = "squar_exp",
        hyper_opt: str = "Cobyla",
        theta_low: float = 1e-6,
        random_state: int = 0,
    ):
        self.n_high = n_high
        self.n_fit = n_fit
        self.n_start = n_start
        self.n_searches = n_searches
        self.corr = corr
        self.hyper_opt = hyper_opt
        self.theta_low = theta_low
        self.random_state = random_state

    def _options(self, seed: int | None = None) -> dict:
        seed = self.random_state if seed is None else seed
        return {
            "corr": self.corr,
            "eval_noise": True,
            "hyper_opt": self.hyper_opt,
            "n_start": self.n_start,
            "theta0": [1.0],
            "theta_bounds": [self.theta_low, 20.0],
            "seed": seed,
            "print_global": False,
        }

    def _train(self, model, X_low, y_low, X_high, y_high):
        model.set_training_values(self.standardizer_.transform(X_low), np.asarray(y_low, float)[:, None], name=0)
        model.set_training_values(self.standardizer_.transform(X_high), np.asarray(y_high, float)[:, None])
        model.train()
        return model

    def fit(self, X, y, X_low=None, y_low=None):
        remember_inputs(self, X)
        X_high = np.asarray(X, float)
        self.n_features_in_ = X_high.shape[1]
        y = np.asarray(y, float)
        n_fit = max(self.n_high, self.n_fit or 0)
        self.training_rows_ = rows = training_subset(len(X_high), n_fit, self.random_state)
        X_low = input_matrix(self, X_low)  # the DoE's columns taken by name, as the parts'
        self.standardizer_ = DoEStandardizer().fit(X_low)  # the DoE's statistics, as the gate's
        self.data_ = {"X_low": X_low, "y_low": np.asarray(y_low, float), "X_high": X_high[rows], "y_high": y[rows]}
        # each search on its own seeded part of the same rows, with its own starts
        draws = [
            rows[training_subset(len(rows), self.n_high, self.random_state + 7 + k)] for k in range(self.n_searches)
        ]
        found = [self._search(X_high[draw], y[draw], self.random_state + k) for k, draw in enumerate(draws)]
        # the likelihoods of different draws do not compare: the searches are judged on periods they did not see
        held_out = [self._period_predictions(SEARCH_FOLDS, h) for h in found] if len(found) > 1 else []
        self.search_errors_, best = lowest_on_periods(held_out, self.data_["y_high"])
        self.searched_ = found
        self.hyperparameters_, self.hyper_rows_ = found[best], draws[best]
        final = self._refit()
        self.likelihood_ = float(final.optimal_rlf_value[-1])  # of the chosen hyperparameters on every part
        self.state_ = ar1_state(final)
        return self

    def _search(self, X_high, y_high, seed: int) -> list[list[float]]:
        """Each level's length scales and noise found by SMT's likelihood search on these parts."""
        MFK, _ = _mfk_class()
        searched = self._train(MFK(**self._options(seed)), self.data_["X_low"], self.data_["y_low"], X_high, y_high)
        return [
            np.append(searched.optimal_theta[level], searched.optimal_noise_all[level]).tolist() for level in range(2)
        ]

    def _refit(self, X_high=None, y_high=None, hyperparameters=None):
        """The model with given (default: the chosen) hyperparameters held, on the given (default: all) parts."""
        _, FixedMFK = _mfk_class()
        X_high = self.data_["X_high"] if X_high is None else X_high
        y_high = self.data_["y_high"] if y_high is None else y_high
        model = FixedMFK(self.hyperparameters_ if hyperparameters is None else hyperparameters, **self._options())
        return self._train(model, self.data_["X_low"], self.data_["y_low"], X_high, y_high)

    def _without(self, keep: np.ndarray, hyperparameters=None):
        """Co-kriging refitted on the fitted parts where ``keep`` (the simulations kept, the hyperparameters held),
        as a function of rows of inputs."""
        state = _as_arrays(
            ar1_state(self._refit(self.data_["X_high"][keep], self.data_["y_high"][keep], hyperparameters))
        )
        return lambda X: ar1_mean(state, self.standardizer_.transform(X))

    def _period_predictions(self, n_folds: int, hyperparameters=None) -> np.ndarray:
        """Each fitted part predicted without its period (``n_folds`` periods of consecutive parts)."""
        period = periods(len(self.data_["y_high"]), n_folds)
        return out_of_period(lambda keep: self._without(keep, hyperparameters), self.data_["X_high"], period, period)

    def out_of_period(self, X, period, training_period) -> np.ndarray:
        """Each row of ``X`` predicted by co-kriging refitted, its hyperparameters held, without the fitted parts
        of the row's period: ``period`` per row of ``X``, ``training_period`` per fitted part (``training_rows_``)."""
        check_is_fitted(self, "state_")
        return out_of_period(
            lambda keep: partial(batched, self._without(keep)), input_matrix(self, X), period, training_period
        )

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "state_")
        X = self.standardizer_.transform(input_matrix(self, X))
        state = _as_arrays(self.state_)
        return batched(lambda rows: ar1_mean(state, rows), X)

    def to_dict(self) -> dict:
        return {
            "format": "hybridtwin.CoKriging/2",
            "params": self.get_params(),
            "inputs": input_names(self),
            "standardizer": self.standardizer_.to_dict(),
            "hyperparameters": self.hyperparameters_,
            "training_rows": self.training_rows_.tolist(),
            "data": {key: value.tolist() for key, value in self.data_.items()},
            "state": self.state_,
        }

    @classmethod
    def from_dict(cls, data: dict) -> "CoKriging":
        model = cls(**data["params"])
        model.standardizer_ = DoEStandardizer.from_dict(data["standardizer"])
        model.data_ = {key: np.asarray(value, float) for key, value in data["data"].items()}
        model.n_features_in_ = model.data_["X_high"].shape[1]
        model.hyperparameters_ = data["hyperparameters"]
        model.training_rows_ = np.asarray(data["training_rows"], int)
        restore_inputs(model, data)
        # a model stored before its predictor was (format 1) is refitted with its hyperparameters held
        model.state_ = data["state"] if "state" in data else ar1_state(model._refit())
        return model
