"""Generate the visual meshes of the TX200 model and of the forming cell (binary STL, with trimesh).

The shapes are coarse stand-ins (cylinders, capsules, boxes) sized roughly like a Staubli TX200; they are
drawn in each body's own frame, which is the Denavit-Hartenberg frame of Table 3.3 rotated by the joint's
constant angle offset (see `models/README.md`). They are for looking at only: collisions use primitives.

Run from the repository root (writes `models/assets/*.stl` and `models/cell/assets/*.stl`):

    .venv/bin/python models/generate_assets.py

The output is deterministic: running the script again rewrites the committed files byte for byte.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh
from trimesh.creation import annulus, box, capsule, cylinder

MODELS_DIR = Path(__file__).resolve().parent
SECTIONS = 24  # facets around a cylinder: a few hundred faces per mesh keeps the repository small

# Clamp, thesis §2.2: ring blank holder and circular base, inner radius 70, outer 95, height 25 mm.
CLAMP_R_MIN_M = 0.070
CLAMP_R_MAX_M = 0.095
CLAMP_HEIGHT_M = 0.025


def _along(axis: str, start: float, stop: float, radius: float, at: tuple[float, float, float] = (0, 0, 0)):
    """Cylinder of `radius` [m] along body axis `axis` from `start` to `stop` [m], offset by `at` [m]."""
    lo = np.array(at, dtype=float)
    hi = np.array(at, dtype=float)
    index = "xyz".index(axis)
    lo[index] += start
    hi[index] += stop
    return cylinder(radius=radius, segment=np.array([lo, hi]), sections=SECTIONS)


def _capsule_between(p0: tuple[float, float, float], p1: tuple[float, float, float], radius: float):
    """Capsule of `radius` [m] whose segment runs from `p0` to `p1` [m]."""
    a = np.asarray(p0, dtype=float)
    b = np.asarray(p1, dtype=float)
    length = float(np.linalg.norm(b - a))
    transform = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], (b - a) / length)
    transform[:3, 3] = (a + b) / 2.0
    return capsule(height=length, radius=radius, count=[12, 8], transform=transform)


def _box(extents: tuple[float, float, float], center: tuple[float, float, float]):
    """Box with full `extents` [m] centred at `center` [m]."""
    transform = np.eye(4)
    transform[:3, 3] = center
    return box(extents=extents, transform=transform)


def robot_meshes() -> dict[str, trimesh.Trimesh]:
    """Return the visual mesh of each robot body, in that body's frame [m]."""
    parts = {
        # base frame: z up, origin on the floor under joint 1
        "base": [_along("z", 0.0, 0.10, 0.30), _along("z", 0.10, 0.40, 0.23)],
        # link1 frame: origin of the base, turns with joint 1; joint 2 axis through (0.26, 0, 0.64) along y
        "link1": [
            _along("z", 0.40, 0.50, 0.24),
            _box((0.42, 0.40, 0.30), (0.08, 0.0, 0.60)),
            _along("y", -0.22, 0.22, 0.20, at=(0.26, 0.0, 0.64)),
        ],
        # link2 frame: origin on joint 2, z along joint 2, the upper arm along x to the elbow at x = 0.95
        "link2": [
            _capsule_between((0.0, 0.0, 0.0), (0.95, 0.0, 0.0), 0.13),
            _along("z", -0.16, 0.16, 0.19),
            _along("z", -0.15, 0.15, 0.16, at=(0.95, 0.0, 0.0)),
        ],
        # link3 frame: origin on the elbow, z along joint 3, the forearm leaves along +y
        "link3": [
            _along("z", -0.14, 0.14, 0.15),
            _box((0.24, 0.26, 0.24), (0.0, 0.12, 0.0)),
            _along("y", -0.22, 0.0, 0.10),
        ],
        # link4 frame: origin on the elbow, z along the forearm (joint 4); the wrist centre is at z = 0.8
        "link4": [
            _along("z", 0.25, 0.62, 0.11),
            _box((0.20, 0.06, 0.22), (0.0, 0.0, 0.70)),
        ],
        # link5 frame: origin at the wrist centre, z along joint 5, the tool side along +y at q5 = 0
        "link5": [_along("z", -0.09, 0.09, 0.085), _along("y", 0.0, 0.10, 0.075)],
        # link6 frame: origin at the wrist centre, z along the tool; the flange face is at z = 0.19
        "link6": [_along("z", 0.10, 0.17, 0.07), _along("z", 0.17, 0.19, 0.0625)],
    }
    return {name: trimesh.util.concatenate(meshes) for name, meshes in parts.items()}


def cell_meshes() -> dict[str, trimesh.Trimesh]:
    """Return the clamp meshes, in their body frames [m] (z from 0 up to the clamp height)."""
    ring = annulus(r_min=CLAMP_R_MIN_M, r_max=CLAMP_R_MAX_M, height=CLAMP_HEIGHT_M, sections=48)
    ring.apply_translation([0.0, 0.0, CLAMP_HEIGHT_M / 2.0])
    return {"clamp_ring": ring}


def write_all(models_dir: Path = MODELS_DIR) -> list[Path]:
    """Write every mesh as binary STL under `models_dir` and return the paths written."""
    written = []
    for folder, meshes in (
        (models_dir / "assets", robot_meshes()),
        (models_dir / "cell" / "assets", cell_meshes()),
    ):
        folder.mkdir(parents=True, exist_ok=True)
        for name, mesh in sorted(meshes.items()):
            path = folder / f"{name}.stl"
            path.write_bytes(trimesh.exchange.stl.export_stl(mesh))
            written.append(path)
    return written


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else MODELS_DIR
    for written_path in write_all(target):
        print(written_path)
