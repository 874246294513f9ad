"""Mistakes a new user makes on the command line: one line on stderr naming the thing at fault,
exit status 2, nothing written; and every option's help says what it is and its default."""

import argparse

import numpy as np
import pytest

from mitsonar.cli import build_parser, main
from mitsonar.scene.xml import material_xml, rectangle_xml


def run(argv, capsys) -> tuple[int, str]:
    """Exit status and stderr of ``mitsonar argv`` (argparse's own errors exit)."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exit_:
        code = exit_.code
    return code, capsys.readouterr().err


def assert_one_line_error(err: str, *names: str) -> None:
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err and "error:" in err
    for name in names:
        assert name in err, (name, err)


@pytest.mark.parametrize("props,message", [
    ({"impedance": -5.0}, "impedance"), ({"impedance": "nan"}, "impedance"),
    ({"preset": "marble"}, "unknown acoustic preset 'marble'"),
    ({"impedance": "soft"}, "impedance must be a number")])
def test_invalid_material_is_one_line_naming_file_and_material(scene_file, tmp_path, capsys,
                                                               props, message):
    scene = scene_file("bad_room", material_xml("broken_wall", **props),
                       rectangle_xml("broken_wall", (2.0, 0, 0.5), (0, -90, 0)))
    code, err = run(["scan", scene, "--out", tmp_path / "out"], capsys)
    assert code == 2
    assert_one_line_error(err, "bad_room.xml (line 2", "'broken_wall'", message)
    assert not (tmp_path / "out").exists()


def test_material_error_in_an_included_file_names_both_files(scene_file, tmp_path, capsys):
    scene_file("walls", material_xml("broken_wall", impedance=-1.0),
               rectangle_xml("broken_wall", (2.0, 0, 0.5), (0, -90, 0)))
    scene = scene_file("room", '<include filename="walls.xml"/>')
    code, err = run(["scan", scene, "--out", tmp_path / "out"], capsys)
    assert code == 2
    assert_one_line_error(err, "room.xml: ", "walls.xml (line 2", "'broken_wall'")


#: Every command with an output directory, with its other required arguments.
OUTPUT_DIRECTORIES = [["scan", "scene.xml"], ["map", "repeated", "scene.xml"],
                      ["map", "surfel", "scene.xml"], ["dataset", "render", "scene.xml"],
                      ["evaluate", "cloud.ply", "scene.xml"], ["array", "plot"]]


@pytest.mark.parametrize("command", OUTPUT_DIRECTORIES, ids=" ".join)
@pytest.mark.parametrize("below", [False, True], ids=["file", "below_a_file"])
def test_output_directory_that_is_a_file_is_refused(tmp_path, capsys, command, below):
    existing = tmp_path / "results.txt"
    existing.write_text("keep me")
    out = existing / "run1" if below else existing
    code, err = run(command + ["--out", out], capsys)
    assert code == 2
    assert_one_line_error(err, "--out", f"{existing} is a file, not a directory")
    assert [p.name for p in tmp_path.iterdir()] == ["results.txt"]
    assert existing.read_text() == "keep me"


def test_evaluate_refuses_a_file_where_its_default_output_directory_goes(tmp_path, capsys):
    (tmp_path / "cloud_metrics").write_text("keep me")
    code, err = run(["evaluate", tmp_path / "cloud.ply", "scene.xml"], capsys)
    assert code == 2
    assert_one_line_error(err, "cloud_metrics is a file, not a directory")


def test_array_design_refuses_a_directory_as_its_layout_file(tmp_path, capsys):
    code, err = run(["array", "design", "--out", tmp_path], capsys)
    assert code == 2
    assert_one_line_error(err, f"{tmp_path} is a directory, not a file")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv", [["scan"], ["scan", "s.xml", "--out", "o", "--preset", "best"],
                                  ["scan", "s.xml", "--out", "o", "--pose", "1,2"], []])
def test_argument_errors_are_one_line(capsys, argv):
    code, err = run(argv, capsys)
    assert code == 2
    assert_one_line_error(err, "--help")


def test_negative_values_follow_their_option():
    parser = build_parser()
    args = parser.parse_args(["scan", "s.xml", "--pose", "-1.8,-0.5,-90", "--out", "o",
                              "--step", "-.5"])
    np.testing.assert_allclose(args.pose, (-1.8, -0.5, -np.pi / 2))
    assert args.step == -0.5
    assert parser.parse_args(["map", "repeated", "--speed", "-1e-3", "s.xml", "--out", "o"]
                             ).speed == -1e-3
    with pytest.raises(SystemExit):  # a flag takes no value: '-1' is left as an extra argument
        parser.parse_args(["map", "repeated", "s.xml", "--out", "o", "--broadband", "-1"])


def parsers(parser: argparse.ArgumentParser):
    """``parser`` and every sub-parser below it."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from parsers(sub)


