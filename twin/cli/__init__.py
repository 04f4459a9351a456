"""Command line `tx200-twin`: one module per command in this package, listed in COMMANDS.

Modules: `info`, `path`, `fe_history`, `identify`, `calibrate`, `reproduce`, `force_validation`, `springback_scans`, `lab`, `replay`, `learn`,
`compensate`, `check`, `bench`, `sweep`, `place`, `discrepancy`, `demo`, `import_run` (`import`), `export`, `online`, `materials` and `robots`,
one per command, each over its task (`twin/apps/tasks/`: a typed request, a report); `_common` holds the options
several commands share (the FE history, the force model, the declared process, the placement, `--json`) and
`finish`; `_types` the argparse types with plausible ranges (seeds, counts, lengths, feeds); `_repeats` refuses a
single-valued option typed twice (argparse would keep the last in silence).

Each command module defines `HELP` (one line), `add_arguments(parser)` and `run(args) -> int`. Before a command runs,
its outputs (the options in `OUTPUT_OPTIONS`) pass `twin.base.outputs.check_outputs` against every option naming an
existing file or folder: an output never replaces an input or another output.
Every sub-parser's help shows each option's default (`DefaultsFormatter`, where the help does not already say it),
and path options get one metavar scheme (`uniform_metavars`): RUN for a run folder, DIR for a folder, FILE for a
file (unless the module names a more specific one, e.g. PNG or FILE.toml).
Commands that report numbers take `--json FILE` (`-` for stdout) and print a short human summary. A `TwinError`
ends the command with its message and exit code 2; a warning (e.g. an effect read under a name used before) is
printed as a note, a model used outside its published range (`ExtrapolationWarning`) as a warning.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from twin.base.outputs import check_outputs
from twin.cli._common import apply_cell
from twin.cli._repeats import check_repeated_options
from twin.errors import AssumptionWarning, ExtrapolationWarning, TwinError

# the options that write; every other option (or positional) naming an existing path is an input
OUTPUT_OPTIONS = ("--out", "--json", "--gcode-out", "--stl-out", "--design-stl", "--write-model", "--model-out", "--report", "--work",
                  "--markdown", "--figure", "--readme", "--rrd")
# (command, option) whose folder is replaced as a whole (a run directory written by renames)
REPLACED_FOLDERS = {("lab", "--out"), ("import", "--out")}
# (command, option) that names a folder (the rest name files)
FOLDER_OUTPUTS = {*REPLACED_FOLDERS, ("demo", "--out"), ("reproduce", "--work"), ("discrepancy", "--report"),
                  ("export", "--out")}
EXIT_CODES = """exit codes:
  0  done
  1  done, and the result failed the check it reports (`check`: a gain away from 1; `online`: no robot packet
     answered, or no F/T sample in the session)
  2  refused: a bad option or input file (the message names it and what was expected), an output that would
     replace an input, or an output that cannot be written; nothing is written"""

# command name -> module under twin.cli (imported lazily so `--help` stays fast)
COMMANDS: dict[str, str] = {
    "info": "info",
    "path": "path",
    "fe-history": "fe_history",
    "identify": "identify",
    "calibrate": "calibrate",
    "reproduce": "reproduce",
    "force-validation": "force_validation",
    "springback-scans": "springback_scans",
    "lab": "lab",
    "replay": "replay",
    "learn": "learn",
    "compensate": "compensate",
    "check": "check",
    "bench": "bench",
    "sweep": "sweep",
    "place": "place",
    "discrepancy": "discrepancy",
    "demo": "demo",
    "import": "import_run",
    "export": "export",
    "online": "online",
    "robots": "robots",
    "materials": "materials",
}


def _shown(value: object) -> str:
    """A default as `--help` shows it: floats with `:g`, sequences space-separated."""
    if isinstance(value, list | tuple):
        return " ".join(_shown(v) for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


class DefaultsFormatter(argparse.RawDescriptionHelpFormatter):
    """Appends `(default: X)` to an option's help unless it already mentions its default (or has none)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if default in (None, False, argparse.SUPPRESS) or "default" in text.lower() or action.nargs == 0:
            return text
        if not action.option_strings and action.nargs not in ("?", "*"):
            return text
        return f"{text} (default: {_shown(default).replace('%', '%%')})"


