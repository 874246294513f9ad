"""Command-line interface: ``mitsonar <command> ...``. Degrees at this boundary, SI inside.

One module per command group; each provides ``add_cli(subparsers)``, which adds its parser(s)
and sets ``func`` to the function that runs them. Library modules hold no argument parsing.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from mitsonar.cli.arguments import Parser

#: Command groups, in the order ``mitsonar --help`` lists them.
COMMAND_MODULES: list[str] = ["mitsonar.cli.scan", "mitsonar.cli.map", "mitsonar.cli.dataset",
                              "mitsonar.cli.evaluate", "mitsonar.cli.array",
                              "mitsonar.cli.scenes"]


def build_parser() -> argparse.ArgumentParser:
    """The ``mitsonar`` parser with every command's sub-parser."""
    parser = Parser(prog="mitsonar",
                    description="Simulate a 40 kHz ultrasonic phased array and a camera in "
                                "Mitsuba scenes: scans, maps, datasets, scores, array design. "
                                "Angles in degrees, everything else in SI units.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                help="what to run ('mitsonar COMMAND --help' lists its options)")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_cli(sub)
    return parser


def main(argv=None) -> int:
    """Run ``mitsonar`` on ``argv`` (default: the command line); returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, OSError, argparse.ArgumentTypeError) as err:
        # user errors (and the system refusing a file: permissions, a full disk): one clear
        # line naming the command, no traceback
        sub_command = getattr(args, f"{args.command}_command", None)
        name = " ".join(filter(None, ("mitsonar", args.command, sub_command)))
        print(f"{name}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