def test_every_option_says_what_it_is_and_its_default():
    missing = []
    for parser in parsers(build_parser()):
        for action in parser._actions:
            name = f"{parser.prog} {'/'.join(action.option_strings) or action.dest}"
            if not action.help:
                missing.append(f"{name}: no help")
            elif (action.default not in (None, argparse.SUPPRESS) and action.nargs != 0
                  and "default" not in action.help):
                missing.append(f"{name}: default {action.default!r} not named")
            if isinstance(action, argparse._SubParsersAction):
                missing += [f"{parser.prog} {c.dest}: no help" for c in action._choices_actions
                            if not c.help]
    assert not missing, "\n".join(missing)


def test_run_time_errors_name_the_sub_command(tmp_path, capsys):
    """An error raised while a nested command runs names that command, not only its group."""
    from mitsonar.cli import main

    missing = tmp_path / "missing"
    assert main(["dataset", "info", str(missing)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mitsonar dataset info: error:"), err
    assert "\n" not in err


def test_a_file_the_system_refuses_is_one_line(tmp_path, capsys, monkeypatch):
    """An OSError while a command writes (permission denied, read-only or full disk) is one line
    naming the file, exit 2, no traceback."""
    from mitsonar.cli import build_parser, main, scan

    def refuse(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "out" / "points.ply"))

    monkeypatch.setattr(scan, "_run_scan", refuse)
    parser = build_parser()  # built after the patch: the scan command now runs refuse()
    monkeypatch.setattr("mitsonar.cli.build_parser", lambda: parser)
    assert main(["scan", "room_glass", "--out", str(tmp_path / "out")]) == 2
    refused = tmp_path / "out" / "points.ply"
    err = capsys.readouterr().err.strip()
    assert err == f"mitsonar scan: error: [Errno 13] Permission denied: '{refused}'"


@pytest.mark.parametrize("mode", ["repeated", "surfel"])
@pytest.mark.parametrize("value", ["0", "-1", "80"])
def test_a_drive_longer_than_the_trajectory_is_refused(tmp_path, capsys, mode, value):
    """room_glass's trajectory lasts 79.5 s: --duration outside (0, 79.5] names it."""
    code, err = run(["map", mode, "room_glass", "--duration", value, "--out", tmp_path / "o"],
                    capsys)
    assert code == 2
    assert_one_line_error(err, "--duration", "79.5")


@pytest.mark.parametrize("options,names", [
    (["--chirp"], ["--chirp 30-50", "--broadband", "2 kHz"]),
    (["--chirp", "20-80", "--broadband"], ["--chirp 20-80", "--preset paper", "20 kHz"]),
    (["--chirp", "20-60"], ["--chirp", "invalid choice", "'30-50', '20-80'"]),
    (["--transmit", "defocused"], ["--transmit defocused", "--scan imaging"])])
def test_repeated_options_that_do_not_go_together(tmp_path, capsys, options, names):
    """A sweep behind transducers that do not pass it (30-50 kHz behind the TCT40 class, 20-80
    behind the broadband ones), a sweep by an unknown name, a defocused transmission for OFDM
    frames: one line naming the options, before anything is simulated or written."""
    code, err = run(["map", "repeated", "room_glass", "--out", tmp_path / "o", *options], capsys)
    assert code == 2
    assert_one_line_error(err, *names)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("command", [["map", "surfel", "structure"],
                                     ["dataset", "render", "office", "--samples", "1"]],
                         ids=" ".join)
def test_a_camera_image_too_narrow_is_refused(tmp_path, capsys, command):
    """--width 3 (a 3 x 2 image, on which line detection fails inside OpenCV): one line naming
    the setting and its minimum, exit 2, nothing written."""
    code, err = run([*command, "--width", "3", "--out", tmp_path / "o"], capsys)
    assert code == 2
    assert_one_line_error(err, "image_width", ">= 8", "3")
    assert not (tmp_path / "o").exists()


def test_shared_hits_with_single_ping_images_is_refused(tmp_path, capsys):
    """``dataset render --scan image --shared-hits``: the images have no beam scan to share
    hits in; one line naming both options, exit 2, nothing written."""
    code, err = run(["dataset", "render", "room_glass", "--scan", "image", "--shared-hits",
                     "--out", tmp_path / "o"], capsys)
    assert code == 2
    assert_one_line_error(err, "--shared-hits", "--scan image")
    assert not (tmp_path / "o").exists()
