"""Hybrid metamodel for sheet-metal stamping. ``hybridtwin.Predictor`` answers what-if questions
with the models a workflow run wrote (see ``hybridtwin.predictor``)."""


def __getattr__(name):
    # imported on first use, so that ``import hybridtwin.demo`` stays light
    if name == "Predictor":
        from hybridtwin.answers.predictor import Predictor

        return Predictor
    raise AttributeError(f"module 'hybridtwin' has no attribute {name!r}")
