"""ROS 2 message definitions for MCAP recordings, without a ROS installation.

The definitions are text files in ``mitsonar/data/msg/<package>/<Type>.msg``: the standard ROS 2
interfaces that mitsonar writes (their fields as published in ros2/common_interfaces, with short
comments) and mitsonar's own ``mitsonar_msgs/SonarEchoes``. An MCAP schema of encoding
``ros2msg`` holds a type's definition followed by that of every type it uses, each after a line
of 80 '=' and ``MSG: <package>/<Type>`` (the text rosbag2 writes); :func:`definition` builds it.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

#: Folder of the shipped .msg files.
MSG_DIR = Path(__file__).with_name("msg")

_PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
               "int32", "uint32", "int64", "uint64", "string", "wstring"}


def schema_name(name: str) -> str:
    """'pkg/Type' or 'pkg/msg/Type' -> 'pkg/msg/Type' (the schema names rosbag2 writes)."""
    package, _, kind = _split(name)
    return f"{package}/msg/{kind}"


def _split(name: str) -> tuple[str, str, str]:
    parts = name.split("/")
    if len(parts) == 2:
        return parts[0], "msg", parts[1]
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], "msg", parts[2]
    raise ValueError(f"not a ROS 2 message type: {name!r} (expected 'package/Type')")


def message_text(name: str) -> str:
    """The shipped definition of one message type ('pkg/Type')."""
    package, _, kind = _split(name)
    path = MSG_DIR / package / f"{kind}.msg"
    if not path.is_file():
        raise ValueError(f"no definition of {name} in {MSG_DIR}")
    return path.read_text()


def used_types(text: str) -> list[str]:
    """Message types ('pkg/Type') of the fields of a definition, in order, without repeats."""
    found: list[str] = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line or "=" in line:  # blank, comment or constant
            continue
        kind = line.split()[0].split("[", 1)[0]
        if kind not in _PRIMITIVES and kind not in found:
            found.append(kind)
    return found


@cache
def definition(name: str) -> str:
    """Concatenated ``ros2msg`` definition of ``name``: its text, then every type it uses
    (depth first, each once)."""
    order: list[str] = []

    def visit(kind: str) -> None:
        for used in used_types(message_text(kind)):
            if used not in order:
                order.append(used)
                visit(used)

    package, _, kind = _split(name)
    visit(f"{package}/{kind}")
    parts = [message_text(f"{package}/{kind}").rstrip("\n")]
    parts += [f"{'=' * 80}\nMSG: {used}\n{message_text(used).rstrip(chr(10))}" for used in order]
    return "\n".join(parts) + "\n"
