"""Exceptions of tx200-twin: one base, specific subclasses.

Every message shows the bad value and what was valid. Errors about a file name the file and,
where it applies, the 1-based data row (the header is row 0).
"""

from __future__ import annotations

from pathlib import Path


class TwinError(Exception):
    """Base class of every error raised on purpose by tx200-twin."""


class InputError(TwinError, ValueError):
    """A function argument has the wrong shape, type, value or is not finite."""


class ModelError(TwinError):
    """A model file is missing, does not compile, or lacks a required element."""


class DataFileError(TwinError):
    """A data file (CSV, JSON) is missing, malformed, truncated or holds bad values.

    Attributes:
        path: The offending file.
        row: 1-based data row (header is row 0), or None when the whole file is at fault.
        detail: The message without the file and row.
    """

    def __init__(self, path: str | Path, message: str, row: int | None = None) -> None:
        self.path = Path(path)
        self.row = row
        self.detail = message
        where = f"{self.path}" if row is None else f"{self.path}, row {row}"
        super().__init__(f"{where}: {message}")


class UnitsError(DataFileError):
    """Values look like the wrong unit (for instance metres in a `_mm` column)."""


class RunFormatError(DataFileError):
    """A run directory does not follow the `tx200-twin-run/1` contract."""


class SymmetryError(TwinError):
    """An FE force history was loaded without a valid symmetry declaration (`half` or `full`)."""


class UnreachableError(TwinError):
    """Inverse kinematics found no joint solution for a target (out of reach or out of joint range)."""


class SingularityError(TwinError):
    """A joint solution is closer to a singularity than the allowed |det J| threshold."""


class IdentificationError(TwinError):
    """Identification data cannot determine the requested parameters (singular, too few, bad units)."""


class CompensationError(TwinError):
    """Compensation did not converge or got inconsistent inputs."""


class ExtrapolationWarning(UserWarning):
    """A model is used outside the range its published data cover (it still answers; the CLI prints a warning)."""


class AssumptionWarning(UserWarning):
    """The twin completed an input with an assumption it states (the CLI prints it as a note)."""
