"""Where the shipped models and data live, for an editable checkout and for an installed wheel."""

from __future__ import annotations

import functools
from pathlib import Path

from twin.errors import ModelError

_PACKAGE_DIR = Path(__file__).resolve().parent.parent  # twin/


@functools.cache
def models_dir() -> Path:
    """Return the folder holding the shipped robots (their descriptions `*.toml` beside their MJCF) and cells.

    In a checkout this is `<repo>/models`; in an installed wheel the same tree is shipped as `twin/models`.

    Raises:
        ModelError: If neither location holds a robot description.
    """
    for candidate in (_PACKAGE_DIR.parent / "models", _PACKAGE_DIR / "models"):
        if candidate.is_dir() and any(candidate.glob("*.toml")):
            return candidate
    raise ModelError(
        f"model folder not found: looked for robot descriptions (*.toml) in {_PACKAGE_DIR.parent / 'models'} "
        f"and {_PACKAGE_DIR / 'models'}"
    )


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
