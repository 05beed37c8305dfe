"""Mutation testing of the method modules against the fast tests: the share of mutants each module's tests kill.

    python benchmarks/mutation.py                    # a fresh run (about 45 minutes on 2 cores, run alone)
    python benchmarks/mutation.py --modules forms    # rerun one module's mutants, keep the others' verdicts
    python benchmarks/mutation.py --modules forms --survivors  # rerun its survivors only, after adding tests
    python benchmarks/mutation.py --report           # only re-read the results of the last run in mutants/
    python benchmarks/mutation.py --sample 30        # after an unfinished run: a seeded sample of each module's
                                                     # mutants not yet run, and each module's rate estimated

mutmut (its settings: ``[tool.mutmut]`` in pyproject.toml) copies the package to ``mutants/``, changes one
operator, constant or call at a time, and runs the fast tests that reach the changed function. A mutant
is killed when a test fails. Mutants that cannot change any result (equivalent) are listed with their
reason in ``benchmarks/mutation_equivalent.txt`` and left out of the rate; the rest of the survivors,
and the mutants no fast test reaches, count against it. Writes ``benchmarks/results/mutation.md``.

A fresh run of every mutant takes hours on 2 cores: mutmut runs the mutants with the fastest tests first, and a
mutant of the diagnosis' fits or forms takes its 20 tests (about 45 s). ``--sample N`` runs, per module with
mutants not yet run, a seeded random sample of N of them (recorded in ``mutants/sample.json``). The module's rate
is then estimated by strata: the mutants run before, counted, and the rest at the sample's rate, with the 95%
Clopper-Pearson interval of that rate.
"""

import argparse
import ast
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tomllib
from collections import Counter
from pathlib import Path

from hybridtwin.answers.coverage import clopper_pearson

ROOT = Path(__file__).resolve().parent.parent
EQUIVALENT = ROOT / "benchmarks" / "mutation_equivalent.txt"
SAMPLE = ROOT / "mutants" / "sample.json"
OUT = ROOT / "benchmarks" / "results" / "mutation.md"
GOAL = 0.85
UNKILLED = ("survived", "no tests")  # mutmut's states of a mutant no fast test failed on
# forked test processes must not inherit a parent's OpenMP thread team: it hangs them (every mutant timed out)
SINGLE_THREADED = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def fast_tests() -> list[str]:
    """The fast test files, one list for mutmut and for ``known_breaks.py``."""
    settings = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mutmut"]
    return settings["pytest_add_cli_args_test_selection"]


def run_mutmut(children: int, modules: list[str], survivors_only: bool = False) -> None:
    """A fresh run of every mutant, or (``modules``) a rerun of those modules' mutants, the rest kept;
    ``survivors_only``: of their last run's survivors only (valid while only tests were added since)."""
    if not modules:
        shutil.rmtree(ROOT / "mutants", ignore_errors=True)
    selection = [f"hybridtwin.{module}.*" for module in modules]
    if survivors_only:
        selection = [name for name, state in statuses().items() if state in UNKILLED and module_of(name) in modules]
        if not selection:
            return
    mutmut_run(children, selection)


def mutmut_run(children: int, selection: list[str]) -> None:
    """``mutmut run`` of the mutants selected (every one when none is), its children single-threaded."""
    command = ["mutmut", "run", "--max-children", str(children), *selection]
    subprocess.run(command, cwd=ROOT, env={**os.environ, **SINGLE_THREADED}, check=True, stdout=subprocess.DEVNULL)


def run_sample(children: int, modules: list[str], size: int, seed: int) -> None:
    """A seeded sample of ``size`` not-yet-run mutants of each module (of ``modules``, or of every one), run and
    recorded with the module's mutants not yet run before it (beside other modules' earlier samples)."""
    unrun: dict[str, list[str]] = {}
    for name, state in statuses().items():
        if state == "not checked" and (not modules or module_of(name) in modules):
            unrun.setdefault(module_of(name), []).append(name)
    draw = random.Random(seed)
    sample = {module: sorted(draw.sample(sorted(names), min(size, len(names)))) for module, names in unrun.items()}
    record = json.loads(SAMPLE.read_text()) if SAMPLE.exists() else {"unrun": {}, "sample": {}, "seeds": {}}
    for key, value in (("unrun", unrun), ("sample", sample), ("seeds", dict.fromkeys(unrun, seed))):
        record.setdefault(key, {}).update(value)
    SAMPLE.write_text(json.dumps(record, indent=1))
    chosen = [name for names in sample.values() for name in names]
    if chosen:
        mutmut_run(children, chosen)


