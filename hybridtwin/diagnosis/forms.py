"""Small, physically plausible discrepancy forms g(cause; theta), fitted by least squares.

Every form has ``fit(x, y)``, ``predict(x)``, ``n_params`` (free parameters
besides the intercept) and ``to_dict``/``form_from_dict`` for JSON model files.
``x`` is a 1-D float array, except for ``group`` (level labels) and
``product`` (an (n, 2) array).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.special import expit
from sklearn.isotonic import IsotonicRegression

from hybridtwin.io.files import json_safe

FAMILIES = {
    "linear": "linear",
    "quadratic": "polynomial",
    "sigmoid": "saturating",
    "step": "step",
    "monotone": "monotone trend",
    "group": "group offsets",
    "product": "interaction",
    "additive": "additive",
}


SIGMOID_SPAN = 4.39  # a logistic's 10-90% change spans 2*ln(9) = 4.39 widths


def logistic(z):
    """1 / (1 + exp(-z)), by scipy's expit: three times numpy's tanh form, and the sigmoid fits are most of a
    diagnosis' time."""
    return expit(z)


class Form:
    """A fitted term. Beyond its trusted range (``trust_low``..``trust_high``, set by
    :func:`set_trusted_range`) it is held at its value at the range's edge."""

    name = ""
    n_params = 0
    trust_low = None
    trust_high = None

    def predict(self, x):
        x = np.asarray(x) if self.trust_low is None else np.clip(np.asarray(x, float), self.trust_low, self.trust_high)
        return self._predict(x)

    def _predict(self, x):
        raise NotImplementedError

    def continued(self, x):
        """The form's own continuation beyond the values it was fitted on (its held-out prediction): the
        function itself, where :meth:`predict` holds a fitted curvature flat."""
        return self._predict(x)

    def to_dict(self) -> dict:
        return {"form": self.name, **{k: json_safe(v) for k, v in vars(self).items()}}

    def describe(self, column: str, unit: str, x_unit: str = "") -> str:
        """The effect in words: ``unit`` is the target's, ``x_unit`` the cause's ('' when it has none)."""
        raise NotImplementedError


def _with(value: float, unit: str, spec: str = ".4g") -> str:
    """A number with its unit ('50.05 °C'), or bare when the unit is not known."""
    return f"{value:{spec}} {unit}" if unit else f"{value:{spec}}"


class Linear(Form):
    name, n_params = "linear", 1

    def fit(self, x, y):
        self.slope, self.intercept = np.polyfit(x, y, 1)
        return self

    def _predict(self, x):
        return self.intercept + self.slope * np.asarray(x, float)

    def describe(self, column, unit, x_unit=""):
        return f"linear: {self.slope:+.4g} {unit} per {x_unit or 'unit'} of {column}"


class Quadratic(Form):
    """A parabola inside the fitted range, held constant beyond it: curvature is not extrapolated (held out, its
    continuation says which shape the data follow)."""

    name, n_params = "quadratic", 2

    def fit(self, x, y):
        x = np.asarray(x, float)
        self.center = float(np.mean(x))
        self.low, self.high = float(x.min()), float(x.max())
        self.coefficients = np.polyfit(x - self.center, y, 2)
        return self

    def _predict(self, x):
        return self.continued(np.clip(np.asarray(x, float), self.low, self.high))

    def continued(self, x):
        return np.polyval(self.coefficients, np.asarray(x, float) - self.center)

    def describe(self, column, unit, x_unit=""):
        a, b, _ = self.coefficients
        return f"quadratic in {column}, vertex at {_with(self.center - b / (2 * a), x_unit)}" if a else "quadratic"


