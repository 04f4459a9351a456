"""The dynamic plant's second sheet law: a contact patch on an elastic-plastic foundation, another form than law 1.

Why: the twin is judged on the plant, and its learner (`twin.process.force.learned`) writes the axial force as
membrane terms read one tool radius from the tip, the form of the plant's law 1 (`twin.lab.dynamic.sheet`). A
plant whose only sheet has the learner's form cannot show what the twin does on a sheet it was not shaped for.
This law pushes back on the tool by another mechanism, with another hardening law and other constants; it shares
no code or constant with the twin (nor with law 1, except the grid's layout and the elastic constants of Al).

* **Formed surface**: a 2-D grid (0.5 mm; `sheet_grid_mm`) of the sheet's committed (plastic) surface, as law 1's,
  but formed by this law's own yielding (`advance`), not by the tool's envelope. The sheet the tool never yielded
  cannot stand as a cliff beside a yielded node: after each yield, no never-yielded node in the tool's reach stays above a
  neighbour by more than h tan 10 deg (`HANG_SLOPE`; a forward and a backward sweep), so the unformed inside of a
  cone or pyramid hangs down with the groove instead of standing as a rigid plateau for the tool to cut (the
  grid's stand-in for law 1's unsupported bottom). Yielded nodes keep their formed shape (a 45 deg wall stays).
  10 deg is this law's choice, not a published constant: 0 deg (the bottom hanging flat) drops the sheet beside
  a single groove to its floor, 45 deg leaves the inside standing as a ridge the tool cuts.
* **Contact patch**: the tool sphere (centre c = tip + R e_z) against every grid node n inside it; the node's
  penetration is d = R - |n - c| (radial, continuous in the tip's position), its pressure acts on the tool along
  the sphere's normal there, (c - n) / |c - n|: a node on a wall ahead pushes the tool back, one beside pushes it
  sideways, one below pushes it up. The force of a node is p A / max(n_z, cos 70 deg), A = h^2 the node's
  projected area (the sphere's surface over it, capped where the sphere turns vertical).
* **Foundation** (elastic, then plastic cap): the sheet under the tool is a plate of the tool's radius R,
  clamped at the patch's rim and wrapped on the sphere. Two compliances in series: the plate's bending, a clamped
  circular plate under uniform pressure deflecting by w = p R^4 / (64 D), D = E t^3 / (12 (1 - nu^2))
  (Timoshenko, Woinowsky-Krieger, "Theory of Plates and Shells", 2nd ed. 1959, Sec. 15), and the membrane cap's
  stretch (Laplace p = 2 N / R for a spherical membrane, Hooke eps = N (1 - nu) / (E t), radial displacement
  w = R eps); k = 1 / (R^4 / (64 D) + (1 - nu) R^2 / (2 E t)) [Pa/m], the plate's term dominating (t << R).
  The sheet yields when the pressure reaches the membrane's: the sheet in ISF deforms in plane strain across
  the wall (Jeswiet et al., CIRP Annals 54/2 (2005) 623-649), its meridional membrane force at yield is
  N = (2/sqrt 3) sigma_f t (von Mises), wrapped on the tool's radius: p_cap = (2/sqrt 3) sigma_f t / R. The
  pressure is p = clip(k (d + tau d'), 0, p_cap): a node pressed past p_cap / k yields, and `advance` lowers it
  to the sphere of radius R - p_cap / k about the tip (the surface is formed permanently); a tool that backs off
  unloads it elastically with k. tau d' is a material damping on the penetration rate, d' the change of d since
  the previous committed tip over the servo tick (`timestep_s`), tau = `DAMPING_TIME_S` (a loss factor of about
  0.01 at the contact's ~100 Hz, tau = eta / (2 pi f); aluminium's own loss factor is 1e-4 to 1e-3, so this is
  the plant's choice, not a measured constant).
* **Hardening**: Swift, sigma_f = K (eps0 + eps)^n with the NUMISHEET'93 square-cup aluminium sheet's constants
  (K = 576.79 MPa, eps0 = 0.01658, n = 0.3593; Makinouchi, Nakamachi, Onate, Wagoner (eds.), "NUMISHEET'93:
  Numerical Simulation of 3-D Sheet Metal Forming Processes", Isehara 1993, benchmark material data; an Al-Mg
  sheet, R_m ~ 283 MPa by the Considere condition, like AA5182-O), scaled by the declared R_m over this law's own
  engineering R_m (K n^n exp(-(n - eps0)) at eps = n - eps0), as law 1 scales its own law. eps is the node's
  thinning strain, eps = ln sqrt(1 + |grad z|^2) (volume constancy: a node lowered vertically thins as its area
  grows), kept as the largest it has been (a history state per node), the slope capped at 45 deg and read over
  `STRAIN_BASE_M` (1 mm, the nearest whole number of grid spacings), not over the grid's own spacing: on a finer
  grid the spacing resolved the tool's cup steeper and the force of a rigid cone grew with it (+20 % at 0.25 mm;
  docs/dynamic-plant.md, the grid); t = t0 exp(-eps).
* **Friction**: Coulomb over the patch: each node's friction mu p A acts against the slip direction projected
  on the sphere's tangent plane at the node. The slip is a 2-D state s = u / delta, u the contact's tangential
  elastic displacement and delta its value at gross slip (Mindlin-Cattaneo partial slip: where the tool turns,
  the contact sticks and its friction turns with the elastic displacement, not at once): each step of the tip
  adds step / delta to s, held to |s| <= 1, so the friction turns over ~delta and reverses over 2 delta, the
  travel at which a Mindlin contact re-slips the other way. delta is this law's own pre-sliding travel (not law
  1's knob `friction_reversal_mm`, which `reversal_m` carries and this law ignores): Mindlin's tangential
  compliance of a circular contact at full slip, delta = 3 mu P (2 - nu) / (16 G a) for a rigid tool on an
  elastic sheet (G = E / (2 (1 + nu))), with P = pi a^2 p the patch's load (K. L. Johnson, "Contact Mechanics",
  Cambridge 1985, Sec. 7.2, the Mindlin-Cattaneo tangential displacement; the formula quoted from memory):
  delta = 3 pi mu a p (2 - nu) / (16 G), taken at the longest patch a = R and the cap pressure of the unstrained
  sheet (`presliding_m`). That is ~0.5 um for the thesis's sheet and tool (mu = 0.1): far less than the plant's
  0.1 mm steps, so on a path with a sharp corner the friction turns within one step. The sheet's other tangential
  compliances (the plate's membrane stretch, ~E t / R^2 per area) give microns too; none comes near 0.1 mm.
* **Springback** (after unclamping): the law's own elastic part: every committed node was left at the elastic
  penetration p_cap / k of its last yield (the plate's and the cap's elastic deflection under the cap pressure),
  and rises by it, never above the flat sheet (z <= 0): ~0.15 mm on flat sheet, ~0.9 mm on a 45 deg wall for the
  thesis's sheet and tool.

Sourced and chosen: the Swift constants, E, nu, the plate and membrane formulas and Mindlin's compliance are
published (each cited above; the Swift constants and Johnson's formula are quoted from memory, not checked
against the printed pages here); the damping time tau (`DAMPING_TIME_S`), the 10 deg hang (`HANG_SLOPE`), the
70 deg cap on a node's area (`MIN_NORMAL_Z`), the 45 deg cap on the slope read for thinning (`MAX_SLOPE`), the
0.5 mm grid and the choice a = R in delta are this law's choices. Nothing here was fitted: the level comes from
the Swift law, the declared t, R, R_m and mu, and the geometry.
"""

