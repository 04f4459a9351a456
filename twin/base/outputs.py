"""Outputs never over inputs, and outputs with the permissions a plain `open` would give.

`check_outputs` is the one rule every command's outputs pass before anything is written (`twin.cli.main` calls it
with the options as typed): an output may not be an input, replace a file of an input directory, replace a
directory that holds an input, or be another output. `plain_mode` gives a file or folder written through a
temporary (`mkstemp` 0600, `mkdtemp` 0700) the mode the umask gives a new file (0o666 & ~umask) or folder
(0o777 & ~umask). `write_failure` turns an `OSError` of a write into a `DataFileError` naming the target (not the
hidden temporary).
"""

from __future__ import annotations

import os
from collections.abc import Collection, Sequence
from pathlib import Path

from twin.errors import DataFileError, InputError

Named = tuple[str, str | Path]


def current_umask() -> int:
    """The process's umask (read by setting and restoring it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def plain_mode(path: str | Path, *, directory: bool = False) -> None:
    """chmod `path` to the mode a plain `open`/`mkdir` gives under the current umask."""
    os.chmod(path, (0o777 if directory else 0o666) & ~current_umask())


def write_failure(target: str | Path, exc: OSError) -> DataFileError:
    """The `DataFileError` of a failed write, naming the target and the system's reason."""
    reason = exc.strerror or type(exc).__name__
    if isinstance(exc, FileExistsError | NotADirectoryError):
        reason = "a folder on its path is a file"
    return DataFileError(target, f"cannot write it ({reason}); expected a writable location")


def _real(path: str | Path) -> Path:
    """The absolute path with symbolic links resolved (a loop or an unreadable link stays as written)."""
    try:
        return Path(os.path.realpath(path))
    except (OSError, RuntimeError, ValueError):
        return Path(os.path.abspath(path))


def _same(a: str | Path, b: str | Path) -> bool:
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return _real(a) == _real(b)


def repeated_input(paths: Sequence[str | Path]) -> tuple[str | Path, str | Path] | None:
    """The first two of `paths` that name one file or folder (links and spellings resolved), or None: an input
    given twice counts twice (a run learned twice, a run held out from itself)."""
    for i, a in enumerate(paths):
        for b in paths[i + 1:]:
            if _same(a, b):
                return a, b
    return None


def _inside(child: str | Path, parent: str | Path) -> bool:
    """Whether `child` lies strictly inside the folder `parent` (links resolved)."""
    real_child, real_parent = _real(child), _real(parent)
    return real_child != real_parent and real_child.is_relative_to(real_parent)


def _is_dir(path: str | Path) -> bool:
    try:
        return os.path.isdir(path)
    except (OSError, ValueError):
        return False


def _check_writable(option: str, out: str | Path, folder: bool) -> None:
    """InputError unless `out` can be created: not a folder where a file is expected, under a writable folder."""
    path = Path(out)
    if not folder and _is_dir(path):
        raise InputError(f"{option} {out} is a folder; expected a file name")
    parent = path.parent
    while not os.path.lexists(parent) and parent != parent.parent:
        parent = parent.parent
    if not _is_dir(parent):
        raise InputError(f"{option} {out}: {parent} is a file, not a folder; expected a path in a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option} {out}: the folder {parent} is not writable; expected a writable location")


def check_outputs(
    inputs: Sequence[Named], outputs: Sequence[Named], *, replaced: Collection[str] = (),
    folders: Collection[str] | None = None,
) -> None:
    """Refuse outputs that would write over an input or over each other.

    Args:
        inputs: (option as the user typed it, or a positional's name; path) of every input file or folder.
        outputs: (option; path) of every output; `-` (standard output) is skipped.
        replaced: The options among `outputs` whose folder is replaced as a whole (a run directory).
        folders: The options among `outputs` that are folders; given, every output is also checked to be
            creatable (a file name that is not a folder, under a writable folder) before anything is written.

    Raises:
        InputError: An output is an input, an existing file inside an input folder, a replaced folder holding an
            input, the same path as another output, or (with `folders`) cannot be written; the message names the
            options and paths.
    """
    seen: list[Named] = []
    for option, out in outputs:
        if str(out) == "-":
            continue
        if folders is not None:
            _check_writable(option, out, option in folders)
        for source, given in inputs:
            if _same(out, given):
                raise InputError(f"{option} {out} is the input {source} {given}: an output never replaces an "
                                 "input; expected another path")
            if _is_dir(given) and _inside(out, given) and os.path.lexists(out):
                raise InputError(f"{option} {out} would replace a file of the input folder {source} {given}; "
                                 "expected a path outside it or a new file")
            if option in replaced and _inside(given, out):
                raise InputError(f"{option} {out} would replace the folder holding the input {source} {given}; "
                                 "expected a folder that holds no input")
        for other_option, other in seen:
            if _same(out, other):
                raise InputError(f"{option} {out} and {other_option} {other} are the same path: each output "
                                 "needs its own")
        seen.append((option, out))
