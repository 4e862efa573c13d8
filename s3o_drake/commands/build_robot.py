"""Build what a robot needs from its description: map, times, FCN, checks.

    s3o build robot NAME [--steps STEP ...] [--workers 2]

Runs, for the robot of models/NAME/ (its robot.yaml and model), each in a process of its
own, in order:

  model           s3o build model NAME                 -> models/NAME/generated/ (a robot
                                                          of parts, from its makers' files)
  reachability    s3o build reachability --robot NAME  -> models/NAME/reachability_map.npz
  fcn-data        s3o build fcn-data --robot NAME      -> out/NAME/fcn_data, .../fcn_data_dense
  fcn             s3o build fcn                        -> models/NAME/fcn/
  time-model      s3o build time-model --robot NAME    -> models/NAME/time_model.yaml
  oracle-pinning  s3o bench oracle-pinning --robot NAME -> models/NAME/oracle_pinning.json

and records each finished step in models/NAME/build.json: its command, the checksums of
what it read and wrote, its time (wall and CPU seconds, summed over the runs it took). Run
again, it resumes: a step whose command (whatever its --workers), inputs and outputs are as
recorded is skipped (the data step also keeps the scenes it has), and a step cut off
counts its time on from out/NAME/build_time.json, written every minute. Each step reads
what the ones before it wrote where the robot's files are (models/NAME/), so the build
replaces them as it goes.
"""

import contextlib
import datetime
import fcntl
import hashlib
import json
import re
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import yaml

# Light imports only: each step runs in its own process.
from s3o_drake.commands.common import (
    add_robot_name,
    command_parser,
    fail,
    read_robot_description,
)
from s3o_drake.commands.options import add_workers
from s3o_drake.world.files import write_atomically
from s3o_drake.world.resources import (
    DESCRIPTION_FILE,
    MODELS_DIR,
    REPO_DIR,
    RESTAURANT_DENSE,
    repo_path,
    robot_dir,
)

MANIFEST = "build.json"
"""The record of a robot's build, in its folder (or the quick build's)."""
TIME_SO_FAR = "build_time.json"
"""The time of the steps not finished yet, in out/NAME/: a step cut off (the machine shut
down, the build killed) counts on from it when it runs again with the same command."""
CHECKPOINT = 60.0
"""How often (s) a running step's time so far is written down."""
DATA_SEED = 1000
"""The training scenes' generator seed (the benchmark tasks use 0)."""


@dataclass(frozen=True)
class Step:
    name: str
    argv: tuple[str, ...]
    """The `s3o` arguments."""
    reads: tuple[Path, ...]
    """Files and folders whose contents decide whether the step must run again."""
    writes: tuple[Path, ...]


#: The training scenes per layout, the epochs, the pinning check's tasks: the UR5e's.
DATA_SCENES = 143
EPOCHS = 60
PINNING_TASKS = 5


def plan_steps(name: str, *, workers: int) -> list[Step]:
    """The build's steps for robot `name`: into its folder, and the training data (which
    does not ship) into out/NAME/."""
    folder = robot_dir(name)
    generated = folder / "generated"
    sources = (folder / "robot.yaml", *sorted(folder.glob("*.xacro")), MODELS_DIR / "parts")
    model = (folder / "robot.yaml", *sorted(folder.glob("*.urdf")),
             *((generated,) if any(folder.glob("*.xacro")) else ()))
    data = REPO_DIR / "out" / name
    spacious, dense = data / "fcn_data", data / "fcn_data_dense"
    reach_map, times = folder / "reachability_map.npz", folder / "time_model.yaml"
    fcn, pinning = folder / "fcn", folder / "oracle_pinning.json"
    w = str(workers)
    robot = ("--robot", name)
    scenes = ("--seed", str(DATA_SEED), "--count", str(DATA_SCENES), "--workers", w, "--quiet",
              *robot)
    # A robot of parts built from its makers' files first builds them (`s3o build model`).
    built = ([Step("model", ("build", "model", name), sources, (generated,))]
             if any(folder.glob("*.xacro")) else [])
    return [
        *built,
        Step("reachability", ("build", "reachability", *robot, "--out", str(reach_map),
                              "--workers", w, "--quiet"), model, (reach_map,)),
        Step("fcn-data", ("build", "fcn-data", "--out", str(spacious), *scenes),
             (*model, reach_map), (spacious,)),
        Step("fcn-data-dense", ("build", "fcn-data", "--base", str(RESTAURANT_DENSE), "--out",
                                str(dense), *scenes), (*model, reach_map), (dense,)),
        Step("fcn", ("build", "fcn", "--data", str(spacious), str(dense), "--out", str(fcn),
                     "--seed", "0", "--epochs", str(EPOCHS), "--quiet"), (spacious, dense),
             (fcn,)),
        # The time model's measured runs plan as the robot plans, with its network.
        Step("time-model", ("build", "time-model", *robot, "--out", str(times), "--seed", "0",
                            "--workers", w), (*model, reach_map, fcn), (times,)),
        Step("oracle-pinning", ("bench", "oracle-pinning", *robot, "--json", str(pinning),
                                "--count", str(PINNING_TASKS)), (*model, reach_map),
             (pinning,)),
    ]