from __future__ import annotations

import math

import numpy as np

from twin.lab.dynamic import sheet_patch_kernels as kernels
from twin.lab.dynamic.sheet_grid import GRID_SPACING_M, HALF_SIZE_M, GridSheet, turned
from twin.lab.dynamic.sheet_kernels import turned as turned_in_place  # the travel state turns as law 1's
from twin.process.description import Process

#: NUMISHEET'93 benchmark aluminium sheet, Swift law sigma = K (eps0 + eps)^n: K [MPa], eps0 [-], n [-].
SWIFT_K_MPA, SWIFT_EPS0, SWIFT_N = 576.79, 0.01658, 0.3593
#: Young's modulus [Pa] (SubsTech, "Wrought aluminum-magnesium alloy 5086") and Poisson's ratio [-] (ASM/MatWeb
#: "Aluminum 5086-H116"): the handbook values law 1 also uses.
YOUNGS_MODULUS_PA, POISSON_RATIO = 71.0e9, 0.33
DAMPING_TIME_S = 2e-5  # material damping time tau on the penetration rate [s] (module docstring)
MIN_NORMAL_Z = math.cos(math.radians(70.0))  # least vertical share of the sphere's normal for a node's area [-]
MAX_SLOPE = math.tan(math.radians(45.0))  # steepest slope read for a node's thinning [-]
PLANE = 2.0 / math.sqrt(3.0)  # plane-strain von Mises factor [-]
HANG_SLOPE = math.tan(math.radians(10.0))  # steepest slope of the never-yielded sheet beside a yielded node [-]
STRAIN_BASE_M = 1e-3  # the baseline a node's slope is read over, for its thinning (module docstring) [m]


