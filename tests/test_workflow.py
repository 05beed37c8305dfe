"""The workflow end to end on config/test.yaml, in temporary folders.

One run feeds most checks (outputs, contracts, models that load, report); a
second run in another folder must give byte-identical tables; a third reuses the
first folder with changed matched cases, which must not move any trained model.
"""

import base64
import filecmp
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import xgboost as xgb
import yaml

from hybridtwin.diagnosis.extension import DiscrepancyExtension
from hybridtwin.io import files
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.surrogate import GPRSurrogate

from .conftest import ROOT, run_command, says

pytestmark = pytest.mark.workflow
TEST_CONFIG = os.path.join(ROOT, "config", "test.yaml")


def snakemake(workdir, *args, config=TEST_CONFIG, check=True, **popen):
    command = [
        sys.executable,
        "-m",
        "snakemake",
        *args,
        "-s",
        os.path.join(ROOT, "Snakefile"),
        "-d",
        str(workdir),
        "--configfile",
        str(config),
        "--cores",
        "2",
        "--quiet",
        "progress",
    ]
    if popen:
        return subprocess.Popen(command, **popen)
    result = run_command(command, timeout=900)
    if check and result.returncode != 0:
        raise AssertionError(f"snakemake {' '.join(args)} failed:\n{result.stderr[-4000:]}")
    return result


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("run")
    snakemake(workdir)
    return workdir


