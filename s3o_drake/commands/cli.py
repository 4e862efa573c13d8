"""The `s3o` console script: every command of the project as one subcommand.

The subcommands are a table of names, module paths and one-line summaries: `s3o --help`
lists them without importing a command module (several import Drake, torch or matplotlib
at the top of their work), and `s3o NAME ...` imports only the module it runs. The table's
summaries are the modules' first docstring lines (tests/commands/test_cli.py holds them together).
"""

from __future__ import annotations

import importlib
import sys
from dataclasses import dataclass

from s3o_drake.commands.common import DOCS, EXIT_BAD_INPUT, PROG


@dataclass(frozen=True)
class Command:
    """A subcommand: what is typed after `s3o`, the module whose `main(argv)` runs it,
    and the module docstring's first line."""

    name: str
    module: str
    summary: str

    @property
    def prog(self) -> str:
        return f"{PROG} {self.name}"


def _c(name: str, module: str, summary: str) -> Command:
    return Command(name, f"s3o_drake.commands.{module}", summary)


COMMANDS: tuple[Command, ...] = (
    _c("run", "run_scenario",
       "Plan a scenario's task with S3O and execute it in a Drake simulation."),
    _c("generate", "generate", "Generate benchmark tasks by the paper's protocol."),
    _c("evaluate", "evaluate",
       "The benchmark study: every task x method x seed, Fig. 5 and Table I."),
    _c("calibrate", "calibration",
       "Calibration of Fea^m against executed pickups: reliability, ECE, Brier."),
    _c("failure-price", "failure_price",
       "What a pickup's chance of failing costs with recovery, from studies."),
    _c("shared-stop", "shared_stop",
       "What a pickup at a shared stop achieves of its Fea^m, from studies."),
    _c("directives", "directives",
       "Write a scenario as Drake model directives, which Drake's own tools open."),
    _c("diagrams", "diagrams", "Regenerate the Graphviz pictures of the Drake diagrams."),
    _c("sim", "sim", "The simulated robot alone on an LCM bus, for controllers elsewhere."),
    _c("build robot", "build_robot",
       "Build what a robot needs from its description: map, times, FCN, checks."),
    _c("build model", "build_model", "Build a robot's parts from their makers' files."),
    _c("build reachability", "build_reachability",
       "Build the arm's inverse reachability map with Drake IK."),
    _c("build time-model", "derive_times",
       "Derive the planner's time model from the robot's own motions."),
    _c("build fcn-data", "dataset",
       "Make the FCN's training data: overhead crops with Drake-oracle labels."),
    _c("build fcn", "train", "Train the feasibility FCN on oracle-labelled crops."),
    _c("bench planning", "planning_benchmark",
       "Planning time per task, broken down, and utility against 10x the samples."),
    _c("bench execution", "execution_benchmark",
       "How much faster than real time a plan runs, and the playback's size."),
    _c("bench pickup", "pickup_benchmark",
       "Pickup durations: TOPPRA under the UR5e's limits against trapezoids."),
    _c("bench tracking", "tracking_benchmark",
       "How closely each robot's arm follows a planned pickup in simulation."),
    _c("bench time", "time_benchmark",
       "The plan's predicted execution time against the simulated one."),
    _c("bench scale", "scale_benchmark",
       "5 to 40 dishes: planning time by stage, task orders against the optimum."),
    _c("bench limit", "limit_benchmark",
       "How far from the best plan: a reference planner, rations lifted alone."),
    _c("bench feasibility", "feasibility_benchmark",
       "The feasibility check: map and IK speed, agreement, one heatmap's time."),
    _c("bench fcn", "fcn_benchmark",
       "The feasibility FCN against the Drake oracle on unseen scenes."),
    _c("bench perception", "perception_benchmark",
       "Chair perception: the perceived chairs against the true ones."),
    _c("bench navigation", "navigation_benchmark",
       "A scenario's navigation map: its size and its path-length query times."),
    _c("bench abstraction", "abstraction_benchmark",
       "The state-space abstraction: candidates counted and time taken."),
    _c("bench oracle-pinning", "oracle_pinning",
       "Fea^m's oracle against the executed pickup and against Monte Carlo."),
    _c("bench oracle-executed", "oracle_check",
       "Which Fea^m model is off: the plan's or the oracle's, at executed pickups."),
    _c("bench reachability-agreement", "reachability_agreement",
       "The reachability map against exhaustive IK, on random queries."),
    _c("bench compare-feasibility", "compare_feasibility",
       "The planner's two Fea^m sources end to end: plan, execute, count dishes."),
    _c("bench compare-variants", "compare_variants",
       "Variants of a method against a baseline, paired: the attribution table."),
    _c("bench best-stops", "best_stops",
       "Each dish's best stop by Fea^m: the best odds of an open-loop plan."),
    _c("bench same-runs", "same_runs",
       "Whether two studies' runs did the same, the machine's timings aside."),
    _c("bench two-process", "two_process_benchmark",
       "One process against two: the robot beside its controllers, or on a bus."),
    _c("bench soak", "soak",
       "Plan and execute many random scenes: crashes, overruns, hangs, memory."),
)

