"""JSON documents: strict JSON written atomically (numpy values converted, non-finite numbers as null), read with
the file named in every error, and a CLI's `--json` target (a file or stdout)."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import read_text, write_text
from twin.errors import DataFileError


def _jsonable(value: Any) -> Any:
    """Convert numpy values, paths and non-finite floats (-> null, strict JSON) for `json.dumps`."""
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def write_json(path: str | Path, payload: Mapping[str, Any], *, protect: Sequence[str | Path] = ()) -> Path:
    """Write a JSON document atomically (numpy arrays and scalars are converted)."""
    return write_text(path, json.dumps(_jsonable(payload), indent=2, allow_nan=False) + "\n", protect=protect)


def emit_json(target: str | None, payload: Mapping[str, Any], *, protect: Sequence[str | Path] = ()) -> None:
    """Write `payload` for a CLI `--json` option: `-` prints to stdout, a path writes a file, None skips."""
    if target is None:
        return
    if target == "-":
        sys.stdout.write(json.dumps(_jsonable(payload), indent=2, allow_nan=False) + "\n")
    else:
        write_json(target, payload, protect=protect)


class NonFiniteNumberError(ValueError):
    """A number in a JSON or TOML document that is not finite (`finite_float`); `text` as written."""

    def __init__(self, text: str) -> None:
        super().__init__(text)
        self.text = text


def finite_float(text: str) -> float:
    """A document's number as a float, for `json.loads(parse_float=..., parse_constant=...)` and
    `tomllib.loads(parse_float=...)`.

    Raises:
        NonFiniteNumberError: `inf`, `nan`, `Infinity`, `NaN`, or a number too large for a float (`1e999`).
    """
    value = float(text)
    if not math.isfinite(value):
        raise NonFiniteNumberError(text)
    return value


def non_finite_problem(path: Path, document: Any, number: str) -> DataFileError:
    """The error of a number `finite_float` refused: the file, the key that holds it (found in `document`, the
    file parsed without the check), the number as written, and what was expected."""
    return DataFileError(path, non_finite_message(_non_finite_key(document, ""), number))


def non_finite_message(key: str | None, number: str) -> str:
    """What is wrong with a number `finite_float` refused: its key (or None) = the number as written, and what was
    expected (the one wording of every JSON and TOML reader)."""
    where = f"{key} = {number}" if key else f"the number {number}"
    return f"{where} is not finite (infinite, NaN or too large for a 64-bit float); expected a finite number"


def non_finite_key(document: Any) -> str | None:
    """The dotted key (`a.b[2]`) of the first number that is not finite in a parsed document, or None."""
    return _non_finite_key(document, "")


def _non_finite_key(value: Any, key: str) -> str | None:
    """The dotted key (`a.b[2]`) of the first non-finite float in a parsed document, or None."""
    if isinstance(value, float):
        return None if math.isfinite(value) else (key or "(the document)")
    if isinstance(value, Mapping):
        items: Any = ((f"{key}.{k}" if key else str(k), v) for k, v in value.items())
    elif isinstance(value, list):
        items = ((f"{key}[{i}]", v) for i, v in enumerate(value))
    else:
        return None
    for name, item in items:
        found = _non_finite_key(item, name)
        if found is not None:
            return found
    return None


def read_json(path: str | Path) -> dict[str, Any]:
    """Read a JSON object, raising DataFileError naming the file on any problem (a number not finite, such as
    `1e999`, `Infinity` or `NaN`, among them: every file this project writes has null there)."""
    path = Path(path)
    text = read_text(path, "a JSON file")
    try:
        payload = json.loads(text, parse_float=finite_float, parse_constant=finite_float)
    except NonFiniteNumberError as exc:
        raise non_finite_problem(path, json.loads(text), exc.text) from None
    except json.JSONDecodeError as exc:
        raise DataFileError(path, f"not valid JSON ({exc.msg} at line {exc.lineno})", exc.lineno) from None
    except RecursionError:
        raise DataFileError(path, "not valid JSON (nested too deeply); expected a JSON object") from None
    if not isinstance(payload, dict):
        raise DataFileError(path, f"expected a JSON object, found {type(payload).__name__}")
    return payload