def test_every_contracted_output_exists(run_dir):
    results = run_dir / "results"
    for name in (
        "table1_datasets",
        "table2_surrogate_cv",
        "table3_residual_cv",
        "table4_hyperparameters",
        "table5_sensitivity",
        "matched_check",
        "discrepancy_causes",
        "model_extension",
        "prediction_intervals",
        "peer_comparison",
    ):
        assert (results / "tables" / f"{name}.csv").stat().st_size > 0, name
    comparison = pd.read_csv(results / "tables/peer_comparison.csv")
    assert {"gp_discrepancy", "cokriging", "stack", "recommended", "hybrid"} <= set(comparison["model"])
    # every model is scored out of the support (the stack only where a region had parts enough to blend on)
    scored = comparison.set_index("model")
    assert scored.drop(index="stack")["rmse_truth_out_of_support"].notna().all()
    assert (scored.drop(index="stack")["n_out_of_support"] > 0).all()
    for name in ("figure2_residual_check", "figure3_error_distributions", "cause_1"):
        assert (results / "figures" / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
    assert list((results / "synthetic").glob("*.csv"))
    for rule_log in ("tune_residual", "diagnose", "support_gate"):
        assert (results / "logs" / f"{rule_log}.log").exists()
        assert (results / "benchmarks" / f"{rule_log}.tsv").exists()


# CSV files whose columns are not the catalogue's to list: your files and the demo's, and the answers of the
# what-if and monitor commands (their pages list those columns, and their tests hold them to the commands)
COLUMNS_ELSEWHERE = ("data/", "demo/", "predictions/whatif.csv", "monitor/monitor.csv")


def test_every_file_and_column_a_run_writes_is_in_the_outputs_catalogue(run_dir):
    from hybridtwin.io import outputs
    from hybridtwin.paper.tuning import DEFAULT_SEARCH_SPACE

    config = yaml.safe_load(open(TEST_CONFIG))
    results = run_dir / "results"
    written = [path.relative_to(results).as_posix() for path in results.rglob("*") if path.is_file()]
    assert len(written) > 60
    for relative in written:
        entry = outputs.entry_for(relative)
        assert entry is not None, f"{relative} is not in hybridtwin/io/outputs.yaml"
        if not relative.endswith((".csv", ".parquet")) or relative.startswith(COLUMNS_ELSEWHERE):
            continue
        if relative.endswith(".parquet"):
            header = pq.read_schema(results / relative).names
        else:
            header = pd.read_csv(results / relative, nrows=0, sep=config.get("csv", {}).get("sep", ",")).columns
        missing = outputs.undescribed_columns(entry, header, config["columns"]["inputs"], DEFAULT_SEARCH_SPACE)
        assert not missing, f"{relative}: columns {missing} are not described in hybridtwin/io/outputs.yaml"


def test_production_predictions_contract(run_dir):
    predictions = pd.read_csv(run_dir / "results/predictions/production.csv")
    production = pd.read_csv(run_dir / "results/demo/production.csv")
    assert len(predictions) == len(production)
    assert predictions["row"].tolist() == list(range(len(production)))
    for column in (
        "in_support",
        "knn_distance",
        "pred_surrogate",
        "pred_hybrid",
        "pred_hybrid_gated",
        "pred_extended",
        "pred_extended_hybrid",
        "pred_hybrid_oof",
        "pred_hybrid_unfiltered_oof",
    ):
        assert column in predictions and predictions[column].notna().all(), column
    # out of fold where a model was trained: the filtered model's values differ from its final fit inside only
    inside = predictions["in_support"]
    assert not np.allclose(predictions.loc[inside, "pred_hybrid_oof"], predictions.loc[inside, "pred_hybrid"])
    assert np.allclose(predictions.loc[~inside, "pred_hybrid_oof"], predictions.loc[~inside, "pred_hybrid"])
    outside = ~predictions["in_support"]
    assert np.allclose(predictions.loc[outside, "pred_hybrid_gated"], predictions.loc[outside, "pred_surrogate"])
    assert np.allclose(predictions["measured"], production["draw_in_mm"])


def test_tables_contracts(run_dir):
    tables = run_dir / "results/tables"
    causes = pd.read_csv(tables / "discrepancy_causes.csv")
    assert {"rank", "cause", "form", "explained_share", "effect_range", "significant"} <= set(causes.columns)
    assert causes["rank"].tolist() == list(range(1, len(causes) + 1))
    gain = pd.read_csv(tables / "model_extension.csv")
    assert gain["model"].tolist() == ["surrogate", "hybrid", "extended", "extended_hybrid"]
    assert {"rmse_in_support_cv", "rmse_out_of_support", "rmse_matched"} <= set(gain.columns)
    table5 = pd.read_csv(tables / "table5_sensitivity.csv")
    assert table5["region"].tolist() == ["in_support", "out_of_support", "all"]
    table1 = pd.read_csv(tables / "table1_datasets.csv")
    support = files.read_checked(run_dir / "results/support/production_support.parquet")
    assert table1.loc[table1["dataset"] == "Production in-support subset", "size"].item() == support["in_support"].sum()
    for name in ("table2_surrogate_cv", "table3_residual_cv", "table5_sensitivity", "matched_check", "model_extension"):
        assert "evaluated_on" in pd.read_csv(tables / f"{name}.csv"), f"{name} must say on what data it was computed"


def test_diagnosis_report_states_the_data(run_dir):
    """The offset is the mean in-support residual in sign and size, and the top cause is the table's first."""
    results = run_dir / "results"
    text = (results / "diagnosis.md").read_text()
    residuals = files.read_checked(results / "residuals/production_residuals.parquet")
    offset = residuals.loc[residuals["in_support"].astype(bool), "residual_approx"].mean()
    says(text, "`draw_in_mm`", f"{abs(offset):.2f} mm", "higher" if offset > 0 else "lower")
    summary = json.loads((results / "diagnosis/diagnosis.json").read_text())
    assert summary["offset"] == pytest.approx(offset)
    causes = pd.read_csv(results / "tables/discrepancy_causes.csv")
    top = causes.iloc[0]
    if top["selected"]:
        assert f"1. **`{top['cause']}`**, form *{top['form']}*" in text
    else:
        assert "**No cause beyond the offset is significant.**" in text and f"`{top['cause']}`" in text


def test_models_load_with_their_own_loaders_and_reproduce_predictions(run_dir):
    models = run_dir / "results/models"
    for path in models.rglob("*"):
        if path.is_file():
            assert path.suffix == ".json", f"{path.name}: only JSON model files"
            json.loads(path.read_text())  # plain JSON, nothing to unpickle
    assert not list((run_dir / "results").rglob("*.pkl")) and not list((run_dir / "results").rglob("*.pickle"))
    production = files.read_checked(run_dir / "results/data/production.parquet")
    predictions = pd.read_csv(run_dir / "results/predictions/production.csv")
    inputs = yaml.safe_load(open(TEST_CONFIG))["columns"]["inputs"]
    X = production[inputs].to_numpy(float)
    surrogate = GPRSurrogate.from_dict(files.read_json(models / "surrogate_gpr.json")).predict(X)
    assert np.allclose(surrogate, predictions["pred_surrogate"], atol=1e-5)
    booster = xgb.Booster()
    booster.load_model(models / "residual_xgb_filtered.json")
    residual = booster.predict(xgb.DMatrix(production[inputs]))  # the model checks the column names
    assert np.allclose(surrogate + residual, predictions["pred_hybrid"], atol=1e-4)
    gate = KNNSupportGate.from_dict(files.read_json(models / "support_gate.json"))
    assert (gate.predict(X) == predictions["in_support"].to_numpy()).all()
    extension = DiscrepancyExtension.from_dict(files.read_json(models / "extension.json"))
    assert np.allclose(surrogate + extension.predict(production), predictions["pred_extended"], atol=1e-4)


def test_same_config_same_data_same_tables(run_dir, tmp_path):
    snakemake(tmp_path)
    comparison = filecmp.dircmp(run_dir / "results/tables", tmp_path / "results/tables")
    assert comparison.left_list == comparison.right_list
    _, mismatch, errors = filecmp.cmpfiles(
        run_dir / "results/tables", tmp_path / "results/tables", comparison.common_files, shallow=False
    )
    assert not mismatch and not errors, f"tables differ between two runs: {mismatch}"


def embedded_page(report_html: str, name: str) -> str:
    """A result embedded in Snakemake's self-contained report (a base64 data URI named by the file)."""
    match = re.search(rf"filename={re.escape(name)};base64,([A-Za-z0-9+/=]+)", report_html)
    assert match, f"{name} is not embedded in the report"
    return base64.b64decode(match.group(1)).decode("utf-8")


def test_report_shows_the_tables_and_the_diagnosis_inside_it(run_dir):
    snakemake(run_dir, "--report", "results/report.html")
    html = (run_dir / "results/report.html").read_text(errors="replace")
    assert "figure2_residual_check.png" in html
    # tables reach the report as HTML pages (shown inside it), with their values and human headers
    table5 = pd.read_csv(run_dir / "results/tables/table5_sensitivity.csv")
    page = embedded_page(html, "table5.html")
    number = table5["rmse_filtered_train_gated"].iloc[0]
    assert f"{number:.4g}" in page and "<table" in page and "RMSE" in page
    diagnosis = embedded_page(html, "diagnosis.html")
    assert "<h1>What the simulation gets wrong" in diagnosis and "<table>" in diagnosis


def test_matched_cases_never_used_for_training_or_tuning(run_dir, tmp_path):
    workdir = tmp_path / "matched"
    shutil.copytree(run_dir, workdir, symlinks=True)
    matched = pd.read_csv(workdir / "results/demo/matched.csv")
    matched["draw_in_meas_mm"] += 25.0
    matched.to_csv(workdir / "results/demo/matched.csv", index=False)
    before = {p.name: p.read_bytes() for p in (workdir / "results/models").glob("*.json")}
    tables = ("table3_residual_cv.csv", "table4_hyperparameters.csv", "table2_surrogate_cv.csv")
    tables_before = {name: (workdir / "results/tables" / name).read_bytes() for name in tables}
    snakemake(workdir, "--rerun-triggers", "mtime")
    assert {p.name: p.read_bytes() for p in (workdir / "results/models").glob("*.json")} == before
    assert {name: (workdir / "results/tables" / name).read_bytes() for name in tables} == tables_before
    assert (workdir / "results/tables/matched_check.csv").read_bytes() != (
        run_dir / "results/tables/matched_check.csv"
    ).read_bytes()


def _complete_trials(journal: Path) -> list[dict]:
    import optuna

    storage = optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(journal)))
    trials = []
    for summary in optuna.study.get_all_study_summaries(storage):
        study = optuna.load_study(study_name=summary.study_name, storage=storage)
        finished = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
        trials += [t.params for t in sorted(study.get_trials(states=finished), key=lambda t: t.number)]
    return trials