GROUPS = {
    "build": ("WHAT", "make what ships in models/ (written under out/ unless --out names it)"),
    "bench": ("NAME", "measurements and checks (their figures are in docs/)"),
}


def find(words: list[str]) -> Command | None:
    """The command that `words` (the first one or two arguments) name, if any."""
    name = " ".join(words[:2]) if words and words[0] in GROUPS else " ".join(words[:1])
    return next((c for c in COMMANDS if c.name == name), None)


def help_text(group: str | None = None) -> str:
    """The command list: every command (or one group's), a line each."""
    width = 24  # the longest name and two spaces
    lines: list[str] = []
    if group is None:
        lines += [f"usage: {PROG} COMMAND [ARGS ...]   ({PROG} COMMAND --help explains one)",
                  "", "S3O on Drake: plan long-horizon mobile manipulation with S3O and "
                  "execute it in simulation.", "", "commands:"]
        lines += [f"  {c.name:<{width}}{c.summary}" for c in COMMANDS if " " not in c.name]
    for name, (metavar, about) in GROUPS.items():
        if group not in (None, name):
            continue
        if group is not None:
            lines += [f"usage: {PROG} {name} {metavar} [ARGS ...]   ({PROG} {name} {metavar} "
                      "--help explains one)"]
        lines += ["", f"{PROG} {name} {metavar}: {about}"]
        lines += [f"  {c.name.split(' ', 1)[1]:<{width}}{c.summary}"
                  for c in COMMANDS if c.name.startswith(name + " ")]
    lines += ["", f"Every command's details: {DOCS}."]
    return "\n".join(lines)


def _error(prog: str, message: str) -> int:
    """Bad input: one line on stderr, exit status 2 (as every command's)."""
    print(f"{prog}: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _unknown(prog: str, word: str, choices: list[str]) -> int:
    """An unknown command, named; a command's module name (its address before `s3o`) is
    answered with its new name."""
    renamed = next((c for c in COMMANDS if c.module.rsplit(".", 1)[1] == word), None)
    if renamed is not None:
        return _error(prog, f"unknown command {word!r}: it is now `{renamed.prog}`")
    return _error(prog, f"unknown command {word!r} (choose from {', '.join(choices)})")


def main(argv: list[str] | None = None) -> int:
    """`s3o COMMAND [ARGS ...]`: runs the command's module with the arguments that follow
    its name; the return value is its exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    top = [c.name for c in COMMANDS if " " not in c.name] + list(GROUPS)
    if not args:
        return _error(PROG, f"a command is required ({PROG} --help lists them)")
    if args[0] in ("-h", "--help"):
        print(help_text())
        return 0
    if args[0] in GROUPS:
        group, prog = args[0], f"{PROG} {args[0]}"
        members = [c.name.split(" ", 1)[1] for c in COMMANDS if c.name.startswith(group + " ")]
        if len(args) == 1:
            return _error(prog, f"a {GROUPS[group][0]} is required (one of {', '.join(members)})")
        if args[1] in ("-h", "--help"):
            print(help_text(group))
            return 0
        if find(args) is None:
            return _unknown(prog, args[1], members)
    command = find(args)
    if command is None:
        return _unknown(PROG, args[0], top)
    rest = args[len(command.name.split()):]
    status = importlib.import_module(command.module).main(rest)
    return 0 if status is None else int(status)


if __name__ == "__main__":
    sys.exit(main())
