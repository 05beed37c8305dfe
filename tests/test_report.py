"""hybridtwin.report: the diagnosis in words: signs, sizes, the named cause and what could not be separated."""

import pandas as pd
import pytest

from hybridtwin.report.diagnosis_md import diagnosis_markdown

from .conftest import says

CAUSES = pd.DataFrame(
    [
        {"rank": 1, "cause": "die_temp_c", "form": "sigmoid", "explained_share": 0.62, "p_value": 1e-9},
        {"rank": 2, "cause": "coil_id", "form": "group", "explained_share": 0.75, "p_value": 1e-6},
    ]
)
GAIN = pd.DataFrame(
    [
        {
            "model": "hybrid",
            "rmse_in_support_cv": 1.4,
            "rmse_out_of_support": 2.0,
            "rmse_matched": 1.1,
            "evaluated_on": "test rows",
        },
        {
            "model": "extended",
            "rmse_in_support_cv": 1.4,
            "rmse_out_of_support": 1.5,
            "rmse_matched": 1.0,
            "evaluated_on": "test rows",
        },
    ]
)


def _summary(offset, selected=True):
    cause = {
        "name": "die_temp_c",
        "form": "sigmoid",
        "family": "saturating",
        "description": "saturating change of -9.7 mm around die_temp_c = 41.1",
        "effect_range": 9.7,
        "p_value": 1e-9,
    }
    return {
        "offset": offset,
        "offset_se": 0.1,
        "n_rows": 1234,
        "residual_std": 3.0,
        "surrogate_std": 1.0,
        "min_effect": 1.0,
        "selected": [cause] if selected else [],
        "aliases": {"die_temp_c": []},
        "explained_by": {},
        "proxies": {"coil_id": {"accounted_by": ["the model inputs", "die_temp_c"], "share": 0.81}},
        "by_chance": {"thickness_mm": {"id": "coil_id", "levels": 18, "p_value": 0.065}},
    }


@pytest.mark.parametrize("offset, size, direction", [(-3.25, "3.25 mm", "lower"), (7.5, "7.50 mm", "higher")])
def test_offset_sign_and_size(offset, size, direction):
    text = diagnosis_markdown(CAUSES, _summary(offset), GAIN, "draw-in", "mm", None, "runs/p4/figures")
    says(text, "## Offset", "`draw-in`", size, direction)


def test_names_the_cause_the_table_ranks_first_and_the_id_it_stands_for():
    text = diagnosis_markdown(CAUSES, _summary(2.0), GAIN, "draw-in", "mm", None, "runs/p4/figures")
    says(text, "1,234 in-support", "## Causes", "1. **`die_temp_c`**", "sigmoid", "saturating", "62.0%")
    says(text, "`runs/p4/figures/cause_1.png`")  # the run's own results folder
    says(text, "`coil_id`", "an id, not a cause", "the model inputs", "surrogate's own error", "`die_temp_c`", "81%")
    says(text, "`thickness_mm` is constant within each level of `coil_id`", "18 levels", "p = 0.065")


def test_out_of_support_gain_in_words():
    text = diagnosis_markdown(CAUSES, _summary(2.0), GAIN, "draw-in", "mm", None, "runs/p4/figures")
    says(text, "Out of the support", "extended", "1.50 mm", "2.00 mm", "paper's hybrid", "25% lower")
    worse = GAIN.assign(rmse_out_of_support=[1.0, 1.5])
    assert "no gain." in diagnosis_markdown(CAUSES, _summary(2.0), worse, "draw-in", "mm", None, "runs/p4/figures")


def test_says_plainly_when_nothing_is_significant():
    text = diagnosis_markdown(CAUSES, _summary(2.0, selected=False), GAIN, "draw-in", "mm", None, "runs/p4/figures")
    says(text, "No cause beyond the offset is significant", "not significant", "`die_temp_c`")


def test_an_effect_within_the_surrogates_uncertainty_is_said_too_small_to_tell_and_not_named():
    small = [{"name": "ambient_temp_c", "form": "quadratic", "effect_std": 0.61, "p_value": 2e-8}]
    alone = {**_summary(2.0, selected=False), "too_small": small}
    text = diagnosis_markdown(CAUSES, alone, GAIN, "draw-in", "mm", None, "runs/p4/figures")
    says(text, "No cause beyond the offset is significant", "Too small to tell from the surrogate's own error")
    says(text, "`ambient_temp_c`", "quadratic", "0.61 mm std", "less than the surrogate's own uncertainty (1.00 mm")
    assert "Strongest candidate, not significant" not in text and "beyond the causes above" not in text
    text = diagnosis_markdown(CAUSES, {**_summary(2.0), "too_small": small}, GAIN, "draw-in", "mm", None, "f")
    says(text, "1. **`die_temp_c`**", "Too small to tell", "beyond the causes above, the test finds `ambient_temp_c`")
    assert "Too small" not in diagnosis_markdown(CAUSES, _summary(2.0), GAIN, "draw-in", "mm", None, "f")