def swift_mpa(eps: np.ndarray | float) -> np.ndarray:
    """The Swift flow stress [MPa] at true plastic strain `eps` [-] (unscaled)."""
    e = np.maximum(np.asarray(eps, dtype=float), 0.0)
    return SWIFT_K_MPA * (SWIFT_EPS0 + e) ** SWIFT_N


def swift_tensile_strength_mpa() -> float:
    """The Swift law's engineering tensile strength [MPa]: sigma exp(-eps) at necking eps = n - eps0."""
    eps = SWIFT_N - SWIFT_EPS0
    return float(swift_mpa(eps)) * math.exp(-eps)


class PatchSheet(GridSheet):
    """The plant's sheet law 2 (module docstring): contact patch, foundation, yielding, springback. Its per-tick
    `force` and `advance` run compiled (`twin.lab.dynamic.sheet_patch_kernels`); `force_reference` and
    `advance_reference` are the same in Python, and `compiled = False` runs them.

    Args:
        process: The declared sheet and tool: thickness, tool radius, tool friction and R_m (which scales the
            Swift law).
        reversal_m: Law 1's friction-reversal travel [m] (the knob `friction_reversal_mm`), accepted for
            `make_sheet`'s call and not used: this law turns its friction over its own pre-sliding travel
            (`presliding_m`, module docstring).
        timestep_s: The plant's servo tick, between two `advance` calls [s].
        spacing_m: The grid's spacing [m].
    """

    #: Run `force` and `advance` compiled (False: the Python reference).
    compiled: bool = True

    def __init__(self, process: Process, reversal_m: float, timestep_s: float = 1e-3,
                 spacing_m: float = GRID_SPACING_M) -> None:
        self._grid(process, timestep_s, spacing_m)
        self.scale = float(process.tensile_strength_mpa) / swift_tensile_strength_mpa()
        del reversal_m  # law 1's knob; this law's friction turns over `presliding_m`
        self.presliding_m = self._presliding_m()
        self.slip_gain = 1.0 / max(self.presliding_m, 1e-12)  # s = u / delta: each step adds step / delta
        self.rate_gain = DAMPING_TIME_S / self.timestep_s
        self.half = math.ceil(self.radius / self.spacing) + 1
        self.strain_step = max(math.floor(0.5 * STRAIN_BASE_M / self.spacing + 0.5), 1)  # spacings either side
        self.reset()

    def reset(self) -> None:
        """A flat, unstrained sheet, the tool at rest along +x."""
        self.z_m = np.zeros((len(self.y_m), len(self.x_m)))
        self.strain = np.zeros(self.z_m.shape)
        self.yielded = np.zeros(self.z_m.shape, dtype=bool)
        self.slip = np.array([1.0, 0.0])
        self.last = np.array([0.0, 0.0, 1.0])  # previous committed tip [m]: far above the sheet until started

    def start(self, p_sheet_m: np.ndarray, direction: float) -> None:
        """Where the tool starts [m] and the direction along x it starts to travel (+1 or -1)."""
        self.last = np.asarray(p_sheet_m, dtype=float)[:3].copy()
        self.slip = np.array([float(direction), 0.0])

    def _presliding_m(self) -> float:
        """delta [m], the tangential elastic displacement of the contact at gross slip (Mindlin-Cattaneo, module
        docstring): 3 pi mu a p (2 - nu) / (16 G) at a = R and p the unstrained sheet's cap pressure."""
        shear = YOUNGS_MODULUS_PA / (2.0 * (1.0 + POISSON_RATIO))
        cap = float(self.node_law(0.0)[1])
        return 3.0 * math.pi * self.mu * self.radius * cap * (2.0 - POISSON_RATIO) / (16.0 * shear)

    def node_law(self, strain: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Foundation stiffness k [Pa/m] (plate and membrane cap in series) and cap pressure p_cap [Pa] of nodes of
        thinning `strain` [-] (module docstring)."""
        e = np.asarray(strain, dtype=float)
        t = self.t0 * np.exp(-e)
        sigma = self.scale * SWIFT_K_MPA * (SWIFT_EPS0 + e) ** SWIFT_N * 1e6
        r = self.radius
        membrane = 2.0 * YOUNGS_MODULUS_PA * t / ((1.0 - POISSON_RATIO) * r * r)
        plate = 64.0 * YOUNGS_MODULUS_PA * t * t * t / (12.0 * (1.0 - POISSON_RATIO * POISSON_RATIO) * r**4)
        stiffness = 1.0 / (1.0 / membrane + 1.0 / plate)
        return stiffness, PLANE * sigma * t / r

    def force(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """Force of the sheet on the tool [N], (3,), sheet frame, at tip `p_sheet_m` [m]; pure."""
        if self.compiled:
            out = np.empty(3)
            x, y, z = p_sheet_m
            kernels.force(self.z_m, self.strain, self.x_m, self.y_m, self.spacing, self.radius, self.t0, self.scale,
                          self.mu, self.slip, self.last, self.rate_gain, self.half, float(x), float(y), float(z), out)
            return out
        return self.force_reference(p_sheet_m)

    def _box(self, x: float, y: float) -> tuple[slice, slice] | None:
        """The grid rows and columns around (x, y) [m] that a tool sphere can reach; None off the grid."""
        ix = round((x + HALF_SIZE_M) / self.spacing)
        iy = round((y + HALF_SIZE_M) / self.spacing)
        x0, x1 = max(ix - self.half, 0), min(ix + self.half + 1, len(self.x_m))
        y0, y1 = max(iy - self.half, 0), min(iy + self.half + 1, len(self.y_m))
        if x0 >= x1 or y0 >= y1:
            return None
        return slice(y0, y1), slice(x0, x1)

    def force_reference(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """`force` in Python, operation for operation what the compiled kernel does (node by node, vectorised)."""
        x, y, zt = (float(v) for v in p_sheet_m)
        box = self._box(x, y)
        if box is None:
            return np.zeros(3)
        rows, cols = box
        r = self.radius
        z = self.z_m[rows, cols]
        dx = (self.x_m[cols] - x)[None, :] + 0.0 * z
        dy = (self.y_m[rows] - y)[:, None] + 0.0 * z
        dz = z - (zt + r)
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        depth = r - dist
        inside = depth > 0.0
        if not inside.any():
            return np.zeros(3)
        dx, dy, dz, dist, depth = dx[inside], dy[inside], dz[inside], dist[inside], depth[inside]
        lx = (self.x_m[cols] - self.last[0])[None, :] + 0.0 * z
        ly = (self.y_m[rows] - self.last[1])[:, None] + 0.0 * z
        lz = z - (self.last[2] + r)
        before = r - np.sqrt(lx[inside] ** 2 + ly[inside] ** 2 + lz[inside] ** 2)
        stiffness, cap = self.node_law(self.strain[rows, cols][inside])
        p = stiffness * (depth + self.rate_gain * (depth - before))
        p = np.maximum(np.minimum(p, cap), 0.0)
        n = np.stack([-dx / dist, -dy / dist, -dz / dist])
        fn = p * self.spacing * self.spacing / np.maximum(n[2], MIN_NORMAL_Z)
        sx, sy = float(self.slip[0]), float(self.slip[1])
        along = sx * n[0] + sy * n[1]
        mu = self.mu
        return np.array([np.sum(fn * (n[0] - mu * (sx - along * n[0]))),
                         np.sum(fn * (n[1] - mu * (sy - along * n[1]))),
                         np.sum(fn * (n[2] - mu * (-along * n[2])))])

    def advance(self, p_sheet_m: np.ndarray) -> None:
        """Commit: the tool tip passed through `p_sheet_m` [m]: the slip, the yielded surface, the strains."""
        if not self.compiled:
            self.advance_reference(p_sheet_m)
            return
        x, y, z = (float(v) for v in p_sheet_m)
        turned_in_place(self.slip, self.slip_gain, x - float(self.last[0]), y - float(self.last[1]))
        kernels.yield_nodes(self.z_m, self.strain, self.yielded, self.x_m, self.y_m, self.spacing, self.radius, self.t0,
                            self.scale, self.half, self.strain_step, x, y, z)
        self.last = np.array([x, y, z])

    def advance_reference(self, p_sheet_m: np.ndarray) -> None:
        """`advance` in Python, operation for operation what the compiled kernels do."""
        p = np.asarray(p_sheet_m, dtype=float)
        self.slip = turned(self.slip, self.slip_gain * (p[:2] - self.last[:2]))
        self._yield(p)
        self.last = p[:3].copy()

    def _yield(self, p: np.ndarray) -> None:
        """Lower the nodes the tool pressed past the cap to the sphere less the elastic penetration at the cap, then
        update the thinning strain of the nodes around them (central differences over `STRAIN_BASE_M`, the largest
        so far)."""
        box = self._box(float(p[0]), float(p[1]))
        if box is None:
            return
        rows, cols = box
        r = self.radius
        z = self.z_m[rows, cols]
        dx = (self.x_m[cols] - p[0])[None, :] + 0.0 * z
        dy = (self.y_m[rows] - p[1])[:, None] + 0.0 * z
        dz = z - (p[2] + r)
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        stiffness, cap = self.node_law(self.strain[rows, cols])
        reach = r - cap / stiffness
        yielded = dist < reach
        lowered = (p[2] + r) - np.sqrt(np.where(yielded, reach * reach - dx * dx - dy * dy, 0.0))
        z[yielded] = lowered[yielded]
        self.yielded[rows, cols] |= yielded
        ny, nx = self.z_m.shape
        self._hang(rows, cols)
        k = self.strain_step
        j0, j1 = max(rows.start - k, k), min(rows.stop + k, ny - k)
        i0, i1 = max(cols.start - k, k), min(cols.stop + k, nx - k)
        if j0 >= j1 or i0 >= i1:
            return
        zz = self.z_m
        gx = (zz[j0:j1, i0 + k : i1 + k] - zz[j0:j1, i0 - k : i1 - k]) / (2.0 * k * self.spacing)
        gy = (zz[j0 + k : j1 + k, i0:i1] - zz[j0 - k : j1 - k, i0:i1]) / (2.0 * k * self.spacing)
        slope = np.minimum(np.sqrt(gx * gx + gy * gy), MAX_SLOPE)
        e = 0.5 * np.log(1.0 + slope * slope)
        np.maximum(self.strain[j0:j1, i0:i1], e, out=self.strain[j0:j1, i0:i1])

    def _hang(self, rows: slice, cols: slice) -> None:
        """No never-yielded node stands above a neighbour by more than HANG_SLOPE h: a forward then a backward sweep
        over the tool's reach (node by node, as the kernel: the sweeps' order matters)."""
        z = self.z_m
        ny, nx = z.shape
        rise = self.spacing * HANG_SLOPE
        free = self.yielded
        js = range(max(rows.start, 1), min(rows.stop, ny - 1))
        is_ = range(max(cols.start, 1), min(cols.stop, nx - 1))
        for order in (1, -1):
            for j in js[::order]:
                for i in is_[::order]:
                    low = min(min(z[j, i - 1], z[j, i + 1]), min(z[j - 1, i], z[j + 1, i])) + rise
                    if low < z[j, i] and not free[j, i]:
                        z[j, i] = low

    def unloaded_surface(self) -> np.ndarray:
        """The surface after unclamping [m], (ny, nx): each node risen by its elastic penetration at the cap,
        p_cap / k, never above the flat sheet."""
        stiffness, cap = self.node_law(self.strain)
        return np.minimum(self.z_m + cap / stiffness, 0.0)