STEP_NAMES = ("model", "reachability", "fcn-data", "fcn", "time-model", "oracle-pinning")
"""What --steps names; fcn-data makes both layouts' scenes."""


def checksum(path: Path) -> str:
    """SHA-256 of a file, or of a folder's files (their paths and bytes); "" if missing. A
    robot's description counts by its content without its `missing` field: its comments
    and what it says the robot still lacks are not what a step reads (emptying `missing`
    at the end of a build would otherwise make every step's record stale)."""
    path = Path(path)
    if path.is_file() and path.name == DESCRIPTION_FILE:
        content = yaml.safe_load(path.read_text()) or {}
        content.pop("missing", None)
        return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()
    if path.is_file():
        return hashlib.sha256(path.read_bytes()).hexdigest()
    if not path.is_dir():
        return ""
    digest = hashlib.sha256()
    for file in sorted(p for p in path.rglob("*") if p.is_file()):
        digest.update(file.relative_to(path).as_posix().encode())
        digest.update(file.read_bytes())
    return digest.hexdigest()


@dataclass(frozen=True)
class StepTime:
    """What a step has taken so far, over the runs it took: wall seconds, the CPU seconds
    of its processes (the step's and every process it started), and how many runs."""

    seconds: float = 0.0
    cpu_seconds: float = 0.0
    runs: int = 0


def _command(step: Step) -> str:
    """The step's command as recorded: its paths from the repository's root."""
    return "s3o " + " ".join(repo_path(a) if "/" in a else a for a in step.argv)


def _record(step: Step, spent: StepTime | None = None) -> dict:
    record = {"command": _command(step),
              "reads": {repo_path(p): checksum(p) for p in step.reads},
              "writes": {repo_path(p): checksum(p) for p in step.writes}}
    if spent is not None:
        record["seconds"] = round(spent.seconds, 1)
        record["cpu_seconds"] = round(spent.cpu_seconds, 1)
        record["runs"] = spent.runs
        record["finished"] = datetime.datetime.now().isoformat(timespec="seconds")
    return record


def what_it_makes(command: str) -> str:
    """A recorded command without its `--workers N`: how many processes made a step's
    outputs says how fast, not what (a build resumed on fewer workers would otherwise make
    its finished steps again, the map's among them)."""
    return re.sub(r" --workers \d+", "", command)


def is_done(step: Step, manifest: dict) -> bool:
    """Whether the manifest records `step` with this command (whatever its workers), these
    inputs and outputs."""
    done = manifest.get("steps", {}).get(step.name)
    if done is None:
        return False
    now = _record(step)
    return (what_it_makes(done.get("command", "")) == what_it_makes(now["command"])
            and all(done.get(k) == now[k] for k in ("reads", "writes"))
            and all(now["writes"].values()))


def run_step(step: Step, *, so_far: StepTime,
             checkpoint: Callable[[StepTime], None]) -> StepTime:
    """Runs one step (its arguments name the robot) and returns its time, `so_far` and this
    run's; hands `checkpoint` the time so far every CHECKPOINT seconds. A failed step is
    one line and exit status 2."""
    import psutil

    start, cpu_before = time.perf_counter(), _children_cpu()
    process = subprocess.Popen([sys.executable, "-m", "s3o_drake.commands", *step.argv],
                               cwd=REPO_DIR)
    cpu = 0.0
    while True:
        try:
            status = process.wait(timeout=CHECKPOINT)
            break
        except subprocess.TimeoutExpired:
            with contextlib.suppress(psutil.Error):
                cpu = max(cpu, _tree_cpu(psutil.Process(process.pid)))
            checkpoint(_plus(so_far, time.perf_counter() - start, cpu))
    # Every process the step started has been waited for by now: the children's count.
    cpu = max(cpu, _children_cpu() - cpu_before)
    spent = _plus(so_far, time.perf_counter() - start, cpu)
    if status != 0:
        checkpoint(spent)
        fail(f"step {step.name} failed (exit status {status}): s3o {' '.join(step.argv)}")
    return spent