def _tuning_under_way(workdir, n_trials: int):
    """A run started (in its own process group) on a slow tuning setup, once 2 trials have finished:
    returns the Snakemake process, the config it runs with and the study's journal."""
    config = yaml.safe_load(open(TEST_CONFIG))
    config["tuning"]["n_trials"] = n_trials
    config["tuning"]["search_space"] = {
        "n_estimators": {"low": 300, "high": 600, "type": "int"},
        "max_depth": {"low": 6, "high": 10, "type": "int"},
    }
    config_path = workdir / "config.yaml"
    config_path.write_text(yaml.safe_dump(config))
    snakemake(workdir, "results/residuals/production_residuals.parquet", config=config_path)
    journal = workdir / "results/optuna/journal.log"
    process = snakemake(
        workdir,
        "results/tuning/best_params.json",
        config=config_path,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.time() + 240
    while time.time() < deadline and (not journal.exists() or len(_complete_trials(journal)) < 2):
        time.sleep(0.5)
    return process, config_path, journal


def test_killed_tuning_resumes_and_keeps_finished_trials(tmp_path):
    process, config_path, journal = _tuning_under_way(tmp_path, 10)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    finished = _complete_trials(journal)
    assert 2 <= len(finished) < 10, "the run should have been killed during tuning"
    assert not (tmp_path / "results/tuning/best_params.json").exists()
    snakemake(tmp_path, "--unlock", config=config_path)  # a killed Snakemake leaves its lock behind
    snakemake(tmp_path, "results/tuning/best_params.json", config=config_path)
    after = _complete_trials(journal)
    assert len(after) == 10
    assert after[: len(finished)] == finished, "finished trials must be kept as they were"


def _group_alive(group: int) -> bool:
    try:
        os.killpg(group, 0)
    except ProcessLookupError:
        return False
    return True


def test_a_killed_runs_orphan_never_overwrites_the_rerun(tmp_path):
    first, config_path, _ = _tuning_under_way(tmp_path, 8)
    first.send_signal(signal.SIGKILL)  # Snakemake alone: its tuning job is left running
    first.wait()
    assert _group_alive(first.pid), "no orphan: the job died with the workflow (then there is nothing to guard)"
    os.killpg(first.pid, signal.SIGSTOP)  # hold the orphan back until the rerun has finished
    try:
        snakemake(tmp_path, "--unlock", config=config_path)
        snakemake(tmp_path, "results/tuning/best_params.json", config=config_path)
        outputs = [tmp_path / "results/tuning" / name for name in ("best_params.json", "trials.csv")]
        written = {path: (path.read_bytes(), path.stat().st_mtime_ns) for path in outputs}
        os.killpg(first.pid, signal.SIGCONT)
        deadline = time.time() + 300
        while time.time() < deadline and _group_alive(first.pid):  # the orphan's time passes
            time.sleep(0.5)
        assert not _group_alive(first.pid), "the orphaned job still runs"
        assert {path: (path.read_bytes(), path.stat().st_mtime_ns) for path in outputs} == written
    finally:
        if _group_alive(first.pid):
            os.killpg(first.pid, signal.SIGKILL)


def test_two_tuning_workers_lose_no_trials(tmp_path):
    script = (
        "import sys, numpy as np\n"
        "from hybridtwin.paper import tuning\n"
        "rng = np.random.default_rng(0); X = rng.normal(size=(300, 3)); y = X[:, 0] + rng.normal(0, .1, 300)\n"
        "tuning.tune(X, y, n_trials=8, n_folds=3, seed=int(sys.argv[2]), storage=sys.argv[1],\n"
        "              space={'n_estimators': {'low': 5, 'high': 30, 'type': 'int'},\n"
        "                     'max_depth': {'low': 2, 'high': 4, 'type': 'int'}})\n"
    )
    journal = tmp_path / "shared.log"
    # the same data, space, folds and seed: both workers join one study
    workers = [subprocess.Popen([sys.executable, "-c", script, str(journal), "3"]) for _ in range(2)]
    assert all(worker.wait(timeout=300) == 0 for worker in workers)
    import optuna

    storage = optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(str(journal)))
    (summary,) = optuna.study.get_all_study_summaries(storage)
    trials = optuna.load_study(study_name=summary.study_name, storage=storage).get_trials()
    assert len(trials) >= 8
    assert [t.number for t in trials] == list(range(len(trials))), "no trial number lost"
    finished = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    assert all(t.state in finished for t in trials), "every trial of both workers finished"