class Sigmoid(Form):
    """intercept + amplitude * logistic((x - threshold) / width): a saturating change."""

    name, n_params = "sigmoid", 3

    def fit(self, x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        low, high, scale = sigmoid_range(x)
        intercept, amplitude, threshold, width = sigmoid_grid_start(x, y)
        start = [intercept, amplitude, threshold / scale, np.log(width / scale)]
        bounds = (
            [-np.inf, -np.inf, low / scale - 0.5, np.log(1e-3)],
            [np.inf, np.inf, high / scale + 0.5, np.log(5.0)],
        )
        curve = SigmoidCurve(x, y, scale)
        solution = least_squares(curve.residuals, start, curve.jacobian, bounds, x_scale="jac", max_nfev=100)
        self.intercept, self.amplitude = float(solution.x[0]), float(solution.x[1])
        self.threshold, self.width = float(solution.x[2] * scale), float(np.exp(solution.x[3]) * scale)
        return self

    def _predict(self, x):
        return self.intercept + self.amplitude * logistic((np.asarray(x, float) - self.threshold) / self.width)

    def describe(self, column, unit, x_unit=""):
        return (
            f"saturating change of {self.amplitude:+.3g} {unit} around {column} = {_with(self.threshold, x_unit)} "
            f"(10-90% over {_with(SIGMOID_SPAN * self.width, x_unit, '.3g')})"
        )


def sigmoid_range(x):
    """The 2nd and 98th percentiles of ``x`` and their spread (1 where they coincide): the sigmoid's scale.
    Its threshold stays within half a spread of that range."""
    low, high = np.percentile(x, [2, 98])
    return low, high, (high - low) or 1.0


SIGMOID_WIDTH_SHARES = (0.01, 0.03, 0.08, 0.2, 0.5)  # the start's widths, as shares of the spread
GRID_ROWS = 2_000  # a longer column's grid is first weighed on every k-th row, down to this many
GRID_KEPT = 10  # the grid's points weighed on every row after that: the best on the sample


def sigmoid_grid_start(x, y):
    """The least-squares sigmoid over a grid: thresholds at the 5th, 10th, .., 95th percentiles of ``x``,
    widths :data:`SIGMOID_WIDTH_SHARES` of its spread; intercept and amplitude exact for each.
    The start of :meth:`Sigmoid.fit`, which picks the basin the exact fit converges in.

    On more than :data:`GRID_ROWS` rows the 95 points are weighed on every k-th row and the best
    :data:`GRID_KEPT` of them on every row: the 95 logistic curves over every row were three quarters of a fit on
    8,000 rows."""
    _, _, spread = sigmoid_range(x)
    thresholds = np.percentile(x, np.linspace(5, 95, 19))
    widths = spread * np.array(SIGMOID_WIDTH_SHARES)
    stride = -(-len(x) // GRID_ROWS)
    sse, intercept, amplitude = _weighed_grid(x[::stride], y[::stride], thresholds, widths)
    points = np.stack(np.meshgrid(thresholds, widths), axis=-1).reshape(-1, 2)  # width by width, as the fits
    if stride > 1:
        points = points[np.argsort(sse, kind="stable")[:GRID_KEPT]]
        sse, intercept, amplitude = _sigmoid_fits(x, y, points[:, 0], points[:, 1])
    j = int(np.argmin(sse))
    return intercept[j], amplitude[j], points[j, 0], points[j, 1]


def _weighed_grid(x, y, thresholds, widths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_sigmoid_fits` at every threshold, width by width."""
    fits = [_sigmoid_fits(x, y, thresholds, width) for width in widths]
    return tuple(np.concatenate(part) for part in zip(*fits))


def _sigmoid_fits(x, y, thresholds, widths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per threshold (and width: one, or one per threshold): the squared error, intercept and amplitude of the
    least-squares intercept + amplitude * logistic((x - threshold) / width)."""
    S = logistic((x[:, None] - thresholds[None, :]) / widths)
    s_mean = S.mean(axis=0)
    centered = np.subtract(S, s_mean, out=S)
    var = (centered**2).sum(axis=0)
    centred_y = y - y.mean()
    amplitude = np.where(var > 0, centered.T @ centred_y / np.where(var > 0, var, 1), 0.0)
    return (centred_y**2).sum() - amplitude**2 * var, y.mean() - amplitude * s_mean, amplitude


class SigmoidCurve:
    """The sigmoid's residuals and their Jacobian at theta = (intercept, amplitude, threshold / scale,
    log(width / scale)) for least squares. The Jacobian takes the logistic of the residuals' last theta:
    least_squares asks for it at the point it has just evaluated, one logistic over every row less per step."""

    def __init__(self, x, y, scale):
        self.x, self.y, self.scale = x, y, scale
        self._theta = self._z = self._s = None

    def _logistic(self, theta) -> tuple[np.ndarray, np.ndarray]:
        if self._theta is None or not np.array_equal(theta, self._theta):
            z = (self.x - theta[2] * self.scale) / (np.exp(theta[3]) * self.scale)
            self._theta, self._z, self._s = np.array(theta, float), z, logistic(z)
        return self._z, self._s

    def residuals(self, theta) -> np.ndarray:
        """Sigmoid minus data."""
        return theta[0] + theta[1] * self._logistic(theta)[1] - self.y

    def jacobian(self, theta) -> np.ndarray:
        """The derivatives of :meth:`residuals` by theta, one column each."""
        z, s = self._logistic(theta)
        width = np.exp(theta[3]) * self.scale
        ds = theta[1] * s * (1.0 - s)
        return np.column_stack([np.ones_like(self.x), s, -ds * self.scale / width, -ds * z])


class Step(Form):
    """intercept + jump * [x >= threshold], the best split found exactly by sorting."""

    name, n_params = "step", 2

    def fit(self, x, y, min_share: float = 0.02):
        x, y = np.asarray(x, float), np.asarray(y, float)
        order = np.argsort(x, kind="stable")
        xs, ys = x[order], y[order]
        n = len(ys)
        left_sum = np.cumsum(ys)[:-1]
        left_n = np.arange(1, n)
        right_sum = ys.sum() - left_sum
        gain = left_sum**2 / left_n + right_sum**2 / (n - left_n)
        valid = (xs[1:] > xs[:-1]) & (left_n >= max(1, min_share * n)) & (n - left_n >= max(1, min_share * n))
        if not valid.any():
            self.threshold, self.low, self.jump = float(xs[-1]) + 1.0, float(ys.mean()), 0.0
            return self
        i = int(np.argmax(np.where(valid, gain, -np.inf)))
        self.threshold = float((xs[i] + xs[i + 1]) / 2)
        self.low = float(left_sum[i] / left_n[i])
        self.jump = float(right_sum[i] / (n - left_n[i]) - self.low)
        return self

    def _predict(self, x):
        return self.low + self.jump * (np.asarray(x, float) >= self.threshold)

    def describe(self, column, unit, x_unit=""):
        return f"step of {self.jump:+.3g} {unit} at {column} = {_with(self.threshold, x_unit)}"


class Monotone(Form):
    """Isotonic (increasing or decreasing) trend; its parameters are its distinct levels."""

    name = "monotone"

    def fit(self, x, y):
        # the direction with the smaller squared error (sklearn's "auto" guesses it from a Spearman test)
        fits = [IsotonicRegression(increasing=up, out_of_bounds="clip").fit(x, y) for up in (True, False)]
        model = min(fits, key=lambda fit: float(np.sum((np.asarray(y, float) - fit.predict(x)) ** 2)))
        self.knots_x = np.asarray(model.X_thresholds_, float)
        self.knots_y = np.asarray(model.y_thresholds_, float)
        return self

    @property
    def n_params(self):
        # each jump has a place and a height, and the direction is chosen from the data
        return 2 * max(1, len(np.unique(np.round(self.knots_y, 12))) - 1) + 1

    def _predict(self, x):
        return np.interp(np.asarray(x, float), self.knots_x, self.knots_y)

    def describe(self, column, unit, x_unit=""):
        change = self.knots_y[-1] - self.knots_y[0]
        span = f"{self.knots_x[0]:.4g}..{_with(self.knots_x[-1], x_unit)}"
        return f"monotone trend of {change:+.3g} {unit} over {column} {span}"


class Group(Form):
    """One offset per level; a level never seen in fitting gets the overall mean."""

    name = "group"

    def fit(self, x, y):
        labels = np.asarray(x).astype(str)
        levels, codes = np.unique(labels, return_inverse=True)
        sums = np.bincount(codes, weights=np.asarray(y, float))
        counts = np.bincount(codes)
        self.overall = float(np.mean(y))
        self.offsets = dict(zip(levels.tolist(), (sums / counts).tolist()))
        return self

    @property
    def n_params(self):
        return max(1, len(self.offsets) - 1)

    def _predict(self, x):
        labels = np.asarray(x).astype(str)
        levels, codes = np.unique(labels, return_inverse=True)
        values = np.array([self.offsets.get(level, self.overall) for level in levels.tolist()], float)
        return values[codes] if len(levels) else np.empty(0)

    def describe(self, column, unit, x_unit=""):
        values = np.array(list(self.offsets.values()))
        return f"offsets per {column} level: {len(values)} levels, sd {values.std():.3g} {unit}"


class Product(Form):
    """Bilinear interaction: c0 + c1*a + c2*b + c3*a*b (the linear parts absorb the centring)."""

    name, n_params = "product", 3

    def fit(self, x, y):
        a, b = np.asarray(x, float).T
        self.center = [float(a.mean()), float(b.mean())]
        self.coefficients = np.linalg.lstsq(self._design(a, b), np.asarray(y, float), rcond=None)[0]
        return self

    def _design(self, a, b):
        a, b = a - self.center[0], b - self.center[1]
        return np.column_stack([np.ones_like(a), a, b, a * b])

    def _predict(self, x):
        a, b = np.asarray(x, float).T
        return self._design(a, b) @ np.asarray(self.coefficients, float)

    def own_interaction(self, x):
        """The a*b term beyond the two columns' slopes on rows ``x``: the part of a*b that no line in a and b fits,
        times its coefficient."""
        a, b = np.asarray(x, float).T
        design = self._design(a, b)
        slopes = design[:, :3] @ np.linalg.lstsq(design[:, :3], design[:, 3], rcond=None)[0]
        return self.coefficients[3] * (design[:, 3] - slopes)

    def describe(self, column, unit, x_unit=""):
        return f"interaction: {self.coefficients[3]:+.4g} {unit} per unit of ({column.replace('*', ' x ')})"


class Additive(Product):
    """The product's two main effects without the a*b term: c0 + c1*a + c2*b.

    The yardstick of an interaction: a product that does not beat it is two separate effects.
    """

    name, n_params = "additive", 2

    def _design(self, a, b):
        return super()._design(a, b)[:, :3]

    def own_interaction(self, x):
        return np.zeros(len(x))

    def describe(self, column, unit, x_unit=""):
        first, second = column.split("*")
        return (
            f"additive: {self.coefficients[1]:+.4g} {unit} per unit of {first}, "
            f"{self.coefficients[2]:+.4g} {unit} per unit of {second}"
        )


NUMERIC_FORMS = (Linear, Quadratic, Sigmoid, Step, Monotone)
FORMS = {cls.name: cls for cls in (*NUMERIC_FORMS, Group, Product, Additive)}


def form_from_dict(data: dict) -> Form:
    form = FORMS[data["form"]].__new__(FORMS[data["form"]])
    for key, value in data.items():
        if key == "form":
            continue
        setattr(form, key, np.asarray(value, float) if isinstance(value, list) else value)
    return form


def fit_form(name: str, x, y) -> Form:
    return FORMS[name]().fit(x, y)


def backfit(values: list, form_names: list[str], y, passes: int = 20) -> tuple[list[Form], list[float]]:
    """Joint least-squares fit of several additive terms by backfitting.

    Returns the fitted forms and each term's mean over the rows, so that
    ``form.predict(x) - mean`` is the term's centred contribution.
    """
    y = np.asarray(y, float)
    fitted = [np.zeros_like(y) for _ in values]
    models: list[Form] = [None] * len(values)
    means = [0.0] * len(values)
    for _ in range(passes if len(values) > 1 else 1):
        for j, (x, name) in enumerate(zip(values, form_names)):
            partial = y - sum((fitted[k] for k in range(len(values)) if k != j), np.zeros_like(y))
            models[j] = fit_form(name, x, partial)
            raw = models[j].predict(x)
            means[j] = float(raw.mean())
            fitted[j] = raw - means[j]
    return models, means


# How far a term is trusted beyond the values it was fitted on: a form is fitted on the inner
# quantiles of its cause and scored on the outer ones, extrapolated against held constant.
EDGE_QUANTILES = (0.1, 0.9)
EDGE_ALPHA = 0.01  # one-sided block test that extrapolating beats holding constant on the edges
MIN_EDGE_ROWS = 50
MIN_EDGE_BLOCKS = 10  # the edges' blocks are lengthened down to this many while their means stay correlated


def edge_split(x):
    """Rows whose cause lies within the inner quantiles (:data:`EDGE_QUANTILES`, per column for a pair),
    and those quantiles; None where either side has too few rows to judge."""
    columns = np.asarray(x, float).reshape(len(x), -1)
    low, high = np.quantile(columns, EDGE_QUANTILES, axis=0)
    inner = np.all((columns >= low) & (columns <= high), axis=1)
    # the outer rows are the fewer (at most a tenth of the rows beyond each quantile, per column)
    if (~inner).sum() < MIN_EDGE_ROWS or np.any(high <= low):
        return None
    return inner, low, high


def extrapolates(name: str, x, y, n_blocks: int = 50) -> bool:
    """Whether the data show the form's trend continuing beyond its inner stretch.

    The form is fitted on the inner rows (:func:`edge_split`) and predicts the outer rows
    twice: extrapolated, and held at the inner stretch's edge. It extrapolates only where
    the extrapolated prediction is better, by a block-wise one-sided test over consecutive
    rows. Group offsets never extrapolate (an unseen level gets the mean).
    """
    from hybridtwin.metrics import block_p_value

    if name == Group.name:
        return False
    split = edge_split(x)
    if split is None:
        return False
    inner, low, high = split
    x, y = np.asarray(x, float), np.asarray(y, float)
    model = fit_form(name, x[inner], y[inner])
    outer = x[~inner]
    extrapolated = model.predict(outer)
    held = model.predict(np.clip(outer, low, high))
    return block_p_value(y[~inner] - held, extrapolated - held, n_blocks, min_blocks=MIN_EDGE_BLOCKS) < EDGE_ALPHA


def set_trusted_range(form: Form, x, y) -> Form:
    """Hold ``form`` constant beyond the values of ``x`` it was fitted on, unless the edges show its trend
    continuing (:func:`extrapolates`); then trust it as far again beyond each end as the data span."""
    if form.name == Group.name:
        return form
    x = np.asarray(x, float)
    low, high = np.min(x, axis=0), np.max(x, axis=0)
    if extrapolates(form.name, x, y):
        low, high = low - (high - low), high + (high - low)
    form.trust_low = low.tolist() if np.ndim(low) else float(low)
    form.trust_high = high.tolist() if np.ndim(high) else float(high)
    return form
