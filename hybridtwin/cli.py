"""The ``hybridtwin`` command: questions to a finished workflow run's models.

    hybridtwin predict NEW.csv --models results/models -o OUT.csv        # a table of settings
    hybridtwin predict --models results/models --set die_temp_c=60       # typical production, one input changed
    hybridtwin sweep --models results/models --vary die_temp_c=20:110:46 -o sweep.csv --plot sweep.png
    hybridtwin monitor BATCH.csv --models results/models -o OUT.csv           # new production, checked

Every answer carries its trust verdict (validated, calibrated, extrapolation) and the reason in words. A CSV is
read with the run's conventions (csv.sep, csv.decimal, column names) and the same checks; bad input ends with
one line and exit status 1.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys

from hybridtwin.io.config import default
from hybridtwin.io.errors import InputError
from hybridtwin.io.reading import ENCODINGS, SEPARATORS, CsvFormat

# the models of a run with the default results_dir
DEFAULT_MODELS = f"{default('results_dir')}/models"
SEPARATOR_NAMES = {name: sep for sep, name in SEPARATORS.items()}


def _common(command: argparse.ArgumentParser) -> None:
    command.add_argument("--models", default=DEFAULT_MODELS, help=f"a run's models folder (default: {DEFAULT_MODELS})")
    command.add_argument("-o", "--output", help="CSV to write (default: show the answer on the screen)")
    command.add_argument("--level", type=float, help="interval level, for example 0.9 (default: the run's)")
    command.add_argument(
        "--set", action="append", default=[], metavar="NAME=VALUE", help="an input's value (repeat for more)"
    )
    command.add_argument("--base", metavar="FILE.csv", help="take the inputs not set from a row of this CSV")
    command.add_argument("--base-row", type=int, metavar="N", help="that row, from 1 (default: 1)")
    command.add_argument(
        "--all-models", action="store_true", help="add every model's prediction and the regions' bookkeeping"
    )
    command.add_argument("--jobs", type=int, help="threads for the peers (default: every core this process may use)")
    _csv_flags(command)


def _csv_flags(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--sep", choices=list(SEPARATOR_NAMES), help="the CSV files' separator, if not the run's csv.sep"
    )
    command.add_argument("--decimal", choices=["point", "comma"], help="decimal mark, if not the run's csv.decimal")
    command.add_argument("--encoding", choices=list(ENCODINGS), help="text encoding, if not the run's csv.encoding")


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(prog="hybridtwin", description=__doc__.split("\n\n")[0])
    commands = top.add_subparsers(dest="command", required=True)
    predict = commands.add_parser(
        "predict", help="predict the target for new settings, with an interval and a trust verdict"
    )
    predict.add_argument("csv", nargs="?", help="CSV of settings, one row each (the run's input column names)")
    _common(predict)
    sweep = commands.add_parser("sweep", help="the answer along one input, the others held, as a table and a figure")
    sweep.add_argument("--vary", required=True, metavar="NAME=LOW:HIGH:N", help="the input, its range and N values")
    sweep.add_argument("--plot", metavar="FILE.png", help="the figure to write")
    _common(sweep)
    monitor = commands.add_parser(
        "monitor", help="check new production against the models: an alarm when it changed, since when and why"
    )
    monitor.add_argument(
        "batch", help="CSV of new production in the log's format (inputs, measured target), in time order"
    )
    monitor.add_argument("--models", default=DEFAULT_MODELS, help=f"a run's models folder (default: {DEFAULT_MODELS})")
    monitor.add_argument("-o", "--output", help="CSV to write, with monitor.md beside it (default: the summary only)")
    monitor.add_argument("--plot", metavar="FILE.png", help="the figure to write (residual, statistic, alarm)")
    _csv_flags(monitor)
    return top


def _format(args, predictor) -> CsvFormat:
    return CsvFormat(
        SEPARATOR_NAMES[args.sep] if args.sep else predictor.csv.sep,
        {"point": ".", "comma": ","}[args.decimal] if args.decimal else predictor.csv.decimal,
        args.encoding or predictor.csv.encoding,
        fix="flag",
    )


def question(args, predictor, fmt: CsvFormat, varied: dict | None = None):
    """The settings asked about: a CSV of them, or one row from --set, --base and typical production
    (``varied``: a sweep's input, set by the sweep)."""
    from hybridtwin.answers import whatif
    from hybridtwin.io import data

    if getattr(args, "csv", None):
        if args.set or args.base:
            raise InputError("give a CSV file of settings, or --set / --base for one question: not both")
        return predictor.read(args.csv, fmt)
    values = whatif.pairs(args.set, predictor.inputs)
    both = sorted(set(values) & set(varied or {}))
    if both:
        raise InputError(f"--set {both[0]} and --vary {both[0]}: the sweep varies it; leave out the --set")
    values.update(varied or {})
    if args.base_row is not None and not args.base:
        raise InputError("--base-row without --base: give the CSV the row is taken from with --base FILE.csv")
    if args.base:
        row = args.base_row or 1
        base = data.load_row(args.base, row, predictor.inputs, fmt)
        return whatif.filled(values, predictor.inputs, base, f"{args.base} row {row}")
    if not values and args.command == "predict":
        raise InputError(
            "nothing asked: give a CSV file of settings, or --set NAME=VALUE (the inputs not set take typical "
            "production values)"
        )
    return whatif.filled(values, predictor.inputs, predictor.typical, "typical production (median in support)")


def run(args) -> None:
    from hybridtwin.answers import answer
    from hybridtwin.answers.predictor import Predictor

    _not_over_an_input(args)
    predictor = Predictor.load(args.models)
    fmt = _format(args, predictor)
    if args.command == "monitor":
        return _monitor(args, predictor, fmt)
    if args.command == "sweep":
        from hybridtwin.answers import whatif

        name, values = whatif.sweep_values(args.vary, predictor.inputs)
        frame = whatif.sweep_frame(question(args, predictor, fmt, {name: values[0]}), name, values)
    else:
        frame = question(args, predictor, fmt)
    answers = predictor.predict(frame, args.level, args.all_models, args.jobs)
    if args.command == "sweep" and args.plot:
        _plot(predictor, answers, name, args.plot)
    if args.output:
        predictor.write(answers, args.output, fmt)
        logging.getLogger("hybridtwin").info("%d row(s) written to %s", len(answers), args.output)
    else:
        varied = (name,) if args.command == "sweep" else ()
        print(answer.on_screen(answers, predictor.inputs, predictor.spec["unit"], varied=varied))


def _not_over_an_input(args) -> None:
    """Your files are only read: an output named as an input file is refused."""
    from pathlib import Path

    output = getattr(args, "output", None)
    for given in (getattr(args, "csv", None), getattr(args, "base", None), getattr(args, "batch", None)):
        if output and given and Path(output).resolve() == Path(given).resolve():
            raise InputError(f"-o {output!r} is the input file {given!r}: write the answers to another file")


def _plot(predictor, answers, name: str, path: str) -> None:
    from hybridtwin.io import files
    from hybridtwin.report import plots

    spec, unit = predictor.spec, predictor.input_units.get(name, "")
    figure = plots.sweep(answers, name, predictor.doe_range[name], spec["target"], spec["unit"], unit)
    files.save_figure(figure, path)


def _monitor(args, predictor, fmt: CsvFormat) -> None:
    from pathlib import Path

    from hybridtwin.io import files
    from hybridtwin.monitor import watch, words

    watched = watch.watch(predictor, watch.load_batch(args.batch, predictor, fmt))
    if args.output:
        predictor.write(watched.table, args.output, fmt)
        with files.atomic_path(Path(args.output).with_name("monitor.md")) as temporary:
            temporary.write_text(words.markdown(watched, Path(args.batch).name))
    if args.plot:
        from hybridtwin.monitor.figure import monitor

        files.save_figure(monitor(watched, f"Monitor: {Path(args.batch).name}"), args.plot)
    print(words.summary(watched))


def main(argv=None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(levelname)s: %(message)s", stream=sys.stderr)
    args = parser().parse_args(argv)
    try:
        run(args)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # the screen's reader stopped early (| head): not an error of the answer
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's own advice, so exit flushes quietly
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