def test_the_tuning_runs_as_the_configured_number_of_worker_jobs(tmp_path):
    config = yaml.safe_load(open(TEST_CONFIG))
    config.setdefault("tuning", {})["workers"] = 3
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    dry = snakemake(tmp_path, "-n", config=path)
    workers = re.findall(r"^rule tune_worker:\n(?:    .*\n)*?    output: (\S+)", dry.stdout, re.M)
    assert sorted(Path(w).name for w in workers) == ["worker_0.json", "worker_1.json", "worker_2.json"]
    assert len(re.findall(r"^rule tune_residual:", dry.stdout, re.M)) == 1


def planned_rules(workdir, config) -> set[str]:
    """The rules a dry run would run."""
    dry = snakemake(workdir, "-n", config=config)
    return set(re.findall(r"^(?:local)?rule (\w+):", dry.stdout, re.M))


def test_a_config_with_its_keys_in_another_order_reruns_nothing(run_dir, tmp_path):
    def reversed_keys(value):
        return {key: reversed_keys(value[key]) for key in reversed(value)} if isinstance(value, dict) else value

    config = tmp_path / "config.yaml"
    config.write_text(yaml.safe_dump(reversed_keys(yaml.safe_load(open(TEST_CONFIG))), sort_keys=False))
    assert planned_rules(run_dir, config) == set()


