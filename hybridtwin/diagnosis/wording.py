"""What accounts for an id's offsets, in words: light (no numpy), for the report's pages."""

INPUT_SURFACE = "the model inputs"  # how the surface is named among what accounts for an id's offsets
SMOOTH_INPUTS = "a smooth function of the model inputs"  # what takes up the offsets of levels at inputs of their own


def accounted_words(names, code=str) -> str:
    """What accounts for an id's offsets, in words; ``code`` formats a column's name."""
    words = [
        f"{INPUT_SURFACE} (the surrogate's own error, or an effect of the inputs alone)"
        if name == INPUT_SURFACE
        else code(name)
        for name in names
    ]
    return " and ".join(words) if words else "nothing"


def by_chance_words(column: str, group: str, levels: int, p_value: float, code=str) -> str:
    """A column an id holds that fitted the id's level means no better than chance, in words."""
    return (
        f"{code(column)} is constant within each level of {code(group)}: its form fits the offsets of the {levels} "
        f"levels no better than the columns {code(group)} holds fit them shuffled (p = {p_value:.2g})"
    )


def smooth_inputs_words(own_p: float) -> str:
    """Why an id whose levels each ran at inputs of their own is not named, in words (``own_p``: the p-value of
    offsets of its own beyond a smooth function of the inputs)."""
    return (
        f"its levels ran at inputs of their own, and {SMOOTH_INPUTS} takes up its offsets as well as it does "
        f"(offsets of its own beyond that: p = {own_p:.2g}); levels run at the same settings would tell them apart"
    )


def untold_trend_words(p_value: float, power: float) -> str:
    """A chosen trend in time that the data cannot tell from the settings that changed with time, in words."""
    return (
        "cannot be told apart from the settings that changed with time: the runs of parts at the same settings "
        f"were too few or too short to show it (between them the test saw nothing, p = {p_value:.2g}, with a power "
        f"of {power:.0%} to see the trend as fitted), and {SMOOTH_INPUTS} could follow it too; longer coils, or "
        "parts run again at earlier settings, would tell them apart"
    )


def settings_in_time_words(p_value: float, power: float) -> str:
    """Why a trend in time is not named where settings changed with time, in words: the p-value of the trend
    between parts run at the same settings beyond a smooth function of the inputs, and the test's power."""
    return (
        "a trend in time that follows the settings that changed with time; between parts run at the same settings "
        f"(the halves of each run of parts with the same ids) it did not show beyond {SMOOTH_INPUTS} (p = "
        f"{p_value:.2g}), where the test had a power of {power:.0%} to see the trend as fitted"
    )
