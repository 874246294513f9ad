"""Argument types, options and the parser shared by the commands: degrees and robot poses at this
boundary, SI inside."""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import numpy as np

from mitsonar.physics.waveforms import SWEEPS
from mitsonar.scene.catalog import resolve_scene
from mitsonar.sensors.trajectory import Trajectory
from mitsonar.signal.detection import ECHO_MODES

#: A value that starts like a negative number ('-1.8,0,0', '-.5'), not like an option.
_NEGATIVE = re.compile(r"-\.?\d")


class Parser(argparse.ArgumentParser):
    """An ArgumentParser (and, through ``add_subparsers``, its sub-parsers) whose errors are one
    line, and that reads ``--pose -1.8,0,0`` as ``--pose=-1.8,0,0``: argparse alone takes a
    value starting with '-' for an option unless it is a plain number."""

    def parse_known_args(self, args=None, namespace=None):
        args = sys.argv[1:] if args is None else list(args)
        return super().parse_known_args(self._join_negative_values(args), namespace)

    def _join_negative_values(self, args: list[str]) -> list[str]:
        """``[..., '--opt', '-1,2', ...]`` -> ``[..., '--opt=-1,2', ...]`` for this parser's
        options that take one value; nothing after ``--`` is touched."""
        joined: list[str] = []
        for k, token in enumerate(args):
            if token == "--":
                return joined + args[k:]
            action = self._option_string_actions.get(joined[-1]) if joined else None
            if action is not None and action.nargs is None and _NEGATIVE.match(token):
                joined[-1] = f"{joined[-1]}={token}"
            else:
                joined.append(token)
        return joined

    def error(self, message):
        """Print ``message`` on one line (not the usage) and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def command_group(subparsers, name: str, help: str, description: str | None = None):
    """The sub-parsers of a command with sub-commands (``mitsonar NAME COMMAND``); the chosen
    sub-command is ``args.<name>_command``, which :func:`mitsonar.cli.main`'s errors name."""
    group = subparsers.add_parser(name, help=help, description=description)
    return group.add_subparsers(dest=f"{name}_command", required=True, metavar="COMMAND",
                                help=f"what to run ('mitsonar {name} COMMAND --help' lists its "
                                     "options)")


def add_output_argument(parser) -> None:
    """The required ``--out`` directory of a command that writes several files."""
    parser.add_argument("--out", type=output_directory, required=True,
                        help="output directory, created if absent; its files are replaced")


def output_directory(text) -> Path:
    """argparse type of an output directory: absent (it is created) or a directory. Raises
    ArgumentTypeError naming the file in the way where it, or a folder on its path, is a file."""
    path = Path(text)
    _check_folders(path, [*reversed(path.parents), path])
    return path


def output_file(text) -> Path:
    """argparse type of an output file: not a directory, and no file where its folders go."""
    path = Path(text)
    _check_folders(path, reversed(path.parents))
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{path} is a directory, not a file")
    return path


def _check_folders(path: Path, folders) -> None:
    """Raise ArgumentTypeError if one of ``folders`` (on the way to ``path``) is a file."""
    for folder in folders:
        if folder.exists() and not folder.is_dir():
            where = "" if folder == path else f"{path}: "
            raise argparse.ArgumentTypeError(f"{where}{folder} is a file, not a directory")


def parse_pose(text: str) -> tuple[float, float, float]:
    """'x,y,yaw' with x, y [m] and yaw [deg] -> (x, y, yaw [rad])."""
    try:
        x, y, yaw = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"pose must be 'x,y,yaw_deg', got {text!r}") from None
    if not np.all(np.isfinite([x, y, yaw])):
        raise argparse.ArgumentTypeError(f"pose must be finite, got {text!r}")
    return x, y, np.radians(yaw)


def parse_fov(text: str) -> tuple[float, float]:
    """'60x40' [deg] -> (horizontal, vertical) [rad]."""
    try:
        h, v = (float(t) for t in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"fov must be 'HxV' in degrees, got {text!r}") from None
    if not (0 < h < 180 and 0 < v < 180):
        raise argparse.ArgumentTypeError(f"fov angles must lie in (0, 180) degrees, got {text!r}")
    return np.radians(h), np.radians(v)


def scene_path(text: str) -> Path:
    """argparse type of a scene: a scene file, or the name of a shipped scene (``mitsonar
    scenes``) -> its file (:func:`~mitsonar.scene.catalog.resolve_scene`)."""
    return resolve_scene(text)


def add_scene_argument(parser) -> None:
    """The positional ``scene``: the Mitsuba XML scene the command works in."""
    parser.add_argument("scene", type=scene_path,
                        help="Mitsuba XML scene file with acoustic materials (metres, z up), or "
                             "the name of a shipped scene ('mitsonar scenes' lists them)")


