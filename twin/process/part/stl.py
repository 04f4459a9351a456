"""STL files read from their bytes: binary or ASCII, every malformation refused with the file named.

A binary STL is an 80-byte header, a little-endian uint32 triangle count n and n records of 50 bytes (a normal, three
vertices as float32, a uint16 attribute); its size is exactly 84 + 50 n bytes. Anything else that starts with `solid`
is read as ASCII STL (`facet normal ... / outer loop / vertex x y z (x3) / endloop / endfacet`, any number of
`solid ... endsolid` blocks). The bytes are read here, not by a mesh library's loader, so that no text-encoding
detection (`trimesh`'s optional `charset_normalizer`) runs and no missing optional module can be what the user reads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.base.csvio import read_bytes
from twin.errors import DataFileError

_WHAT = "an STL (binary or ASCII) of the part in millimetres"
_EXPECTED = f"expected {_WHAT}"
#: The largest coordinate an STL may hold [file units, mm]: 100 m, beyond any part a robot forms.
MAX_COORDINATE = 1e5
_BINARY = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])


def read_stl_triangles(path: str | Path) -> np.ndarray:
    """The triangles of an STL file as written (no unit change), shape (n, 3, 3) (n may be 0).

    Raises:
        DataFileError: Missing, unreadable, empty, a truncated binary STL, an ASCII STL with a malformed line (its
            line number named), or neither (naming the file and what was expected).
    """
    path = Path(path)
    data = read_bytes(path, _WHAT)
    if not data.strip():
        raise DataFileError(path, f"is empty (no triangles); {_EXPECTED}")
    if len(data) >= 84:
        count = int(np.frombuffer(data, "<u4", 1, 80)[0])
        if len(data) == 84 + 50 * count:
            return _checked(path, np.frombuffer(data, _BINARY, count, 84)["vertices"].astype(float))
    if data.lstrip()[:5].lower() == b"solid":
        return _checked(path, _ascii(path, data))
    if len(data) < 84:
        raise DataFileError(path, f"{len(data)} bytes that neither start with 'solid' (ASCII STL) nor hold a binary "
                            f"STL's 84-byte header; {_EXPECTED}")
    count = int(np.frombuffer(data, "<u4", 1, 80)[0])
    raise DataFileError(path, f"not an STL: as binary STL its header announces {count} triangles (84 + 50 x {count} "
                        f"= {84 + 50 * count} bytes) but the file has {len(data)} bytes (truncated?), and it does "
                        f"not start with 'solid' (ASCII STL); {_EXPECTED}")


def _checked(path: Path, triangles: np.ndarray) -> np.ndarray:
    """The triangles if every coordinate is a finite number within `MAX_COORDINATE`, else DataFileError."""
    bad = ~(np.abs(triangles) <= MAX_COORDINATE)  # NaN too
    if bad.any():
        facet = int(np.argmax(bad.any(axis=(1, 2))))
        value = float(triangles.reshape(len(triangles), -1)[facet][np.argmax(bad[facet].ravel())])
        raise DataFileError(path, f"triangle {facet + 1}: coordinate {value!r} is not a finite number within "
                            f"{MAX_COORDINATE:g} (100 m in millimetres); {_EXPECTED}")
    return triangles


def _ascii(path: Path, data: bytes) -> np.ndarray:
    """The triangles of an ASCII STL (module docstring); each bad line named."""
    text = data.decode("latin-1")  # names and comments may hold any byte; the numbers are ASCII
    vertices: list[list[float]] = []
    in_loop = -1  # vertices read in the current `outer loop`, or -1 outside one
    for lineno, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        if not words:
            continue
        key = words[0].lower()
        if key == "vertex":
            if in_loop < 0 or in_loop >= 3 or len(words) != 4:
                raise DataFileError(path, f"line {lineno}: {line.strip()[:60]!r}: expected 'vertex x y z', three "
                                    "per 'outer loop'; " + _EXPECTED)
            try:
                vertices.append([float(w) for w in words[1:]])
            except ValueError:
                raise DataFileError(path, f"line {lineno}: {line.strip()[:60]!r}: a coordinate is not a number; "
                                    + _EXPECTED) from None
            in_loop += 1
        elif key == "outer":
            in_loop = 0
        elif key == "endloop":
            if in_loop != 3:
                raise DataFileError(path, f"line {lineno}: a facet with {max(in_loop, 0)} vertices: expected 3 (a "
                                    f"triangle); {_EXPECTED}")
            in_loop = -1
        elif key not in ("solid", "endsolid", "facet", "endfacet"):
            raise DataFileError(path, f"line {lineno}: {line.strip()[:60]!r} is not ASCII STL (expected solid, facet "
                                f"normal, outer loop, vertex, endloop, endfacet, endsolid); {_EXPECTED}")
    if in_loop >= 0:
        raise DataFileError(path, f"ends inside a facet (no 'endloop'): truncated; {_EXPECTED}")
    return np.asarray(vertices, dtype=float).reshape(-1, 3, 3)
