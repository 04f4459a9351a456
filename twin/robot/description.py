"""Which robot: the shipped robots, the ones a user registered in this session, and loading a robot by name or
path (`load_robot`), each description file read once (`twin.robot.robot_file`) until it or its MJCF changes.

The records a robot is (`RobotDescription`, what the twin knows of it) live in `twin.robot.facts`.
"""

from __future__ import annotations

import os
import tomllib
import warnings
from pathlib import Path

from twin.base.registry import Registry
from twin.base.resources import models_dir
from twin.errors import AssumptionWarning, ModelError
from twin.robot.facts import ROBOT_FORMAT, RobotDescription

DEFAULT_ROBOT = "tx200"

#: Description file -> (its and its MJCF's modification times, the description): a recalibrated model is re-read.
_CACHE: dict[str, tuple[tuple[int, int], RobotDescription]] = {}
#: Models folder and its modification time -> the shipped robots found there.
_SHIPPED: dict[tuple[str, int], dict[str, Path]] = {}


#: Robots a user registered by name in this session (`register_robot`), found before the shipped ones.
ROBOTS: Registry[RobotDescription] = Registry("robot", error=ModelError)


def register_robot(robot: str | Path | RobotDescription) -> RobotDescription:
    """Register a robot (a description file, a URDF/MJCF, or a description) under its name, so that
    `load_robot(name)` and `--robot NAME` find it.

    Raises:
        InputError: Its name is already registered. ModelError: a bad file.
    """
    return ROBOTS.register(load_robot(robot))


def shipped_robots() -> dict[str, Path]:
    """Name -> description file of every robot shipped in the models folder (`*.toml`, `*/robot.toml`)."""
    folder = models_dir()
    key = (str(folder), folder.stat().st_mtime_ns)
    if key not in _SHIPPED:
        found: dict[str, Path] = {}
        for path in sorted([*folder.glob("*.toml"), *folder.glob("*/robot.toml")]):
            try:
                data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
            except (OSError, tomllib.TOMLDecodeError):
                continue
            if data.get("format") == ROBOT_FORMAT and isinstance(data.get("name"), str):
                found[data["name"]] = path
        _SHIPPED[key] = found
    return dict(_SHIPPED[key])


def load_robot(robot: str | Path | RobotDescription | None = None) -> RobotDescription:
    """The robot named (a shipped robot), at a path (a description file, or a URDF/MJCF of the user's own that
    `twin.robot.user_model` completes), or the default (`tx200`).

    Raises:
        ModelError: Unknown name (lists the shipped robots), a missing or malformed file, or an MJCF that lacks
            a part the description names.
    """
    if isinstance(robot, RobotDescription):
        return robot
    if robot is None or (isinstance(robot, str) and Path(robot).suffix.lower() not in (".toml", ".xml", ".urdf")
                         and "/" not in robot and os.sep not in robot):
        name = DEFAULT_ROBOT if robot is None else robot
        if name in ROBOTS:
            return ROBOTS[name]
        shipped = shipped_robots()
        if name not in shipped:
            raise ModelError(f"unknown robot {name!r}; shipped robots: {sorted(shipped)} (or a path to a .toml file)")
        path = shipped[name]
    else:
        path = Path(robot)
        if path.suffix.lower() in (".xml", ".urdf"):
            path = _user_model(path)
    cached = _CACHE.get(str(path))
    if cached is not None and cached[0] == _stamps(path, cached[1].mjcf):
        return cached[1]
    if not path.is_file():
        raise ModelError(f"robot description not found: {path} (expected a {ROBOT_FORMAT} .toml file)")
    from twin.robot.robot_file import read_description  # MuJoCo: only when a description file is read

    description = read_description(path)
    _CACHE[str(path)] = (_stamps(path, description.mjcf), description)
    return description


def _user_model(path: Path) -> Path:
    """The description the twin writes for a user's URDF or MJCF (`twin.robot.user_model`), warning with each
    assumption it made."""
    from twin.robot.user_model import describe_model_file

    if not path.is_file():
        raise ModelError(f"robot model not found: {path} (expected a URDF or MJCF file)")
    description, assumptions = describe_model_file(path)
    for sentence in assumptions:
        warnings.warn(f"robot {path.name}: {sentence}", AssumptionWarning, stacklevel=3)
    return description


def robot_record(robot: RobotDescription) -> str:
    """How runs and model files name a robot: its name when it is the shipped one, else its description file."""
    return robot.name if shipped_robots().get(robot.name) == robot.source else str(robot.source)


def _stamps(path: Path, mjcf: Path) -> tuple[int, int]:
    """Modification times of a description file and its MJCF (-1 for one that is gone)."""
    return tuple(p.stat().st_mtime_ns if p.exists() else -1 for p in (path, mjcf))  # type: ignore[return-value]