def uniform_metavars(command: str, parser: argparse.ArgumentParser) -> None:
    """Give each path option without a metavar RUN (run folder), DIR (folder) or FILE."""
    for action in parser._actions:
        if action.metavar is not None or action.choices is not None or action.nargs not in (None, "?"):
            continue
        option = action.option_strings[-1] if action.option_strings else ""
        if action.dest == "run_dir" or option in ("--run", "--learn-from") or (command, option) in REPLACED_FOLDERS:
            action.metavar = "RUN"
        elif (command, option) in FOLDER_OUTPUTS:
            action.metavar = "DIR"
        elif action.type is Path or option == "--json":
            action.metavar = "FILE"


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with one sub-parser per command."""
    parser = argparse.ArgumentParser(
        prog="tx200-twin",
        description="MuJoCo digital twin of a compliant robot forming sheet metal incrementally (ISF): any part, "
        "any robot; replay, learn, identify, compensate, check.",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action=_Version, nargs=0, help="show the installed version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"twin.cli.{module_name}")
        command = sub.add_parser(name, help=module.HELP, description=module.HELP, formatter_class=DefaultsFormatter)
        module.add_arguments(command)
        uniform_metavars(name, command)
        command.set_defaults(_run=module.run)
    return parser


class _Version(argparse.Action):
    """`--version`, the package metadata read only when asked (importlib.metadata costs a fifth of `--help`)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        from importlib import metadata

        try:
            version = metadata.version("tx200-twin")
        except metadata.PackageNotFoundError:
            version = "unknown (not installed)"
        print(f"{parser.prog} {version}")
        parser.exit()


def check_command_outputs(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """`check_outputs` for a parsed command line: its `OUTPUT_OPTIONS` against every other path it names."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    inputs: list[tuple[str, str | Path]] = []
    outputs: list[tuple[str, str | Path]] = []
    for action in sub.choices[args.command]._actions:
        value = getattr(args, action.dest, None)
        values = value if isinstance(value, list) else [value]  # `nargs` positionals (`learn RUN [RUN ...]`)
        if action.dest in ("help", "_run") or action.choices is not None:
            continue
        name = action.option_strings[-1] if action.option_strings else action.dest.upper()
        for item in values:
            if not isinstance(item, str | Path):
                continue
            if name in OUTPUT_OPTIONS:
                outputs.append((name, item))
            elif Path(item).exists() or Path(item).is_symlink():
                inputs.append((name, item))
    replaced = {option for command, option in REPLACED_FOLDERS if command == args.command}
    folders = {option for command, option in FOLDER_OUTPUTS if command == args.command}
    check_outputs(inputs, outputs, replaced=replaced, folders=folders)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `tx200-twin` console script."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    others: list[warnings.WarningMessage] = []  # shown once the recording has ended (re-shown inside, each was
    try:  # recorded again into the list being read: a command with a warning of another kind never ended)
        with warnings.catch_warnings(record=True) as caught, np.printoptions(legacy="1.25"):  # 3.96, not np.float64(3.96)
            warnings.simplefilter("always", FutureWarning)
            warnings.simplefilter("always", ExtrapolationWarning)
            warnings.simplefilter("always", AssumptionWarning)
            try:
                sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
                check_repeated_options(sub.choices[args.command], argv[argv.index(args.command) + 1:])
                apply_cell(args)
                check_command_outputs(parser, args)
                return int(args._run(args))
            except TwinError as exc:
                print(f"tx200-twin {args.command}: error: {exc}", file=sys.stderr)
                return 2
            except OSError as exc:  # a file system refusal no reader or writer foresaw: named, not a traceback
                print(f"tx200-twin {args.command}: error: {exc.filename}: {exc.strerror or exc}", file=sys.stderr)
                return 2
            finally:
                for note in dict.fromkeys(str(w.message) for w in caught
                                          if issubclass(w.category, (FutureWarning, AssumptionWarning))):
                    print(f"tx200-twin {args.command}: note: {note}", file=sys.stderr)
                for note in dict.fromkeys(str(w.message) for w in caught
                                          if issubclass(w.category, ExtrapolationWarning)):
                    print(f"tx200-twin {args.command}: warning: {note}", file=sys.stderr)
                others = [w for w in caught
                          if not issubclass(w.category, (FutureWarning, ExtrapolationWarning, AssumptionWarning))]
    finally:
        for w in others:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)

if __name__ == "__main__":
    sys.exit(main())
