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


def read_json(path: str | Path) -> dict[str, Any]:
    """Read a JSON object, raising DataFileError naming the file on any problem."""
    path = Path(path)
    try:
        payload = json.loads(read_text(path, "a JSON file"))
    except json.JSONDecodeError as exc:
        raise DataFileError(path, f"not valid JSON ({exc.msg} at line {exc.lineno})", exc.lineno) from None
    except RecursionError:
        raise DataFileError(path, "not valid JSON (nested too deeply); expected a JSON object") from None
    if not isinstance(payload, dict):
        raise DataFileError(path, f"expected a JSON object, found {type(payload).__name__}")
    return payload
