"""A real SLURM run: the demo workflow through profiles/slurm on a one-node SLURM cluster on this machine.

    sudo python benchmarks/slurm_local.py        # as root, on Debian 12, in the project's Python; a few minutes

1. Installs Debian's ``slurm-wlm`` and ``munge`` (no daemon is started by the install) and the pinned
   executor plugin (``requirements-slurm.txt``).
2. Starts a cluster of one node, this machine: ``munged``, ``slurmctld`` and ``slurmd``, with their state,
   logs and sockets in a temporary folder, and a ``/etc/slurm/slurm.conf`` written here and deleted at the
   end (the job steps' ``srun`` reads SLURM's config from there: the pinned jobstep plugin drops
   ``SLURM_CONF`` from a job's environment). The node is declared with the CPUs and memory ``slurmd -C``
   finds, in one partition named ``compute``, the name the shipped profile uses.
3. Runs the demo workflow with ``tuning.workers: 2`` through ``profiles/slurm``, changed only where this
   cluster needs it (the log lists each change): no account, no job asking for more CPUs or memory than
   the node has, the two tuning workers at once, status by ``squeue`` every few seconds.
4. Checks the SLURM run: every job ran as a SLURM job and completed, the two tuning jobs ran at the same
   time on one study, each ran trials, and no trial was lost.
5. Runs the same workflow locally (``--cores``, the same threads per job) on the SLURM run's tuning study,
   and checks that every table (every CSV and Parquet file under ``results/``) is byte-identical to the
   SLURM run's. Two workers running at once make the trials the study tries depend on which trial ends
   first, so a fresh study would differ (docs/cluster.md); everything else must be equal.
6. Stops the cluster, also on a failure or Ctrl-C, and checks that none of its processes is left.

The runs are in ``runs/slurm_local/`` (``slurm/`` and ``local/``, each with its Snakemake log); this
script's log goes to ``benchmarks/results/slurm_local.log``. It refuses to start where SLURM or munge
daemons already run, or where /etc/slurm/slurm.conf exists.
"""

from __future__ import annotations

import argparse
import datetime
import filecmp
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ["slurm-wlm", "munge"]
PINS = ROOT / "requirements-slurm.txt"
PROFILE = ROOT / "profiles/slurm/config.yaml"
WORKERS = 2
DAEMONS = ("munged", "slurmctld", "slurmd", "slurmstepd")
POLICY = Path("/usr/sbin/policy-rc.d")
# where SLURM's commands look for their config when SLURM_CONF is not set: a job's srun does
CONF = Path("/etc/slurm/slurm.conf")


class Log:
    """Lines with the time since the start, to the screen and to the log file."""

    def __init__(self, path: Path):
        self.path, self.start = path, time.monotonic()
        path.parent.mkdir(parents=True, exist_ok=True)
        self.handle = path.open("w")

    def __call__(self, text: str = "") -> None:
        stamp = f"[{time.monotonic() - self.start:7.1f} s] "
        for line in str(text).splitlines() or [""]:
            print(stamp + line, flush=True)
            self.handle.write(stamp + line + "\n")
        self.handle.flush()


def run(log: Log, command: list, check: bool = True, quiet: bool = False, **kwargs) -> subprocess.CompletedProcess:
    log("$ " + " ".join(str(part) for part in command))
    result = subprocess.run([str(part) for part in command], capture_output=True, text=True, **kwargs)
    if not quiet or result.returncode:
        log((result.stdout + result.stderr).rstrip()[-3000:])
    if check and result.returncode:
        raise RuntimeError(f"{command[0]} failed with exit code {result.returncode}")
    return result


def running(names=DAEMONS) -> dict[int, str]:
    """Processes by their name (pid -> name), read from /proc."""
    found = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                name = (entry / "comm").read_text().strip()
            except OSError:
                continue  # ended meanwhile
            if name in names:
                found[int(entry.name)] = name
    return found


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def require(condition, failure: str) -> None:
    if not condition:
        raise RuntimeError(failure)