# ---- the frozen predictor (what-if questions) on the run's models ----

SHARED_WITH_PRODUCTION = (
    "in_support",
    "knn_distance",
    "pred_surrogate",
    "pred_hybrid",
    "pred_hybrid_gated",
    "pred_hybrid_unfiltered",
    "pred_extended",
    "pred_extended_hybrid",
    "pred_gp_discrepancy",
    "pred_cokriging",
)


def _as_written(frame: pd.DataFrame, columns, path) -> pd.DataFrame:
    """Columns as the workflow writes them (files.write_csv's float format), read back as text."""
    files.write_csv(frame[list(columns)], path)
    return pd.read_csv(path, dtype=str)


def test_predictor_api_reproduces_the_production_predictions(run_dir, tmp_path):
    from hybridtwin import Predictor

    predictor = Predictor.load(run_dir / "results/models")
    production = pd.read_csv(run_dir / "results/demo/production.csv")
    answers = predictor.predict(production, all_models=True)
    written = pd.read_csv(run_dir / "results/predictions/production.csv", dtype=str)
    pd.testing.assert_frame_equal(
        _as_written(answers, SHARED_WITH_PRODUCTION, tmp_path / "answers.csv"), written[list(SHARED_WITH_PRODUCTION)]
    )
    # the input's rows and columns come back first, in their order
    assert list(answers.columns[: production.shape[1]]) == list(production.columns)
    pd.testing.assert_frame_equal(answers[production.columns], production)
    # columns in another order give the same answers: they are taken by name
    shuffled = predictor.predict(production[production.columns[::-1]], all_models=True)
    pd.testing.assert_frame_equal(shuffled[answers.columns], answers)


def test_the_predictor_follows_the_guard_out_of_the_support(run_dir):
    import copy
    from dataclasses import replace

    from hybridtwin import Predictor

    predictor = Predictor.load(run_dir / "results/models")
    assert (
        predictor.extension.out_of_support
        == files.read_json(run_dir / "results/models/extension.json")["extended_hybrid_out_of_support"]
    )
    production = pd.read_csv(run_dir / "results/demo/production.csv").head(2000)
    inside = predictor.gate.predict(production[predictor.inputs].astype(float))
    assert inside.any() and (~inside).any()
    # the test run's extension is close to the hybrid: shifted by 5 mm, ignoring the choice would show
    shifted = copy.deepcopy(predictor.extension)
    shifted.extension.offset_ += 5.0
    stands = replace(predictor, extension=replace(shifted, out_of_support=True)).predict(production, all_models=True)
    falls = replace(predictor, extension=replace(shifted, out_of_support=False)).predict(production, all_models=True)
    extended_hybrid, hybrid = "pred_extended_hybrid", "pred_hybrid"
    assert np.abs(stands[extended_hybrid] - stands[hybrid])[~inside].min() > 1.0
    np.testing.assert_allclose(falls[extended_hybrid][~inside], falls[hybrid][~inside])
    np.testing.assert_allclose(falls[extended_hybrid][inside], stands[extended_hybrid][inside])
    remainder = predictor.extension.remainder.predict(production[predictor.inputs].astype(float))
    np.testing.assert_allclose(stands[extended_hybrid], stands["pred_extended"] + remainder)


