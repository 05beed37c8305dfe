"""What accounts for an id's offsets, in words: light (no numpy), for the report's pages."""

INPUT_SURFACE = "the model inputs"  # how the surface is named among what accounts for an id's offsets


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
