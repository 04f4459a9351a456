"""Lazy public names of a package: its `__all__`, imported from their modules on first use (PEP 562).

A stage's `__init__` lists its public names and the module each lives in; `import twin.process` then costs
nothing until a name is used, so a command that needs little (`--help`, `path`, `export`) does not import
MuJoCo, numba or scipy through a package it passes on the way.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(
    package: str, names: Mapping[str, str]
) -> tuple[list[str], Callable[[str], Any], Callable[[], list[str]]]:
    """`__all__`, `__getattr__` and `__dir__` for a package whose public names live in its modules.

    Args:
        package: The package's `__name__`.
        names: Public name -> module that defines it.

    Returns:
        The three module attributes, to assign in the package's `__init__`.
    """

    def get_attribute(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(names[name]), name)
        setattr(sys.modules[package], name, value)  # the next lookup is a plain attribute
        return value

    def listing() -> list[str]:
        return sorted({*names, *vars(sys.modules[package])})

    return sorted(names), get_attribute, listing
