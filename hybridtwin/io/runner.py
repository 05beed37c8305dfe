"""Glue for the workflow's rule scripts: logging to the rule's log and clean input errors.

It takes Snakemake's ``snakemake`` object as a plain object (input, output,
params, log, threads, config) and never imports snakemake, so the package can be
used and tested without it.
"""

from __future__ import annotations

import logging
import sys
import warnings

from hybridtwin.io.errors import InputError


def run(snakemake, main) -> None:
    """Call ``main(snakemake)`` with logging to the rule's log file and to stderr.

    An :class:`InputError` ends the job with its message and exit status 1, no traceback.
    """
    handlers = [logging.StreamHandler(sys.stderr)]
    if getattr(snakemake, "log", None):
        handlers.append(logging.FileHandler(snakemake.log[0], mode="w"))
    logging.basicConfig(
        level=logging.INFO, handlers=handlers, force=True, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    logging.captureWarnings(True)
    warnings.simplefilter("default")
    for noisy in ("matplotlib", "PIL", "optuna"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    try:
        main(snakemake)
    except InputError as error:
        logging.getLogger("hybridtwin").error("%s", error)
        sys.exit(1)
    except Exception:
        logging.getLogger("hybridtwin").exception("rule failed")
        raise


def spec_of(snakemake):
    """The run's settings the rule's step uses (``params.spec``: the inputs and what else it needs), with the
    rule's threads."""
    from hybridtwin.pipeline import Spec

    return Spec(**snakemake.params.spec, n_jobs=snakemake.threads)


def demo_truth(inputs) -> tuple:
    """The demo's noise-free truth per production part and its noise level, when the rule's ``inputs`` have
    them (a run on the demo plant); (None, None) otherwise."""
    if not inputs.get("truth"):
        return None, None
    from hybridtwin.io import files

    truth = files.read_checked(inputs.get("truth"), ["truth_mm"])["truth_mm"].to_numpy(float)
    return truth, float(files.read_json(inputs.get("demo_spec"))["noise_mm"])
