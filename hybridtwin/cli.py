"""The ``hybridtwin`` command: what-if predictions from a finished workflow run's models.

    hybridtwin predict NEW.csv --models results/models -o OUT.csv [--level 0.9]
    hybridtwin predict --models results/models --set die_temp_c=55 --set thickness_mm=0.7 ...

The CSV is read with the run's conventions (csv.sep, csv.decimal, column names)
and the same checks; bad input ends with the workflow's message and exit status 1.
"""

from __future__ import annotations

import argparse
import logging
import sys

import pandas as pd

from hybridtwin.answers.predictor import Predictor
from hybridtwin.io.config import default
from hybridtwin.io.errors import InputError
from hybridtwin.io.reading import SEPARATORS, CsvFormat

# the models of a run with the default results_dir
DEFAULT_MODELS = f"{default('results_dir')}/models"


def _settings(pairs: list[str], predictor: Predictor) -> pd.DataFrame:
    """--set NAME=VALUE pairs as a one-row table; every input must be given."""
    values = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep:
            raise InputError(f"--set {pair!r}: write NAME=VALUE, for example --set {predictor.inputs[0]}=1.0")
        number = value.strip()
        if predictor.csv.decimal == ",":
            number = number.replace(",", ".", 1) if "." not in number else "not a number"
        try:
            values[name.strip()] = float(number)
        except ValueError:
            hint = " (the run's decimal mark is '.': write 0.75, without digit grouping)" if "," in value else ""
            raise InputError(f"--set {pair!r}: value {value!r} of {name.strip()!r} is not a number{hint}") from None
    unknown = [name for name in values if name not in predictor.inputs]
    missing = [name for name in predictor.inputs if name not in values]
    if unknown or missing:
        raise InputError(
            "--set: "
            + "; ".join(
                part
                for part in (
                    f"unknown input(s) {', '.join(map(repr, unknown))}" if unknown else "",
                    f"missing input(s) {', '.join(map(repr, missing))}" if missing else "",
                )
                if part
            )
            + f". The models take {', '.join(predictor.inputs)}"
        )
    return pd.DataFrame([values])


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hybridtwin", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    predict = commands.add_parser(
        "predict", help="predict the target for new settings, with an interval and the in/out-of-domain verdict"
    )
    predict.add_argument("csv", nargs="?", help="CSV of settings, one row each (the run's input column names)")
    predict.add_argument(
        "--models", default=DEFAULT_MODELS, help=f"a workflow run's models folder (default: {DEFAULT_MODELS})"
    )
    predict.add_argument("-o", "--output", help="CSV to write (default: print to the screen)")
    predict.add_argument("--level", type=float, help="interval level, for example 0.9 (default: the run's)")
    predict.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="one setting for a one-off question, instead of a CSV (repeat for each input)",
    )
    predict.add_argument(
        "--without-peers",
        action="store_true",
        help="skip the GP discrepancy and co-kriging (faster on large tables; where one of them is "
        "a region's best model, the next one is recommended)",
    )
    predict.add_argument(
        "--jobs",
        type=int,
        help="threads for the peers' predictions (default: every core this process may use; "
        "the answers do not depend on it)",
    )
    predict.add_argument("--sep", choices=list(SEPARATORS), help="CSV separator, if not the run's csv.sep")
    predict.add_argument("--decimal", choices=[".", ","], help="decimal mark, if not the run's csv.decimal")
    return parser


def predict(args) -> None:
    predictor = Predictor.load(args.models, with_peers=not args.without_peers)
    fmt = CsvFormat.from_config(
        {"sep": args.sep or predictor.csv.sep, "decimal": args.decimal or predictor.csv.decimal}
    )
    if bool(args.csv) == bool(args.set):
        raise InputError("give either a CSV file of settings or --set NAME=VALUE for every input, not both")
    frame = predictor.read(args.csv, fmt) if args.csv else _settings(args.set, predictor)
    answers = predictor.predict(frame, args.level, with_peers=not args.without_peers, n_jobs=args.jobs)
    if args.output:
        predictor.write(answers, args.output, fmt)
        logging.getLogger("hybridtwin").info("%d row(s) written to %s", len(answers), args.output)
    else:
        shown = answers.T if len(answers) == 1 else answers
        print(shown.to_string())


def main(argv=None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(levelname)s: %(message)s", stream=sys.stderr)
    args = _parser().parse_args(argv)
    try:
        predict(args)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
