"""The data half of the VAL3 syntax check (`twin.apps.export.val3_check`): a `.dtx` file's declarations, their
types, fields, configurations and fathers, written from the VAL3 reference manual's "Data" chapter for the types
we emit."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from twin.errors import InputError

IDENT = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,14}$")
FIELDS = {
    "frame": ("x", "y", "z", "rx", "ry", "rz"),
    "tool": ("x", "y", "z", "rx", "ry", "rz"),
    "pointRx": ("x", "y", "z", "rx", "ry", "rz"),
    "trsf": ("x", "y", "z", "rx", "ry", "rz"),
    "mdesc": ("accel", "vel", "decel", "tmax", "rmax", "leave", "reach"),
    "num": ("value",),
    "bool": (),  # its value is true or false
    "sio": (),  # its value is a link to a controller socket
    "jointRx": ("j1", "j2", "j3", "j4", "j5", "j6"),  # axis values [deg]: a home, a `herej()` local
}
SIO_LINK = re.compile(r"(Socket|UdpSocket)\\[A-Za-z][A-Za-z0-9_]*")
CONFIG = {
    "shoulder": {"lefty", "righty", "ssame", "sfree"},
    "elbow": {"epositive", "enegative", "esame", "efree"},
    "wrist": {"wpositive", "wnegative", "wsame", "wfree"},
}
BLENDS = {"off", "joint", "Cartesian"}


def val3_error(where: str, message: str) -> InputError:
    return InputError(f"VAL3 {where}: {message}")


def local_name(tag: str) -> str:
    return tag.split("}", 1)[-1]


def check_data(name: str, text: str) -> dict[str, tuple[str, int]]:
    """Check a `.dtx` file; returns data name -> (type, size)."""
    root = ET.fromstring(text)
    if local_name(root.tag) != "Database" or not root.tag.startswith(
        "{http://www.staubli.com/robotics/VAL3/Data/"
    ):
        raise val3_error(name, f"root element is {root.tag}, expected Database in the VAL3 Data namespace")
    declared: dict[str, tuple[str, int]] = {"world": ("frame", 1), "flange": ("tool", 1)}
    fathers: list[tuple[str, str, str]] = []
    for data in root.iter():
        if local_name(data.tag) != "Data":
            continue
        dname, kind, size = data.get("name", ""), data.get("type", ""), data.get("size", "")
        if not IDENT.match(dname) or dname in declared:
            raise val3_error(
                name, f"data name {dname!r} is not a new identifier (letter, then letters/digits/_, <= 15)"
            )
        if kind not in FIELDS:
            raise val3_error(name, f"{dname}: type {kind!r} is not one we emit ({sorted(FIELDS)})")
        if not size.isdigit() or int(size) < 1:
            raise val3_error(name, f"{dname}: size {size!r}, expected a positive integer")
        values = [v for v in data if local_name(v.tag) == "Value"]
        keys = sorted(int(v.get("key", "-1")) for v in values)
        if keys != list(range(int(size))):
            raise val3_error(name, f"{dname}: value keys {keys[:5]}..., expected 0..{int(size) - 1}")
        for value in values:
            where = f"{dname}[{value.get('key')}]"
            if kind == "bool" and value.get("value") not in ("true", "false"):
                raise val3_error(name, f"{where}: value={value.get('value')!r}, expected 'true' or 'false'")
            if kind == "sio" and not SIO_LINK.fullmatch(value.get("link", "")):
                raise val3_error(name, f"{where}: link={value.get('link')!r}, expected Socket\\<name> or "
                            "UdpSocket\\<name> (a socket configured on the controller)")
            for field in FIELDS[kind]:
                try:
                    float(value.get(field, ""))
                except ValueError:
                    raise val3_error(
                        name, f"{where}: field {field}={value.get(field)!r}, expected a number"
                    ) from None
            for field, allowed in CONFIG.items():
                if kind == "pointRx" and value.get(field) not in allowed:
                    raise val3_error(
                        name, f"{where}: {field}={value.get(field)!r}, expected one of {sorted(allowed)}"
                    )
            if kind == "mdesc" and value.get("blend") not in BLENDS:
                raise val3_error(name, f"{where}: blend={value.get('blend')!r}, expected one of {sorted(BLENDS)}")
            if kind in ("frame", "tool", "pointRx"):
                fathers.append((where, kind, value.get("fatherId", "")))
        declared[dname] = (kind, int(size))
    for where, kind, father in fathers:
        match = re.fullmatch(r"([A-Za-z][A-Za-z0-9_]*)\[(\d+)\]", father)
        want = "tool" if kind == "tool" else "frame"
        if not match or declared.get(match.group(1), ("", 0))[0] != want:
            raise val3_error(name, f"{where}: fatherId {father!r} is not an element of a declared {want}")
        if int(match.group(2)) >= declared[match.group(1)][1]:
            raise val3_error(name, f"{where}: fatherId {father!r} is out of range")
    return declared