def test_every_model_file_names_its_inputs(run_dir):
    inputs = yaml.safe_load(open(TEST_CONFIG))["columns"]["inputs"]
    models = run_dir / "results/models"
    for name in (
        "surrogate_gpr.json",
        "support_gate.json",
        "doe_standardization.json",
        "predictor.json",
        "peer_gp_discrepancy.json",
        "peer_cokriging.json",
    ):
        assert files.read_json(models / name)["inputs"] == inputs, name
    for name in ("residual_xgb_filtered.json", "residual_xgb_unfiltered.json", "residual_xgb_extended.json"):
        booster = xgb.Booster()
        booster.load_model(models / name)
        assert booster.feature_names == inputs, name


def test_a_setting_beyond_the_doe_range_is_out_of_the_domain_even_inside_the_gate(run_dir):
    from hybridtwin import Predictor

    predictor = Predictor.load(run_dir / "results/models")
    doe = files.read_checked(run_dir / "results/data/doe.parquet")
    # typical production (in support, like the logged parts: validated), and the DoE's median setting with the die
    # half a degree above every simulation (inside the gate, beyond a DoE range)
    typical = pd.DataFrame([predictor.typical])[list(predictor.inputs)]
    hotter = doe[predictor.inputs].median().to_frame().T.assign(die_temp_c=doe["die_temp_c"].max() + 0.5)
    answers = predictor.predict(pd.concat([typical, hotter], ignore_index=True), all_models=True)
    assert answers["in_domain"].tolist() == [True, False]
    assert answers.loc[1, "in_support"]  # the gate alone lets it pass
    assert answers.loc[1, "interval_region"] != "in_support" and answers.loc[1, "model_region"] == "in_support"
    assert answers.loc[1, "outside_doe_range"].startswith("die_temp_c 0.5 above the DoE's max")
    assert answers.loc[0, "trust"] == "validated" and answers.loc[1, "trust"] != "validated"
    says(answers.loc[1, "trust_reason"], "die_temp_c", "0.5 °C above the DoE's maximum")
    assert answers.loc[0, "pred_lower"] < answers.loc[0, "pred_recommended"] < answers.loc[0, "pred_upper"]


def _cli(*args, cwd):
    return run_command(
        ["hybridtwin", "predict", *map(str, args)],
        timeout=120,
        cwd=cwd,
        env={"PATH": os.environ["PATH"], "HOME": os.environ.get("HOME", "/tmp")},
    )