def statuses() -> dict[str, str]:
    """Mutant name -> status (killed, survived, no tests, timeout, ...), from mutmut's own listing."""
    listing = subprocess.run(
        ["mutmut", "results", "--all", "true"], cwd=ROOT, check=True, capture_output=True, text=True
    ).stdout
    return dict(re.findall(r"^\s*(\S+): (.+?)\s*$", listing, flags=re.MULTILINE))


def equivalent_mutants() -> dict[str, str]:
    """Name -> why it cannot change a result, from the committed list (``name  # reason`` per line)."""
    reasons = {}
    for line in EQUIVALENT.read_text().splitlines():
        name, _, reason = line.partition("#")
        if name.strip():
            reasons[name.strip()] = reason.strip()
    return reasons


# Survivors that cannot change a result, recognized by their one changed line (the rest are listed by name).
RULES = {
    "dtype": "only the dtype of a conversion changes, and every caller passes numbers of that dtype"
    " (where one may not, integers are tested: the out-of-fold splice, the CV target, the fold ids)",
    "nan spelling": 'float("NAN") is float("nan")',
    "debug message": "only the text or arguments of a debug-level log message change (logging never raises on them)",
}
DTYPE = re.compile(r"(dtype=)?\b(float|int|object)\b(?=\s*\))")


def rule_of(original: str, mutated: str) -> str | None:
    def squeeze(text: str) -> str:
        return re.sub(r"\s+", "", text)

    for match in DTYPE.finditer(original):
        keyword = match[1] or ""
        for replacement in (f"{keyword}None", ""):
            if squeeze(original[: match.start()] + replacement + original[match.end() :]) == squeeze(mutated):
                return "dtype"
    if mutated == original.replace('"nan"', '"NAN"') != original:
        return "nan spelling"
    if original.startswith("log.debug(") and mutated.startswith("log.debug("):
        return "debug message"
    return None


def changed_lines(module: Path) -> dict[str, tuple[str, str]]:
    """Mutant name -> (original line, mutated line) for mutants that change one line, read from mutmut's copy."""
    source = module.read_text()
    lines = source.splitlines()
    functions = {
        node.name: lines[node.lineno - 1 : node.end_lineno]
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.FunctionDef) and "__mutmut_" in node.name
    }
    changes = {}
    for name, lines in functions.items():
        stem, _, tag = name.rpartition("__mutmut_")
        original = functions.get(f"{stem}__mutmut_orig")
        if tag == "orig" or original is None or len(original) != len(lines):
            continue
        diff = [(a.strip(), b.strip()) for a, b in zip(original[1:], lines[1:]) if a != b]
        if len(diff) == 1:
            changes[f"{dotted(module)}.{name}"] = diff[0]
    return changes


def dotted(module: Path) -> str:
    """hybridtwin.diagnosis.fits for mutants/hybridtwin/diagnosis/fits.py."""
    return ".".join(module.relative_to(ROOT / "mutants").with_suffix("").parts)


def module_of(mutant: str) -> str:
    """A mutant's module as the table names it (diagnosis.fits for hybridtwin.diagnosis.fits.x_fit__mutmut_3)."""
    return ".".join(mutant.split(".")[1:-1])


def kinds(status: dict[str, str], equivalent: dict[str, str], names) -> Counter:
    """How many of ``names`` were killed, timed out, survived, ... or are equivalent."""
    return Counter("equivalent" if name in equivalent else status[name] for name in names)


def detected_share(count: Counter) -> tuple[int, int]:
    """(mutants detected, mutants judged): killed or timed out, of all run less the equivalent ones."""
    judged = sum(count.values()) - count["equivalent"] - count["not checked"]
    return count["killed"] + count["timeout"], judged


def sampled_rate(status, equivalent, unrun: list[str], sample: list[str]) -> tuple[float, float, float, int]:
    """A module's kill rate by strata: the mutants run before the sample counted, those still not run at the
    sample's rate (its equivalent share too); with the rate's 95% Clopper-Pearson bounds. Returns (rate, low,
    high, sample judged)."""
    module = module_of(sample[0])
    everyone = [name for name in status if module_of(name) == module]
    before = set(everyone) - set(unrun)
    known_detected, known_judged = detected_share(kinds(status, equivalent, before))
    in_sample = kinds(status, equivalent, sample)
    detected, judged = detected_share(in_sample)
    rest = len(unrun) - len(sample)
    rest_judged = rest * judged / max(judged + in_sample["equivalent"], 1)

    def rate(p: float) -> float:
        return (known_detected + detected + rest_judged * p) / (known_judged + judged + rest_judged)

    low, high = clopper_pearson(detected, judged)
    return rate(detected / judged if judged else float("nan")), rate(low), rate(high), judged


