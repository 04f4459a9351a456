"""Lazy public names of a package: its `__all__`, imported from their modules on first use (PEP 562).

A stage's `__init__` lists its public names and the module each lives in; `import twin.process` then costs
nothing until a name is used, so a command that needs little (`--help`, `path`, `export`) does not import
MuJoCo, numba or scipy through a package it passes on the way. `lazy_module` does the same for a library
that a module uses in a few functions only.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable, Mapping
from types import ModuleType
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


def lazy_module(name: str) -> ModuleType:
    """A module that is imported on its first attribute access (`importlib.util.LazyLoader`).

    For a library a module uses in a few functions only (trimesh): `import twin.x` stays cheap, and the library
    loads when a function first needs it. Modules write `if TYPE_CHECKING: import lib` / `else: lib =
    lazy_module("lib")`, so the type checker still sees the library.

    Args:
        name: The module's absolute name.
    """
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