def add_preset_argument(parser) -> None:
    """The ``--preset`` option: a named sonar configuration (``SonarConfig.preset``)."""
    parser.add_argument("--preset", choices=("default", "paper"), default="default",
                        help="sonar model: 'default' (the physical model) or 'paper' (the "
                             "paper's: point reflectors, ideal transducers, 340 m/s) "
                             "(default: default)")


def add_drive_arguments(parser, sweep_use: str) -> None:
    """``--broadband`` and ``--chirp``: the transducers and the drive (``SonarConfig.with_drive``;
    ``sweep_use`` says what the sweep is for)."""
    parser.add_argument("--broadband", action="store_true",
                        help="broadband transducers (20 kHz at -6 dB) instead of the 2 kHz TCT40 "
                             "class")
    parser.add_argument("--chirp", nargs="?", const="30-50", default=None, choices=SWEEPS,
                        metavar="KHZ",
                        help="drive the transmission with a 4 ms frequency sweep instead of the "
                             "tone burst: 30-50 kHz (without KHZ; needs --broadband or --preset "
                             "paper) or 20-80 (RTIS's, sampled at 250 kHz; needs --preset "
                             f"paper) ({sweep_use})")


def drive_config(args):
    """The ``--preset`` configuration with ``--broadband`` and ``--chirp``
    (:func:`add_drive_arguments`); a sweep behind the TCT40 class is refused naming the
    options."""
    from mitsonar.sensors.sonar import SonarConfig

    try:
        return SonarConfig.preset(args.preset).with_drive(args.broadband, args.chirp)
    except ValueError as error:  # the sweep behind transducers that do not pass it
        needs = "--broadband or --preset paper" if args.chirp == "30-50" else "--preset paper"
        raise ValueError(f"--chirp {args.chirp} needs {needs}: {error}") from None


def add_shared_hits_argument(parser) -> None:
    """``--shared-hits``: a scan's beams share one trace and one gridding of the element pairs
    (:meth:`Sonar.scan <mitsonar.sensors.sonar.Sonar.scan>`)."""
    parser.add_argument("--shared-hits", action="store_true",
                        help="trace the field of view once and synthesise every ping of a scan "
                             "from one gridding of the element pairs: each beam carries its "
                             "transmit side lobes, 2-3x faster on a full grid (default: each "
                             "beam in its own 20 deg cone; the paper preset always)")


def add_echoes_argument(parser, default: str, what: str) -> None:
    """The ``--echoes`` option: which echoes of each beam ``what`` takes
    (``DetectionSettings.echoes``)."""
    parser.add_argument("--echoes", choices=ECHO_MODES, default=default,
                        help=f"echoes of each beam {what}: the strongest ('first'), every echo "
                             f"('all'), every range cell across extended echoes too ('cells') or "
                             f"a range cell at the peak of each beam's cone image ('image') "
                             f"(default {default})")


def positive_count(text: str) -> int:
    """argparse type of a count that must be a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def add_workers_argument(parser, what: str) -> None:
    """The ``--workers N`` option: ``what`` simulated by N local processes
    (:mod:`mitsonar.parallel`), the same results whatever N."""
    parser.add_argument("--workers", type=positive_count, default=1,
                        help=f"local worker processes that simulate {what} at once, each loading "
                             "the scene (the same results whatever the number; a frame's receive "
                             "chain uses one core, so two workers on two cores run about twice "
                             "as fast with the paper preset) (default 1)")


def add_record_argument(parser) -> None:
    """The ``--record FILE.mcap`` option of the map commands."""
    parser.add_argument("--record", type=output_file, default=None, metavar="FILE.mcap",
                        help="also record the run as MCAP with ROS 2 messages: images, "
                             "detections, frames, odometry and the map, for Foxglove and ROS 2 "
                             "tools (docs/mcap.md) (default: no recording)")


def add_trajectory_argument(parser) -> None:
    """The ``--trajectory PATH.json`` option of commands that move along a scene's trajectory."""
    parser.add_argument("--trajectory", type=Path, default=None,
                        help="trajectory JSON file ({'waypoints': [[x_m, y_m, yaw_deg], ...], "
                             "'speed_m_s', 'yaw_rate_deg_s'}) (default: the one in the scene's "
                             "ground_truth.json)")


def trajectory_from_args(args) -> Trajectory:
    """``args.trajectory`` if given, else the default trajectory of ``args.scene``."""
    if args.trajectory is not None:
        return Trajectory.from_file(args.trajectory)
    return Trajectory.from_scene(args.scene)
