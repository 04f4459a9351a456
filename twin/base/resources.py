"""Where the shipped models and data live, for an editable checkout and for an installed wheel."""

from __future__ import annotations

from pathlib import Path

from twin.errors import ModelError

_PACKAGE_DIR = Path(__file__).resolve().parent.parent  # twin/


def models_dir() -> Path:
    """Return the folder holding `tx200.xml` and `cell/scene.xml`.

    In a checkout this is `<repo>/models`; in an installed wheel the same tree is shipped as `twin/models`.

    Raises:
        ModelError: If neither location holds `tx200.xml`.
    """
    for candidate in (_PACKAGE_DIR.parent / "models", _PACKAGE_DIR / "models"):
        if (candidate / "tx200.xml").is_file():
            return candidate
    raise ModelError(
        f"model folder not found: looked for tx200.xml in {_PACKAGE_DIR.parent / 'models'} "
        f"and {_PACKAGE_DIR / 'models'}"
    )


def robot_xml() -> Path:
    """Path of the robot-only MJCF `tx200.xml`."""
    return models_dir() / "tx200.xml"


def scene_xml() -> Path:
    """Path of the cell scene `cell/scene.xml` (includes the robot)."""
    path = models_dir() / "cell" / "scene.xml"
    if not path.is_file():
        raise ModelError(f"scene model not found at {path}")
    return path


def data_file(name: str) -> Path:
    """Path of a file shipped in `twin/data/`.

    Args:
        name: File name inside `twin/data/`, e.g. `fe_force_history.csv`.

    Raises:
        ModelError: If the file does not exist.
    """
    path = _PACKAGE_DIR / "data" / name
    if not path.is_file():
        raise ModelError(f"package data file not found: {path}")
    return path