def test_user_names_are_inert_in_markdown_and_html():
    text = diagnosis_markdown(CAUSES, _summary(2.0), GAIN, "Einzug <b>mm</b>", "m<i>m</i>", None, "figures")
    assert "<b>" not in text.replace("`Einzug <b>mm</b>`", "") and "<i>" not in text
    says(text, "# ", "`Einzug <b>mm</b>`")
    assert "m&lt;i&gt;m&lt;/i&gt;" in text


def test_a_sample_of_the_in_support_parts_is_stated():
    summary = {**_summary(2.0), "n_rows": 10_000, "n_in_support": 11_823}
    text = diagnosis_markdown(CAUSES, summary, GAIN, "draw-in", "mm", None, "runs/p4/figures")
    says(text, "sample", "10,000", "11,823 in-support")
    assert "| model | in support (CV) | out of support |" in text


def test_report_pages_escape_names_give_human_headers_and_units():
    from hybridtwin.report import pages

    table = pd.DataFrame({"model": ["<b>hybrid</b>"], "rmse_truth_out_of_support": [1.23456], "n_test": [11823]})
    page = pages.table_page(table, "Table 5", "results/tables/table5.csv", "°C")
    assert "&lt;b&gt;hybrid&lt;/b&gt;" in page and "<b>hybrid" not in page
    assert "<th>RMSE truth out of support [°C]</th>" in page and "<th>n test</th>" in page
    assert "<td>1.235</td>" in page and "<td>11,823</td>" in page
    # the user's own columns keep their names (and get no unit of the target's)
    own = pages.table_page(pd.DataFrame({"blank_width_mm": [1.0]}), "T", "t.csv", "deg", ["blank_width_mm"])
    assert "<th>blank_width_mm</th>" in own
    words = pages.markdown_page("# Title\n\n| a | b |\n|---|---|\n| `x` | 2 |\n", "Diagnosis", "results/diagnosis.md")
    assert "<h1>Title</h1>" in words and "<td><code>x</code></td>" in words


def test_the_front_page_says_an_effect_is_too_small_to_tell():
    from hybridtwin.report import summary

    small = [{"name": "ambient_temp_c", "form": "quadratic", "effect_std": 0.61, "p_value": 2e-8}]
    lines = summary._errors({**_summary(2.0, selected=False), "too_small": small}, "draw-in", "mm")
    says("\n".join(lines), "none beyond the offset", "Too small to tell", "``ambient_temp_c``", "0.61 mm (std)")
    assert not any("Too small" in line for line in summary._errors(_summary(2.0, selected=False), "draw-in", "mm"))


def test_a_sweep_figure_per_rank_or_why_there_is_none(monkeypatch):
    from hybridtwin.report import plots

    drawn, said = [], []
    monkeypatch.setattr(plots, "sweep", lambda answers, name, span, *rest: drawn.append((name, span, rest[-1])) or name)
    monkeypatch.setattr(plots, "placeholder", lambda text: said.append(text) or text)
    sweeps = [None, ("die_temp_c", pd.DataFrame())]  # cause 1 an id, cause 2 a column
    units = {"die_temp_c": "°C"}
    figures = plots.cause_sweeps(sweeps, 2, 3, {"die_temp_c": (20.0, 50.0)}, "draw_in_mm", "mm", units)
    assert figures == ["cause 1 is an id: no sweep can show it", "die_temp_c", "no cause 3"]
    assert drawn == [("die_temp_c", (20.0, 50.0), "°C")] and len(said) == 2


def test_the_first_page_says_which_column_gave_way_to_an_id_by_chance():
    from hybridtwin.report.summary import _errors

    text = "\n".join(_errors(_summary(2.0, selected=False), "draw-in", "mm"))
    says(text, "``coil_id`` is an id, not a cause", "``thickness_mm`` is constant within each level of ``coil_id``")
    says(text, "18 levels no better than the columns ``coil_id`` holds fit them shuffled (p = 0.065)")


def test_an_id_at_settings_of_its_own_is_said_so_on_the_diagnosis_page_and_the_first_page():
    from hybridtwin.report.summary import _errors

    summary = _summary(2.0, selected=False)
    summary["proxies"] = {
        "lot": {"accounted_by": ["a smooth function of the model inputs"], "share": None, "own_p": 0.4}
    }
    for text in (
        diagnosis_markdown(CAUSES, summary, GAIN, "draw-in", "mm", None, "runs/p4/figures"),
        "\n".join(_errors(summary, "draw-in", "mm")),
    ):
        says(text, "lot", "is an id, not a cause: its levels ran at inputs of their own", "p = 0.4")


def test_a_trend_that_followed_the_settings_is_said_so_on_the_diagnosis_page_and_the_first_page():
    from hybridtwin.report.summary import _errors

    summary = _summary(2.0, selected=False)
    summary["follows_inputs"] = {"stroke_counter": {"p_value": 0.34, "power": 0.97}}
    summary["untold_trends"] = {"timestamp": {"p_value": 0.5, "power": 0.03}}
    for text in (
        diagnosis_markdown(CAUSES, summary, GAIN, "draw-in", "mm", None, "runs/p4/figures"),
        "\n".join(_errors(summary, "draw-in", "mm")),
    ):
        says(text, "stroke_counter", "is not named: a trend in time that follows the settings", "p = 0.34", "97%")
        says(text, "timestamp", "cannot be told apart from the settings that changed with time", "power of 3%")
