"""The questions an engineer asks: one setting changed from typical production, a row of their own, a sweep.

Inputs not given take their typical production value (the median of the in-support parts, stored with the
models) or a base row's; the answer says which were filled. Values typed on the command line accept either
decimal mark (a person types them, with no digit grouping).
"""

from __future__ import annotations

import difflib
import re

import numpy as np
import pandas as pd

from hybridtwin.io.errors import InputError

# "NAME=LOW:HIGH:N", the sweep's range and number of values
SWEEP = re.compile(r"^(?P<name>[^=]+)=(?P<low>[^:]+):(?P<high>[^:]+):(?P<n>\d+)$")


def number(text: str, where: str) -> float:
    """A value typed by a person: '0.75' or '0,75'; not '1.234,5' (digit grouping) nor '0.7mm'."""
    value = text.strip()
    if re.fullmatch(r"[-+]?[1-9]\d{0,2},\d{3}", value):  # a decimal comma, or digit grouping: not to be guessed
        raise InputError(
            f"{where}: {text!r} is ambiguous: a thousand with digit grouping, or {value.replace(',', '.')}? "
            f"write {value.replace(',', '')} or {value.replace(',', '.')}"
        )
    if value.count(",") == 1 and "." not in value:
        value = value.replace(",", ".")
    try:
        parsed = float(value)
    except ValueError:
        hint = " (write the number alone, with one decimal mark and no digit grouping: 0.75)" if value else ""
        raise InputError(f"{where}: {text!r} is not a number{hint}") from None
    if not np.isfinite(parsed):
        raise InputError(f"{where}: {text!r} is not a finite number")
    return parsed


def known_name(name: str, known, what: str) -> str:
    """``name`` if it is one of ``known``; otherwise an error that says which are, and the closest."""
    name = name.strip()
    if name in known:
        return name
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.5)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise InputError(f"{what} {name!r} is not an input of these models{hint}. They take {', '.join(known)}")


def pairs(settings: list[str], inputs) -> dict[str, float]:
    """``--set NAME=VALUE`` pairs, each name an input."""
    values = {}
    for pair in settings:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--set {pair!r}: write NAME=VALUE, for example --set {list(inputs)[0]}=1.0")
        name = known_name(name, inputs, f"--set {pair!r}:")
        if name in values:
            raise InputError(f"--set {name} is given twice; give each input once")
        values[name] = number(value, f"--set {pair!r}")
    return values


def filled(values: dict[str, float], inputs, base: dict[str, float], origin: str) -> pd.DataFrame:
    """One row of every input: ``values`` where given, ``base`` elsewhere; ``filled_inputs`` says which inputs
    came from ``origin`` (typical production, a base row)."""
    row = {name: values.get(name, base.get(name, np.nan)) for name in inputs}
    missing = [name for name in inputs if np.isnan(row[name])]
    if missing:
        raise InputError(f"no value for {', '.join(missing)}: give it with --set NAME=VALUE")
    taken = [name for name in inputs if name not in values]
    frame = pd.DataFrame([row])
    frame["filled_inputs"] = f"{', '.join(taken)} from {origin}" if taken else ""
    return frame


def sweep_values(text: str, inputs) -> tuple[str, np.ndarray]:
    """``--vary NAME=LOW:HIGH:N``: the input and its N values from LOW to HIGH."""
    match = SWEEP.match(text.strip())
    if not match:
        given = text.partition("=")[0].strip()
        name = given if given in list(inputs) else list(inputs)[0]
        raise InputError(f"--vary {text!r}: write NAME=LOW:HIGH:N, N values from LOW to HIGH: --vary {name}=LOW:HIGH:N")
    name = known_name(match["name"], inputs, f"--vary {text!r}:")
    low, high = number(match["low"], f"--vary {text!r}"), number(match["high"], f"--vary {text!r}")
    n = int(match["n"])
    if not high > low:
        raise InputError(f"--vary {text!r}: LOW ({low:g}) must be below HIGH ({high:g})")
    if n < 2 or n > 10_000:
        raise InputError(f"--vary {text!r}: N ({n}) must be between 2 and 10000")
    return name, np.linspace(low, high, n)


def sweep_frame(base: pd.DataFrame, name: str, values: np.ndarray) -> pd.DataFrame:
    """The base row repeated once per value of ``name``."""
    frame = base.loc[base.index.repeat(len(values))].reset_index(drop=True)
    frame[name] = values
    return frame
