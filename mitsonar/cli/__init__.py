"""Command-line interface: ``mitsonar <command> ...``. Degrees at this boundary, SI inside.

One module per command group; each provides ``add_cli(subparsers)``, which adds its parser(s)
and sets ``func`` to the function that runs them. Library modules hold no argument parsing.
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: Command groups, in the order ``mitsonar --help`` lists them.
COMMAND_MODULES: list[str] = ["mitsonar.cli.scan", "mitsonar.cli.map", "mitsonar.cli.dataset",
                              "mitsonar.cli.evaluate", "mitsonar.cli.array"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mitsonar", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_cli(sub)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as err:  # user errors: one clear line, no traceback
        print(f"mitsonar {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