def wait_for(condition, seconds: float, every: float = 1.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(every)
    return condition()


# 1. install


def installed(package: str) -> bool:
    result = subprocess.run(["dpkg-query", "-W", "-f=${Status}", package], capture_output=True, text=True)
    return result.stdout.strip() == "install ok installed"


def install(log: Log) -> None:
    missing = [package for package in PACKAGES if not installed(package)]
    log(f"Debian packages {', '.join(PACKAGES)}: " + (f"installing {', '.join(missing)}" if missing else "installed"))
    if missing:
        # the packages' scripts would start munge and slurmctld (slurmctld, with no config, fails): a policy
        # that forbids any start, for the install only (a machine's own policy-rc.d is left as it is)
        ours = not POLICY.exists()
        if ours:
            POLICY.write_text(
                "#!/bin/sh\n# benchmarks/slurm_local.py, during its apt-get install: start no daemon\nexit 101\n"
            )
            POLICY.chmod(0o755)
        try:
            environment = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
            run(log, ["apt-get", "update"], quiet=True, env=environment)
            run(log, ["apt-get", "install", "-y", "--no-install-recommends", *PACKAGES], quiet=True, env=environment)
        finally:
            if ours:
                POLICY.unlink()
    for package in ("slurmctld", "slurmd", "munge"):
        version = subprocess.run(["dpkg-query", "-W", "-f=${Version}", package], capture_output=True, text=True)
        log(f"  {package} {version.stdout}")
    run(log, [sys.executable, "-m", "pip", "install", "-q", "-r", PINS])
    pins = [line.split("#")[0].strip() for line in PINS.read_text().splitlines()]
    log("  pinned: " + ", ".join(pin for pin in pins if pin))


# 2. the cluster


def node() -> dict[str, str]:
    """This machine as ``slurmd -C`` sees it: NodeName, CPUs, ..., RealMemory."""
    first = subprocess.run(["slurmd", "-C"], capture_output=True, text=True, check=True).stdout.splitlines()[0]
    return dict(part.split("=", 1) for part in first.split())


def slurm_conf(folder: Path, machine: dict[str, str]) -> str:
    described = " ".join(f"{key}={value}" for key, value in machine.items() if key != "NodeName")
    return f"""# one node, this machine: written by benchmarks/slurm_local.py
ClusterName=hybridtwin
SlurmctldHost={machine["NodeName"]}(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={folder}/munge/munge.socket
StateSaveLocation={folder}/state
SlurmdSpoolDir={folder}/spool
SlurmctldPidFile={folder}/slurmctld.pid
SlurmdPidFile={folder}/slurmd.pid
SlurmctldLogFile={folder}/log/slurmctld.log
SlurmdLogFile={folder}/log/slurmd.log
# no cgroups, no accounting database: a plain machine
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
# CPUs and memory are both consumed by jobs, as on a real cluster
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
# finished jobs stay visible to squeue for an hour: the checks read them
MinJobAge=3600
NodeName={machine["NodeName"]} NodeAddr=127.0.0.1 {described} State=UNKNOWN
PartitionName=compute Nodes=ALL Default=YES MaxTime=INFINITE State=UP
"""


class Cluster:
    """munged, slurmctld and slurmd from a config in ``folder``; stop() ends them, and any job left."""

    def __init__(self, folder: Path, log: Log):
        self.folder, self.log = folder, log
        self.conf, self.wrote_conf = CONF, False
        self.env = {key: value for key, value in os.environ.items() if key != "SLURM_CONF"}

    def start(self, machine: dict[str, str]) -> None:
        for sub in ("state", "spool", "log"):
            (self.folder / sub).mkdir(parents=True)
        munge = self.folder / "munge"
        munge.mkdir(mode=0o711)
        munge.chmod(0o711)  # munged's socket folder: its own, searchable by all
        shutil.chown(munge, "munge", "munge")
        self.conf.parent.mkdir(parents=True, exist_ok=True)
        self.wrote_conf = True
        self.conf.write_text(slurm_conf(self.folder, machine))
        self.log(f"slurm.conf ({self.conf}):")
        self.log(self.conf.read_text())
        run(
            self.log,
            ["runuser", "-u", "munge", "--", "munged", f"--socket={munge}/munge.socket",
             f"--pid-file={munge}/munged.pid", f"--log-file={munge}/munged.log", f"--seed-file={munge}/munged.seed"],
        )  # fmt: skip
        run(self.log, ["slurmctld"], env=self.env)
        run(self.log, ["slurmd"], env=self.env)
        if not wait_for(lambda: self.node_state() == "idle", 60):
            raise RuntimeError(f"the node is not idle after 60 s: {self.node_state()!r}")
        run(self.log, ["sinfo", "-N", "-l"], env=self.env)

    def node_state(self) -> str:
        result = subprocess.run(["sinfo", "-h", "-N", "-o", "%T"], capture_output=True, text=True, env=self.env)
        return result.stdout.strip()

    def jobs(self) -> list[dict[str, str]]:
        """Every job the controller knows, finished ones included (MinJobAge)."""
        fields = {"id": "%i", "rule": "%k", "state": "%T", "start": "%S", "end": "%e", "cpus": "%C", "memory": "%m"}
        result = subprocess.run(
            ["squeue", "-h", "--states=all", "-o", "|".join(fields.values())],
            capture_output=True,
            text=True,
            env=self.env,
            check=True,
        )
        return [dict(zip(fields, line.split("|"))) for line in result.stdout.splitlines() if line.strip()]

    def pid(self, name: str) -> int | None:
        path = self.folder / ("munge/munged.pid" if name == "munged" else f"{name}.pid")
        try:
            return int(path.read_text().strip())
        except (OSError, ValueError):
            return None

    def stop(self) -> None:
        """Cancel any job, shut the controller and the node down, end munged; each by its own process id."""
        log = self.log
        if self.pid("slurmctld") and alive(self.pid("slurmctld")):
            active = [job["id"] for job in self.jobs() if job["state"] in ("PENDING", "RUNNING", "COMPLETING")]
            if active:
                run(log, ["scancel", *active], check=False, env=self.env)
                wait_for(lambda: not any(job["state"] in ("RUNNING", "COMPLETING") for job in self.jobs()), 60)
            run(log, ["scontrol", "shutdown"], check=False, env=self.env)
        for name in ("slurmd", "slurmctld", "munged"):
            pid = self.pid(name)
            if pid is None or not alive(pid):
                continue
            if name == "munged":
                os.kill(pid, signal.SIGTERM)
            if not wait_for(lambda: not alive(pid), 30, 0.2):
                log(f"{name} (pid {pid}) still running after 30 s: killed")
                os.kill(pid, signal.SIGKILL)
        # a job step whose slurmd is gone (none ran before this script started: it refuses otherwise)
        for pid, name in running(("slurmstepd",)).items():
            log(f"{name} (pid {pid}) left: killed")
            os.kill(pid, signal.SIGKILL)
        if self.wrote_conf:
            shutil.copy(self.conf, self.folder / "log/slurm.conf")  # for the record
            self.conf.unlink()
            log(f"deleted {self.conf}")


# 3. the runs


def cluster_profile(machine: dict[str, str], status_seconds: int, log: Log) -> tuple[dict, dict[str, int]]:
    """profiles/slurm as this one-node cluster needs it, and the threads per rule it sets."""
    profile = yaml.safe_load(PROFILE.read_text())
    cpus, memory = int(machine["CPUs"]), int(machine["RealMemory"])
    changes = []
    defaults = profile["default-resources"]
    if defaults.pop("slurm_account", None):
        changes.append("default-resources: no slurm_account (no accounting database; the plugin checks accounts)")
    if defaults["slurm_partition"] != "compute":
        changes.append(f"default-resources: slurm_partition {defaults['slurm_partition']} -> compute")
        defaults["slurm_partition"] = "compute"
    threads = dict(profile.get("set-threads", {}))
    threads.setdefault("tune_worker", cpus)
    for rule, asked in sorted(threads.items()):
        # the tuning workers side by side on the node; no job asking for more CPUs than the node has
        fits = max(1, cpus // WORKERS) if rule == "tune_worker" else min(asked, cpus)
        if fits != asked:
            changes.append(f"set-threads: {rule} {asked} -> {fits}")
            threads[rule] = fits
    profile["set-threads"] = threads
    if defaults["mem_mb"] > memory:
        changes.append(f"default-resources: mem_mb {defaults['mem_mb']} -> {memory}")
        defaults["mem_mb"] = memory
    for rule, resources in profile.get("set-resources", {}).items():
        fits = memory // WORKERS if rule == "tune_worker" else memory
        if resources.get("mem_mb", 0) > fits:
            changes.append(f"set-resources: {rule} mem_mb {resources['mem_mb']} -> {fits}")
            resources["mem_mb"] = fits
    added = {
        # sacct needs the accounting database; squeue reads the controller (MinJobAge keeps finished jobs)
        "slurm-status-command": "squeue",
        # the default, 40 s, suits a busy controller; here the workflow's ~35 short jobs in a chain would wait
        "slurm-init-seconds-before-status-checks": status_seconds,
        "slurm-keep-successful-logs": True,
    }
    for key, value in added.items():
        changes.append(f"{key}: {value}")
    profile.update(added)
    log(f"profiles/slurm, changed for this node ({cpus} CPUs, {memory} MB):")
    for change in changes:
        log(f"  {change}")
    return profile, threads


def snakemake(log: Log, folder: Path, args: list, configs: list[Path], timeout: float, name="snakemake") -> float:
    """Run the workflow in ``folder``; its wall time (s). Its output goes to ``folder``/``name``.log."""
    folder.mkdir(parents=True, exist_ok=True)
    command = [
        sys.executable, "-m", "snakemake", *args, "-s", ROOT / "Snakefile", "-d", folder,
        "--configfile", *configs,
    ]  # fmt: skip
    log("$ " + " ".join(str(part) for part in command))
    log(f"  load average before: {load()} (other work on the machine slows the steps)")
    start = time.monotonic()
    with (folder / f"{name}.log").open("w") as output:
        process = subprocess.Popen([str(part) for part in command], stdout=output, stderr=subprocess.STDOUT)
        try:
            code = process.wait(timeout=timeout)
        finally:
            if process.poll() is None:  # a timeout, a failure or Ctrl-C here: Snakemake cancels its SLURM jobs
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=60)
                except subprocess.TimeoutExpired:
                    process.kill()
    seconds = time.monotonic() - start
    if code:
        log((folder / f"{name}.log").read_text()[-4000:])
        raise RuntimeError(f"the workflow failed (exit code {code}) after {seconds:.0f} s: {folder}/{name}.log")
    log(f"  done in {seconds:.0f} s; load average: {load()}")
    return seconds


def load() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


# 4. and 5. the checks


def check_slurm_run(log: Log, cluster: Cluster, logs: list[Path]) -> None:
    submitted, planned = [], 0
    for path in logs:
        text = path.read_text()
        submitted += re.findall(r"has been submitted with SLURM jobid (\d+)", text)
        # the plan's job counts (its first table); rule all runs nothing
        counts = dict(re.findall(r"^(\w+)\s+(\d+)$", text.split("Job stats:")[1].split("\n\n")[0], re.MULTILINE))
        planned += int(counts["total"]) - int(counts.get("all", 0))
    jobs = {job["id"]: job for job in cluster.jobs()}
    log(f"SLURM jobs: {len(jobs)}; submitted by Snakemake: {len(submitted)}; planned (rule all aside): {planned}")
    log("  id | rule | state | start | end | cpus | memory")
    for job in sorted(jobs.values(), key=lambda job: int(job["id"])):
        log("  " + " | ".join(job.values()))
    require(len(submitted) == planned, "not every planned job was submitted to SLURM")
    require(set(submitted) == set(jobs), "the jobs Snakemake submitted are not the jobs SLURM ran")
    require(all(job["state"] == "COMPLETED" for job in jobs.values()), "a SLURM job did not complete")
    workers = sorted(
        (job for job in jobs.values() if job["rule"].startswith("rule_tune_worker")), key=lambda j: j["id"]
    )
    require(len(workers) == WORKERS, f"{len(workers)} tune_worker jobs, not {WORKERS}")
    starts, ends = ([datetime.datetime.fromisoformat(job[key]) for job in workers] for key in ("start", "end"))
    overlap = (min(ends) - max(starts)).total_seconds()
    log(f"the {WORKERS} tuning jobs ran side by side for {overlap:.0f} s")
    require(overlap > 0, "the tuning jobs did not run at the same time")
    check_study(log, logs[0].parent / "results")


def check_study(log: Log, results: Path) -> None:
    """Each worker ran trials of the one study, and every finished trial is one a worker ran."""
    sys.path.insert(0, str(ROOT))
    from hybridtwin.io import files
    from hybridtwin.paper import tuning

    names = {files.read_json(path)["study"] for path in sorted((results / "tuning").glob("worker_*.json"))}
    require(len(names) == 1, f"the workers ran {len(names)} studies")
    study = tuning.optuna.load_study(
        study_name=names.pop(), storage=tuning.open_storage(str(results / "optuna/journal.log"))
    )
    finished = {trial.number for trial in study.get_trials(deepcopy=False, states=tuning.FINISHED)}
    n_trials = yaml.safe_load((ROOT / "config/config.yaml").read_text())["tuning"]["n_trials"]
    ran = {}
    for worker in range(WORKERS):
        lines = (results / f"logs/tune_worker_{worker}.log").read_text()
        ran[worker] = {int(number) for number in re.findall(r"tuning: trial (\d+) finished", lines)}
        log(f"tuning worker {worker} ran trials {sorted(ran[worker])}")
    log(f"the study holds {len(finished)} finished trials of {len(study.trials)} (tuning.n_trials: {n_trials})")
    require(all(ran.values()), "a tuning worker ran no trial")
    require(not set.intersection(*ran.values()), "two workers ran the same trial")
    require(set.union(*ran.values()) == finished, "the study's finished trials are not the ones the workers ran")
    require(len(finished) >= n_trials, "the study holds fewer trials than asked")


def step_times(log: Log, cluster: Cluster, work: Path) -> None:
    """Per step: the SLURM job's time (start to end, Snakemake's start-up in the job included), and the step's
    own wall and CPU time in both runs (its Snakemake benchmark file)."""

    def benchmark(run: str, step: str) -> tuple[float, float]:
        path = work / run / "results/benchmarks" / f"{step}.tsv"
        if not path.exists():
            return float("nan"), float("nan")
        row = dict(zip(*(line.split("\t") for line in path.read_text().splitlines()[:2])))
        return float(row["s"]), float(row["cpu_time"])

    log("per step [s]: SLURM job | step wall, CPU in the SLURM run | step wall, CPU in the local run")
    for job in sorted(cluster.jobs(), key=lambda job: int(job["id"])):
        step = re.sub(r"^rule_|_wildcards", "", job["rule"])
        seconds = (datetime.datetime.fromisoformat(job["end"]) - datetime.datetime.fromisoformat(job["start"])).seconds
        (slurm_wall, slurm_cpu), (local_wall, local_cpu) = benchmark("slurm", step), benchmark("local", step)
        log(f"  {step:32s} {seconds:5d} | {slurm_wall:6.1f} {slurm_cpu:6.1f} | {local_wall:6.1f} {local_cpu:6.1f}")


def compare_tables(log: Log, ours: Path, theirs: Path) -> None:
    def tables_in(folder: Path) -> set[Path]:
        return {path.relative_to(folder) for kind in ("*.csv", "*.parquet") for path in folder.rglob(kind)}

    tables, others = tables_in(ours), tables_in(theirs)
    differ = sorted(str(path) for path in tables & others if not filecmp.cmp(ours / path, theirs / path, shallow=False))
    log(f"tables (CSV and Parquet under results/): {len(tables)} in the SLURM run, {len(others)} in the local run")
    for path in sorted(tables ^ others):
        log(f"  only in one run: {path}")
    for path in differ:
        log(f"  differs: {path}")
    require(tables == others and not differ, "the SLURM run's tables are not the local run's")
    log(f"  all {len(tables)} byte-identical")


# the whole


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=ROOT / "runs/slurm_local", help="the runs' folder (emptied)")
    parser.add_argument("--log", type=Path, default=ROOT / "benchmarks/results/slurm_local.log")
    parser.add_argument("--status-seconds", type=int, default=5, help="seconds between SLURM status checks")
    parser.add_argument("--timeout", type=float, default=3600, help="seconds each workflow run may take")
    args = parser.parse_args()
    if os.geteuid() != 0:
        sys.exit("run as root: it installs packages and starts SLURM's daemons")
    if not Path("/etc/debian_version").exists():
        sys.exit("made for Debian (apt-get, the slurm-wlm and munge packages)")
    if running():
        sys.exit(f"SLURM or munge already runs here ({running()}): this script starts and stops its own")
    if CONF.exists():
        sys.exit(f"{CONF} exists: this machine has a SLURM config of its own, which this script would replace")
    log = Log(args.log)
    # the cluster's cleanup runs on Ctrl-C and on a kill (SIGTERM, SIGHUP) too
    for signum in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, interrupted)
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain"], capture_output=True, text=True).stdout.strip()
    log(f"benchmarks/slurm_local.py on commit {commit.stdout.strip()}{' (with uncommitted changes)' if dirty else ''}")
    log(f"{socket.gethostname()}, Debian {Path('/etc/debian_version').read_text().strip()}, {datetime.date.today()}")
    if args.work.exists():
        shutil.rmtree(args.work)
    args.work.mkdir(parents=True)
    cluster, passed = None, False
    folder = Path(tempfile.mkdtemp(prefix="slurm_local-"))
    folder.chmod(0o755)
    try:
        install(log)
        machine = node()
        cluster = Cluster(folder, log)
        cluster.start(machine)
        profile, threads = cluster_profile(machine, args.status_seconds, log)
        (args.work / "profile").mkdir()
        (args.work / "profile/config.yaml").write_text(yaml.safe_dump(profile, sort_keys=False))
        run_config = args.work / "run.yaml"
        run_config.write_text(yaml.safe_dump({"results_dir": "results", "tuning": {"workers": WORKERS}}))
        configs = [ROOT / "config/config.yaml", run_config]
        os.environ.pop("SLURM_CONF", None)  # the jobs read /etc/slurm/slurm.conf; so does everything here
        # the jobs import this checkout's package (sbatch passes the environment on)
        os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
        log(f"SLURM run: the demo workflow, tuning.workers {WORKERS}, through the profile in {args.work}/profile")
        # first the steps up to the tuning: then both workers start together, as on a cluster with CPUs to spare
        # (on this small node, a worker beside another job would find the study done before the other one starts)
        slurm, profile_args = args.work / "slurm", ["--profile", args.work / "profile"]
        tuning = [*profile_args, "results/tuning/best_params.json"]
        slurm_seconds = snakemake(log, slurm, tuning, configs, args.timeout, name="snakemake_tuning")
        slurm_seconds += snakemake(log, slurm, profile_args, configs, args.timeout)
        check_slurm_run(log, cluster, [slurm / "snakemake_tuning.log", slurm / "snakemake.log"])
        # the local run tries the trials the SLURM run tried: it starts from a copy of that run's study
        journal = Path("results/optuna/journal.log")
        (args.work / "local" / journal).parent.mkdir(parents=True)
        shutil.copy(args.work / "slurm" / journal, args.work / "local" / journal)
        log("local run: the same workflow and threads per job, on a copy of the SLURM run's study")
        local_args = ["--cores", machine["CPUs"], "--set-threads", *(f"{rule}={n}" for rule, n in threads.items())]
        local_seconds = snakemake(log, args.work / "local", local_args, configs, args.timeout)
        step_times(log, cluster, args.work)
        compare_tables(log, args.work / "slurm/results", args.work / "local/results")
        log(f"wall time: SLURM run {slurm_seconds:.0f} s, local run {local_seconds:.0f} s (its tuning already done)")
        passed = True
    except (Exception, KeyboardInterrupt) as error:
        log(f"FAILED: {type(error).__name__}: {error}")
    finally:
        if cluster is not None:
            log("stopping the cluster")
            cluster.stop()
            for name in ("slurmctld.log", "slurmd.log", "slurm.conf"):
                if (folder / "log" / name).exists():
                    shutil.copy(folder / "log" / name, args.work / name)
        left = running()
        left_jobs = [pid for pid in map(int, filter(str.isdigit, os.listdir("/proc"))) if leftover_job(pid, args.work)]
        log(f"left running: {left or 'no SLURM or munge daemon'}, {left_jobs or 'no job of the runs'}")
        shutil.rmtree(folder, ignore_errors=True)
        passed = passed and not left and not left_jobs
        log("PASSED" if passed else "FAILED")
    return 0 if passed else 1


def interrupted(signum, frame):
    raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")


def leftover_job(pid: int, work: Path) -> bool:
    """A process (not this one) running in one of the runs' folders."""
    if pid == os.getpid():
        return False
    try:
        return Path(f"/proc/{pid}/cwd").resolve().is_relative_to(work.resolve())
    except OSError:
        return False


if __name__ == "__main__":
    sys.exit(main())