def test_cli_runs_from_a_fresh_shell_and_matches_the_api(run_dir, tmp_path):
    from hybridtwin import Predictor

    settings = pd.read_csv(run_dir / "results/demo/production.csv").iloc[:25]
    settings.to_csv(tmp_path / "new.csv", index=False)
    result = _cli(
        tmp_path / "new.csv",
        "--models",
        run_dir / "results/models",
        "-o",
        tmp_path / "out.csv",
        "--level",
        "0.8",
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    answers = pd.read_csv(tmp_path / "out.csv")
    expected = Predictor.load(run_dir / "results/models").predict(settings, level=0.8)
    assert answers["recommended_model"].tolist() == expected["recommended_model"].tolist()
    assert np.allclose(answers["pred_upper"], expected["pred_upper"], rtol=1e-7)
    assert (answers["interval_level"] == 0.8).all()
    one = {name: settings.loc[0, name] for name in yaml.safe_load(open(TEST_CONFIG))["columns"]["inputs"]}
    result = _cli("--models", run_dir / "results/models", *[f"--set={k}={v}" for k, v in one.items()], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    says(result.stdout, "prediction:", f"{expected.loc[0, 'pred_recommended']:.2f}", "trust:")


@pytest.mark.parametrize(
    "fault, expected",
    [
        ("missing", ["what-if file", "no column 'rp02_mpa'", "that the models take as an input"]),
        ("text", ["what-if file", "column 'die_temp_c'", "row 3 (line 4)", "'warm'", "not a number"]),
        (
            "decimal_comma",
            ["what-if file", "column 'thickness_mm'", "row 1 (line 2)", "decimal comma", "--decimal comma"],
        ),
    ],
)
def test_cli_bad_input_gets_the_workflows_messages(run_dir, tmp_path, fault, expected):
    settings = pd.read_csv(run_dir / "results/demo/production.csv").iloc[:5].astype(object)
    if fault == "missing":
        settings = settings.drop(columns="rp02_mpa")
    elif fault == "text":
        settings.loc[2, "die_temp_c"] = "warm"
    else:
        settings["thickness_mm"] = [f"{value:.3f}".replace(".", ",") for value in settings["thickness_mm"]]
    path = tmp_path / "bad.csv"
    settings.to_csv(path, index=False)  # a value "0,752" is quoted: a decimal comma in a comma-separated file
    result = _cli(path, "--models", run_dir / "results/models", "-o", tmp_path / "out.csv", cwd=tmp_path)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr
    for text in expected:
        assert text in result.stderr, result.stderr
    assert not (tmp_path / "out.csv").exists()


def test_whatif_key_adds_one_rule_and_its_answers_are_the_clis(run_dir, tmp_path):
    workdir = tmp_path / "whatif"
    shutil.copytree(run_dir, workdir, symlinks=True)
    settings = pd.read_csv(run_dir / "results/demo/production.csv").iloc[100:140]
    settings.to_csv(workdir / "settings.csv", index=False)
    config = yaml.safe_load(open(TEST_CONFIG))
    config["whatif"] = "settings.csv"
    (workdir / "config.yaml").write_text(yaml.safe_dump(config))
    assert planned_rules(workdir, workdir / "config.yaml") == {"whatif", "all"}
    snakemake(workdir, config=workdir / "config.yaml")
    result = _cli(
        workdir / "settings.csv", "--models", workdir / "results/models", "-o", tmp_path / "cli.csv", cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert (workdir / "results/predictions/whatif.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()


def test_monitor_key_adds_its_rule_and_a_report_page_and_its_table_is_the_commands(run_dir, tmp_path):
    workdir = tmp_path / "monitor"
    shutil.copytree(run_dir, workdir, symlinks=True)
    batch = pd.read_csv(run_dir / "results/demo/production.csv").iloc[-300:]
    batch.to_csv(workdir / "batch.csv", index=False)
    config = yaml.safe_load(open(TEST_CONFIG))
    config["monitor"] = "batch.csv"
    (workdir / "config.yaml").write_text(yaml.safe_dump(config))
    assert planned_rules(workdir, workdir / "config.yaml") == {"monitor", "report_pages", "all"}
    snakemake(workdir, config=workdir / "config.yaml")
    assert (workdir / "results/report/monitor.html").exists() and (workdir / "results/figures/monitor.png").exists()
    command = [sys.executable, "-m", "hybridtwin.cli", "monitor", str(workdir / "batch.csv")]
    command += ["--models", str(workdir / "results/models")]
    result = run_command([*command, "-o", str(tmp_path / "cli.csv")], timeout=120, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert (workdir / "results/monitor/monitor.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert (workdir / "results/monitor/monitor.md").read_text() == (tmp_path / "monitor.md").read_text()
    log_rows = len(pd.read_csv(run_dir / "results/demo/production.csv"))  # the test plant's log: a short one
    assert f"a log of {log_rows:,} parts" in (tmp_path / "monitor.md").read_text()


def test_results_dir_puts_everything_a_run_writes_under_it(tmp_path):
    config = yaml.safe_load(open(TEST_CONFIG))
    config["results_dir"] = "runs/plant_a"
    config["data"] = {role: path.replace("results/", "runs/plant_a/") for role, path in config["data"].items()}
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    summary = snakemake(tmp_path, "--summary", config=path).stdout.splitlines()
    outputs = [line.split("\t")[0] for line in summary if "\t" in line and not line.startswith("output_file")]
    assert len(outputs) > 40 and all(name.startswith("runs/plant_a/") for name in outputs), outputs


def test_appending_production_reruns_neither_the_surrogate_nor_the_doe_check(run_dir, tmp_path):
    workdir = tmp_path / "append"
    shutil.copytree(run_dir, workdir, symlinks=True)
    production = workdir / "results/demo/production.csv"
    lines = production.read_text().splitlines(keepends=True)
    production.write_text("".join(lines + lines[-50:]))  # a week's parts, as a plant appends them
    dry = snakemake(workdir, "-n", config=TEST_CONFIG).stdout
    planned = set(re.findall(r"^(?:local)?rule (\w+):", dry, re.M))
    assert {"validate_inputs", "residuals", "tune_residual", "prediction_intervals"} <= planned
    assert not {"surrogate_fit", "surrogate_cv", "demo_data"} & planned, planned
    assert "output: results/data/doe.parquet" not in dry and "output: results/data/production.parquet" in dry


def test_the_peers_files_are_read_only_for_the_rows_that_need_them(run_dir, tmp_path):
    from hybridtwin import Predictor

    settings = pd.read_csv(run_dir / "results/demo/production.csv").iloc[:2000]
    full = Predictor.load(run_dir / "results/models").predict(settings)
    models = tmp_path / "models"
    shutil.copytree(run_dir / "results/models", models)
    for peer in models.glob("peer_*.json"):
        peer.write_text("not JSON")
    peers = ["gp_discrepancy", "cokriging", "stack"]
    without = settings[~full["recommended_model"].isin(peers).to_numpy()]
    assert len(without) > 0  # the test needs rows that no peer answers
    light = Predictor.load(models)  # the broken files are not read until a row needs them
    pd.testing.assert_frame_equal(
        light.predict(without).reset_index(drop=True),
        full[~full["recommended_model"].isin(peers)].reset_index(drop=True),
    )
    new, out = tmp_path / "new.csv", tmp_path / "out.csv"
    without.to_csv(new, index=False)
    command = ["hybridtwin", "predict", str(new), "--models", str(models), "-o", str(out)]
    assert subprocess.run(command, capture_output=True).returncode == 0
    assert subprocess.run([*command, "--all-models"], capture_output=True).returncode != 0  # now they are read


def test_the_harness_runs_the_workflows_own_steps_to_the_same_numbers(run_dir):
    """One pipeline: the scenario harness calls the steps the rule scripts call, and gets the same numbers on the
    same plant as the workflow did from its files."""
    from hybridtwin import diagnosis
    from hybridtwin.demo.harness import Run

    results = run_dir / "results"
    config = yaml.safe_load(open(TEST_CONFIG))
    params = files.read_json(results / "tuning/best_params.json")["params"]
    doe, production = (files.read_checked(results / f"data/{role}.parquet") for role in ("doe", "production"))
    run = Run.of_workflow(config, doe, production, params)

    def same(ours: pd.DataFrame, path: Path):
        theirs = files.read_checked(path)
        for column in ours.columns:
            np.testing.assert_allclose(ours[column].to_numpy(float), theirs[column].to_numpy(float), rtol=1e-6)

    same(run.support.table, results / "support/production_support.parquet")
    same(run.residuals, results / "residuals/production_residuals.parquet")
    same(run.residual_cv.oof, results / "residuals/oof_filtered.parquet")
    settings = diagnosis.Settings.from_config(
        {k: v for k, v in run.config["diagnosis"].items() if k != "n_figures"}, 3, 7, "mm", 2
    )
    causes = run.diagnose(settings)
    written = pd.read_csv(results / "tables/discrepancy_causes.csv")
    assert causes.table["cause"].tolist() == written["cause"].tolist()
    np.testing.assert_allclose(causes.table["explained_share"], written["explained_share"], rtol=1e-6)
    extension = run.extension(causes.terms).production
    same(extension, results / "predictions/extension.parquet")