def _plus(so_far: StepTime, seconds: float, cpu_seconds: float) -> StepTime:
    """`so_far` and one more run, of these seconds (a run counts from its start)."""
    return StepTime(so_far.seconds + seconds, so_far.cpu_seconds + cpu_seconds,
                    so_far.runs + 1)


def _children_cpu() -> float:
    """CPU seconds of this process's children that have ended and been waited for."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _tree_cpu(process) -> float:
    """CPU seconds of a running process and its descendants, those living and those they
    waited for (`psutil.Process`)."""
    import psutil

    total = 0.0
    for p in (process, *process.children(recursive=True)):
        with contextlib.suppress(psutil.Error):
            t = p.cpu_times()
            total += t.user + t.system + t.children_user + t.children_system
    return total


def _time_so_far(path: Path, step: Step) -> StepTime:
    """The recorded time of `step` cut off before with this command, else none."""
    try:
        entry = json.loads(path.read_text())[step.name]
        if what_it_makes(entry["command"]) == what_it_makes(_command(step)):
            return StepTime(**{k: entry[k] for k in asdict(StepTime())})
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return StepTime()


def _keep_time(path: Path, step: Step, spent: StepTime | None) -> None:
    """Writes `step`'s time so far into `path`, or with None drops it (the step is done)."""
    try:
        entries = json.loads(path.read_text())
    except (OSError, ValueError):
        entries = {}
    entries.pop(step.name, None)
    if spent is not None:
        entries[step.name] = {"command": _command(step), **asdict(spent)}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(path, json.dumps(entries, indent=1) + "\n")


@contextlib.contextmanager
def only_build(name: str):
    """Holds the robot's build lock, or fails in one line: two builds of one robot at once
    would each replace files the other reads, and the last to write the record would drop
    the other's steps."""
    lock_path = REPO_DIR / "out" / name / ".build.lock"
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    with lock_path.open("w") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fail(f"{name}: another build of this robot is running; wait for it to end")
        yield


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("build robot", __doc__)
    add_robot_name(parser)
    parser.add_argument("--steps", nargs="+", choices=STEP_NAMES, metavar="STEP",
                        help=f"only these steps (default all: {', '.join(STEP_NAMES)})")
    add_workers(parser, 2)
    args = parser.parse_args(argv)
    from s3o_drake.world.robot_description import RobotDescriptionError, check_model

    description = read_robot_description(args.name)
    try:
        # A robot of parts built from its makers' files is checked once the model step has
        # built them (that step checks it).
        if not any(part.xacro for part in description.parts):
            check_model(description)
    except RobotDescriptionError as e:
        fail(f"{args.name}: {e}")
    with only_build(args.name):
        return _build(args)


def _build(args) -> int:
    manifest_path = robot_dir(args.name) / MANIFEST
    time_path = REPO_DIR / "out" / args.name / TIME_SO_FAR
    manifest = json.loads(manifest_path.read_text()) if manifest_path.is_file() else {}
    manifest.setdefault("robot", args.name)
    manifest.setdefault("steps", {})
    chosen = set(args.steps or STEP_NAMES)
    steps = [s for s in plan_steps(args.name, workers=args.workers)
             if s.name.removesuffix("-dense") in chosen]
    for i, step in enumerate(steps, 1):
        if is_done(step, manifest):
            print(f"[{i}/{len(steps)}] {step.name}: done, as recorded in "
                  f"{repo_path(manifest_path)}", flush=True)
            continue
        print(f"[{i}/{len(steps)}] {step.name}: s3o {' '.join(step.argv)}", flush=True)
        so_far = _time_so_far(time_path, step)
        if so_far.runs:
            print(f"[{i}/{len(steps)}] {step.name}: {so_far.seconds:.0f} s spent on it in "
                  f"{so_far.runs} run(s) before, counted on", flush=True)
        spent = run_step(step, so_far=so_far,
                         checkpoint=lambda t, step=step: _keep_time(time_path, step, t))
        manifest["steps"][step.name] = _record(step, spent)
        write_atomically(manifest_path, json.dumps(manifest, indent=1) + "\n")
        _keep_time(time_path, step, None)
        print(f"[{i}/{len(steps)}] {step.name}: {spent.seconds:.0f} s, {spent.cpu_seconds:.0f}"
              f" s of CPU", flush=True)
    print(f"{args.name}: every step done; the record is {repo_path(manifest_path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