def table(status: dict[str, str], equivalent: dict[str, str], sampled: dict | None = None) -> list[str]:
    counts: dict[str, Counter] = {}
    for name, state in status.items():
        kind = "equivalent" if name in equivalent else state
        counts.setdefault(module_of(name), Counter())[kind] += 1
    lines = [
        "| module | mutants | not yet run | killed | timeout | survived | no fast test reaches it | equivalent"
        " | kill rate |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for module, count in sorted(counts.items()):
        detected, judged = detected_share(count)
        rate = detected / judged if judged else float("nan")
        verdict = " (of those run so far)" if count["not checked"] else ""
        if count["not checked"] and sampled and sampled["sample"].get(module):
            rate, low, high, n = sampled_rate(status, equivalent, sampled["unrun"][module], sampled["sample"][module])
            verdict = f" (estimated: those not yet run at the rate of {n} drawn; 95%: {low:.1%} to {high:.1%})"
        verdict += "" if rate >= GOAL else " (below goal)"
        lines.append(
            f"| {module} | {sum(count.values())} | {count['not checked']} | {count['killed']} | {count['timeout']}"
            f" | {count['survived']} | {count['no tests']} | {count['equivalent']} | {rate:.1%}{verdict} |"
        )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--report", action="store_true", help="only summarize the last run")
    parser.add_argument("--children", type=int, default=2)
    parser.add_argument("--modules", nargs="*", default=[], help="rerun only these modules' mutants (e.g. forms)")
    parser.add_argument("--sample", type=int, default=0, help="run N drawn mutants per module not yet run")
    parser.add_argument("--seed", type=int, default=0, help="the sample's seed")
    parser.add_argument(
        "--survivors", action="store_true", help="with --modules: rerun only their survivors (after adding tests)"
    )
    args = parser.parse_args()
    if args.survivors and not args.modules:
        parser.error("--survivors needs --modules")
    if args.sample:
        run_sample(args.children, args.modules, args.sample, args.seed)
    elif not args.report:
        run_mutmut(args.children, args.modules, args.survivors)
    status = statuses()
    changes = {
        name: change
        for module in (ROOT / "mutants" / "hybridtwin").rglob("*.py")
        for name, change in changed_lines(module).items()
    }
    listed = equivalent_mutants()
    equivalent = {name: reason for name, reason in listed.items() if status.get(name) in UNKILLED}
    for name, state in status.items():
        rule = rule_of(*changes[name]) if state == "survived" and name in changes else None
        if rule:
            equivalent.setdefault(name, RULES[rule])
    stale = sorted(name for name in listed if status.get(name) not in UNKILLED)
    survivors = sorted(name for name, state in status.items() if state in UNKILLED and name not in equivalent)
    lines = [
        "# Mutation testing (`python benchmarks/mutation.py`)",
        "",
        f"mutmut over the method modules, against the fast tests ({', '.join(fast_tests())}).",
        "Kill rate = (killed + timeout) / (all mutants - equivalent ones); a mutant no fast test",
        f"reaches counts as a survivor. Goal: at least {GOAL:.0%} in every module. Equivalent mutants, each with",
        "its reason: `mutation_equivalent.md`; the survivors to work on: `mutation_survivors.md`.",
        "",
        *table(status, equivalent, json.loads(SAMPLE.read_text()) if SAMPLE.exists() else None),
    ]
    if stale:
        lines += ["", "Listed as equivalent but not a survivor of this run (the list is stale):", *stale]
    OUT.write_text("\n".join(lines) + "\n")
    write_listing(
        OUT.with_name("mutation_equivalent.md"), "Equivalent mutants", sorted(equivalent), changes, equivalent
    )
    write_listing(OUT.with_name("mutation_survivors.md"), "Surviving mutants", survivors, changes, status)
    print("\n".join(lines))
    return 0


def write_listing(path: Path, title: str, names, changes, notes) -> None:
    """One line per mutant: its name, the changed line (where it changes one) and a note (a reason or a status)."""
    rows = [f"# {title} (`python benchmarks/mutation.py`)", ""]
    for name in names:
        before, after = changes.get(name, ("(several lines)", ""))
        rows.append(f"- `{name}`: {notes[name]}  \n  `{before}` -> `{after}`")
    path.write_text("\n".join(rows) + "\n")


if __name__ == "__main__":
    sys.exit(main())
