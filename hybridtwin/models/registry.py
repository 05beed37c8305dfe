"""Every model the workflow fits, compares and may recommend, declared once.

Answer columns, comparison tables, intervals, the predictor, the rules' outputs and the report
take their model names, columns and files from here. Adding a peer is one :class:`Model` entry
(with ``estimator`` naming its class) plus that class: see the development page of the docs.

Standard library only: the Snakefile reads it to name the peers' rules and files.
"""

from __future__ import annotations

from dataclasses import dataclass

PEER_FILE = "peer_{name}.json"  # a peer's stored model, under the run's models folder


@dataclass(frozen=True)
class Model:
    """One predictor of the target.

    ``honest``: how its values are made that no part it is scored on was trained on;
    ``predicts``: ``target``, or ``residual`` (added to the surrogate's prediction);
    ``estimator``: for a peer, ``module:Class`` of its estimator (fit, out_of_period, predict,
    to_dict/from_dict), and ``settings`` the (config key under ``peers``, constructor argument) pairs.
    """

    name: str
    label: str
    fitted_on: str
    honest: str
    recommendable: bool = True
    peer: bool = False
    predicts: str = "target"
    estimator: str | None = None
    settings: tuple[tuple[str, str], ...] = ()

    @property
    def column(self) -> str:
        """Its prediction in the per-part tables and in the predictor's answers."""
        return f"pred_{self.name}"

    @property
    def oof_column(self) -> str:
        """Its honest prediction in ``predictions/production.csv`` (out-of-fold on its training parts)."""
        return f"pred_{self.name}_oof"

    @property
    def file(self) -> str | None:
        """A peer's stored model, under the run's models folder."""
        return PEER_FILE.format(name=self.name) if self.peer else None


SURROGATE = Model(
    "surrogate",
    "surrogate (GPR of the simulations)",
    "the DoE's simulations",
    "never trained on a production part",
)
HYBRID_GATED = Model(
    "hybrid_gated",
    "hybrid, gated (the paper's answer)",
    "the DoE and the in-support parts",
    "the hybrid's out-of-fold values in the support, the surrogate outside it",
)
HYBRID = Model(
    "hybrid",
    "hybrid (paper), no gate",
    "the DoE and the in-support parts",
    "out-of-fold on the in-support parts (K-fold CV), the final model elsewhere",
)
HYBRID_UNFILTERED = Model(
    "hybrid_unfiltered",
    "hybrid trained on every part (Table 5)",
    "the DoE and every production part",
    "out-of-fold on every part: folds through the very campaigns it learnt, so reported, never recommended",
    recommendable=False,
)
EXTENDED = Model(
    "extended",
    "extended (surrogate + named causes)",
    "the DoE and the in-support parts",
    "out-of-fold on the in-support parts (the causes chosen on all of them), the final model elsewhere",
)
EXTENDED_HYBRID = Model(
    "extended_hybrid",
    "extended hybrid (+ XGBoost of the rest)",
    "the DoE and the in-support parts",
    "out-of-fold on the in-support parts, the final model elsewhere (the paper's hybrid where the guard says so)",
)
GP_DISCREPANCY = Model(
    "gp_discrepancy",
    "GP discrepancy (Kennedy-O'Hagan)",
    "the DoE and a seeded sample of in-support parts",
    "out of period on the in-support parts (refitted without each period's training parts, hyperparameters held), "
    "the final model elsewhere",
    peer=True,
    predicts="residual",
    estimator="hybridtwin.models.gp_discrepancy:GPDiscrepancy",
    settings=(("gp_n_hyper", "n_hyper"), ("gp_n_fit", "n_fit"), ("gp_n_draws", "n_draws")),
)
COKRIGING = Model(
    "cokriging",
    "co-kriging (AR1, SMT's MFK)",
    "the DoE (low fidelity) and a seeded sample of in-support parts (high fidelity)",
    "out of period on the in-support parts (refitted without each period's training parts, hyperparameters held), "
    "the final model elsewhere",
    peer=True,
    estimator="hybridtwin.models.cokriging:CoKriging",
    settings=(
        ("cokriging_n_high", "n_high"),
        ("cokriging_n_fit", "n_fit"),
        ("cokriging_n_start", "n_start"),
        ("cokriging_n_searches", "n_searches"),
    ),
)
STACK = Model(
    "stack",
    "stack (non-negative blend per region)",
    "the other recommendable models' honest values on the choosing blocks",
    "cross-fitted: each half of a region's choosing parts blended with the weights of the other half",
)

MODELS: tuple[Model, ...] = (
    SURROGATE,
    HYBRID_GATED,
    HYBRID,
    HYBRID_UNFILTERED,
    EXTENDED,
    EXTENDED_HYBRID,
    GP_DISCREPANCY,
    COKRIGING,
    STACK,
)
BY_NAME = {model.name: model for model in MODELS}
PEERS: tuple[Model, ...] = tuple(model for model in MODELS if model.peer)
PEER_NAMES: tuple[str, ...] = tuple(model.name for model in PEERS)
# best first in a tie: the order of MODELS
RECOMMENDABLE: tuple[str, ...] = tuple(model.name for model in MODELS if model.recommendable)
# the recommended model per row, as a pseudo-model of the comparison tables
RECOMMENDED = "recommended"
RECOMMENDED_COLUMN = f"pred_{RECOMMENDED}"
COMPARED: tuple[str, ...] = (*(m.name for m in MODELS if m is not HYBRID_UNFILTERED), RECOMMENDED)
# models whose honest values are a column of predictions/production.csv (the others are made from them)
WITH_OOF_COLUMN: tuple[Model, ...] = (HYBRID, HYBRID_UNFILTERED, EXTENDED, EXTENDED_HYBRID, *PEERS)

# the models that correct the surrogate with the plant's parts and that every answer computes (no peer): out of the
# support, how far they disagree on a part says how unsure the correction is there (answers.intervals.disagreement)
CORRECTIONS: tuple[str, ...] = (HYBRID.name, EXTENDED.name, EXTENDED_HYBRID.name)

# the residual models (XGBoost's own JSON), one per training set
RESIDUAL_FILE = "residual_xgb_{training}.json"
# the run's stored models, under its models folder: part -> file (every peer's from its entry)
FILES = {
    "surrogate": "surrogate_gpr.json",
    "gate": "support_gate.json",
    "residual_filtered": RESIDUAL_FILE.format(training="filtered"),
    "residual_unfiltered": RESIDUAL_FILE.format(training="unfiltered"),
    "extension": "extension.json",
    "remainder": "residual_xgb_extended.json",
    "production_reach": "production_reach.json",
    **{model.name: model.file for model in PEERS},
}


def model(name: str) -> Model:
    """The entry of ``name``; an unknown name is an error that lists the known ones."""
    try:
        return BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown model {name!r}; one of {', '.join(BY_NAME)}") from None
