"""The dynamic plant's own sheet: a membrane force on its own formed surface, and its own springback.

Nothing here comes from the twin's force models (no FE history, no fitted field, not Aerens's formula): the
plant forms its own sheet from its own material law, in a form the twin does not have.

* **Formed surface**: a 2-D grid (0.5 mm; `sheet_grid_mm`) of the lower envelope of the tool sphere along the real
  tool-tip path (`advance`), the sheet's loaded shape under the tool (pure geometry; the sheet's sag between
  contours is not modelled).
* **Force: membrane equilibrium across the tool** (the membrane analysis of SPIF: Silva, Skjoedt, Martins,
  Bay, "Revisiting the fundamentals of single point incremental forming by means of membrane analysis", Int J
  Mach Tools Manuf 48 (2008) 73-83: the deforming sheet carries a meridional membrane force sigma_phi t per
  unit width in plane strain). One membrane strip wraps the tool across its travel, from the formed surface on
  its left to the one on its right; each side leaves the tool at its angle alpha_s, the larger of the chord
  atan(rise_s / kR), rise_s the formed surface kR to that side above the tip (0 on flat sheet: the force builds up
  with depth to the tool's flank angle, 45 deg; k, `sheet_side_read_radii`, its angle averaged over a band of
  `sheet_side_read_band` either side of kR), and the formed surface's slope from
  R to 2R (a wall formed by earlier contours: a cone's wall angle), at most `MAX_ANGLE_RAD`. One strip over a
  tool that does not hold it along its length carries one tension on both sides: N = sigma_phi(alpha) t(alpha)
  and the front contact along the travel w = R sin alpha (the front of the sphere against a wall tangent at
  alpha) are the steeper side's, alpha = max(alpha_l, alpha_r): the force on the tool

      F_up = w N (sin alpha_l + sin alpha_r),   F_left = w N (cos alpha_l - cos alpha_r),

  and Coulomb friction against the travel, -mu F_up (mu the process's declared tool friction). The lateral pull
  is towards the flatter side, and it grows as the tool moves towards the steeper one (the chord there rises), so
  a wall does not pull the tool into itself (the lateral stiffness along a pyramid's and a cone's path, corners
  included: tests/test_plant_corner.py).
  *Unsupported bottom*: a side the tool never pressed, across from one it did, is the bottom hanging from the
  wall (a cone's inside; its grid height 0 is not where that sheet is): the strip runs on from the wall flat
  (alpha 0; its horizontal pull is then tan(alpha/2) of F_up, inwards). Which side is formed is read as a
  fraction, not a node: `formed_fraction`, the share of the grid pressed over a disc of radius
  FORMED_PATCH R (a smooth bump weight, so continuous in position), centred FORMED_READ R to each side of the
  committed tip (`advance`; past the tool's own track, which fills about a fifth of either disc); side s is a
  bottom by b_s = FORMED_GAIN (phi_other - phi_s - FORMED_TRACK) clipped to [0, 1] (a difference of a few
  per cent, a stray press such as a lead-in, is no wall) and its angle is (1 - b_s) alpha_s. The same test with
  the disc at 2R drops a side's slope reading where that read lands on the hanging bottom (near a pyramid's
  corner the near disc is on the adjacent side's track, formed, the far read on the bottom: a wall that is not
  there). The fractions, and the wall's slope from R to 2R, are read from the committed tip: which side hangs
  from which, and the wall formed beside the track, are the sheet's state along the track, not a servo tick's
  sub-grid excursion (read from the tip itself, a wall whose slope flattens away from the tool pulled it in).
  *A closed part's inside*: the sheet a closed track (a cone's, a pyramid's) encloses is joined to the clamped
  frame only through that track: it is the bottom, hanging from it, wherever the fraction test reads (near a
  pyramid's corner that test read the adjacent side's track and let the inside go: a wall that is not there).
  `_fill` finds it every FILL_EVERY grid spacings of travel (the unpressed nodes the pressed ones enclose, 4-connected),
  grown by one tool radius (the innermost track's inner half, whose grid heights are the sphere's flank):
  `hanging`. Its share h_s of a side's near disc makes that side a bottom and the other side the wall: b_s =
  max(h_s, (1 - h_o) b_s) (tests/test_plant_corner.py). An open part (a groove) encloses nothing.
  The wall thickness follows the sine law t_s = t0 cos alpha_s (t = t0 sin(90 deg - alpha), Jeswiet, Micari,
  Hirt, Bramley, Duflou, Allwood, "Asymmetric single point incremental forming of sheet metal", CIRP Annals 54/2
  (2005) 623-649), the strain is the plane-strain thinning eps = (2/sqrt 3) ln(t0/t_s) and sigma_phi =
  (2/sqrt 3) sigma(eps) (von Mises, plane strain). The combination is written here; it is not a published
  formula with published constants, and it was not fitted to anything.
* **Material**: the flow curve measured for the thesis's AA5086-H111 (thesis Eq. 1.3, Voce with m = 1/2:
  sigma = 130.2 + 300.37 (1 - exp(-3.94 eps))^0.5 MPa), scaled by the declared R_m over the law's own
  engineering R_m (necking: d sigma / d eps = sigma), so a stronger declared sheet forms harder (the twin's force
  models use R_m alone, not this law); E = 71 GPa
  (SubsTech, "Wrought aluminum-magnesium alloy 5086"), nu = 0.33 (ASM/MatWeb, "Aluminum 5086-H116").
* **Contact: elastic unloading, with the contact's damping.** The step met one radius ahead of the tip, dz; the
  sheet follows a tool that rises above it elastically by its recovery there (`springback_m`, at least
  `MIN_RECOVERY_M`), so the elastic penetration is e = dz + recovery and the sheet's unloading stiffness is
  k = F / recovery (F the membrane force above): the force is k e, up to F (e >= recovery: the sheet flows, the
  force does not depend on dz, a membrane force), and 0 once e <= 0 (the tool left the sheet). The unloading is
  damped as a Hunt-Crossley contact (K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as
  damping in vibroimpact", J Appl Mech 42 (1975) 440-445): k e (1 + 3/2 alpha_hc de/dt), the damping in proportion
  to the elastic force (none at first touch, no pull on a leaving tool), with alpha_hc = 0.2 s/m, inside the
  0.08-0.32 s/m Hunt and Crossley derived from impacts of steel, bronze and ivory (quoted by Marhefka, Orin, "A
  compliant contact model with nonlinear damping for simulation of robotic systems", IEEE Trans SMC-A 29 (1999)
  566-572; restitution 1 - alpha_hc v; the range as remembered from that paper, not re-read here). Not measured for this aluminium (whose bulk loss factor, ~1e-4 in
  Cremer, Heckl, "Structure-borne sound", would damp less still); small either way: at a tip speed of 10 mm/s it
  changes the elastic force by 0.3 %. The rate de/dt is the tip's descent since the committed tick over the
  plant's servo tick `timestep_s` (the sheet is stepped once per tick, `force` then `advance`; the surface
  ahead is taken as still over a tick).
* **Travel**: a 2-D slip state follows the real tip, turning over `reversal_m` of travel (the knob
  `friction_reversal_mm`): friction acts against it, so it needs the tool to move. The heading, across which the
  sides are read and along which the step ahead is met, is a second such state turning over `HEADING_TURN`
  grid spacings (or `reversal_m` if longer): the sides are the formed surface's geometry, which the grid does
  not resolve below its spacing, not the direction of one servo tick's motion. Read across the tick's own
  velocity, a servo-rate vibration faster than the feed flipped the sides every tick and the force fed energy
  into the vibration (a chatter on the 80 mm cone; tests/test_plant_sheet.py's jitter test).
* **Springback** (after unclamping): the formed wall's membrane stress relaxes elastically; a wall of slant
  length D / sin alpha shortens by its plane-strain elastic strain sigma_phi (1 - nu^2) / E, so a point at depth
  D rises by D sigma_phi(alpha) (1 - nu^2) / E, alpha the local slope (Hooke's law on the membrane stress above;
  a local elastic recovery under the tool is not modelled).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from twin.lab.dynamic import sheet_kernels as kernels
from twin.lab.dynamic.sheet_grid import GRID_SPACING_M, HALF_SIZE_M, GridSheet, turned
from twin.lab.dynamic.sheet_material import (
    POISSON_RATIO,
    YOUNGS_MODULUS_PA,
    voce_mpa,
    voce_tensile_strength_mpa,
)
from twin.process.description import Process

MIN_RECOVERY_M = 0.01e-3  # least elastic follow of the sheet behind a rising tool [m]
FORMED_READ = 1.2  # a side's formed fraction is read around this many tool radii across the travel
FORMED_PATCH = 0.6  # over a disc of this many tool radii around it (0.6 R to 1.8 R across the travel)
FORMED_TRACK = 0.05  # a difference in formed fraction below this is no wall across (a stray press, a lead-in) [-]
FORMED_GAIN = 2.0  # a bottom by this times the difference past it (fully one at FORMED_TRACK + 1 / FORMED_GAIN)
FILL_EVERY = 4  # the hanging bottom is found again after this many grid spacings of the tip's travel
HUNT_CROSSLEY_ALPHA_S_PER_M = 0.2  # contact damping of the elastic unloading [s/m] (module docstring)
MAX_ANGLE_RAD = math.radians(70.0)  # a side steeper than this is a step, read as this angle
BAND_READS = 9  # a side's chord angle averaged over a band (`side_band`) is this many reads
HEADING_TURN = 2  # grid spacings of travel over which the heading (sides, step ahead) turns
_PLANE = 2.0 / math.sqrt(3.0)


class PlantSheet(GridSheet):
    """The plant's sheet (module docstring): formed surface, membrane force, springback. Its per-tick `force` and
    `advance` run compiled (`twin.lab.dynamic.sheet_kernels`); `force_reference` and `advance_reference` are the
    same in Python, and `compiled = False` runs them.

    Args:
        process: The declared sheet and tool: thickness, tool radius, tool friction and R_m (which scales the
            thesis's flow curve).
        reversal_m: Tool travel over which the friction and the sides turn with the travel [m].
        timestep_s: The plant's servo tick, between two `advance` calls [s].
        spacing_m: The grid's spacing [m].
        side_read: How far from the tip a side's chord is read, in tool radii [-] (the knob `sheet_side_read_radii`).
        side_band: Half-width of the band its angle is averaged over, in tool radii (`sheet_side_read_band`).
    """

    compiled: bool = True  #: run `force` and `advance` compiled (False: the Python reference)

    def __init__(self, process: Process, reversal_m: float, timestep_s: float = 1e-3,
                 spacing_m: float = GRID_SPACING_M, side_read: float = 1.0, side_band: float = 0.0) -> None:
        self._grid(process, timestep_s, spacing_m)
        self.chord_read_m = side_read * self.radius  # a side's chord read this far from the tip [m]
        self.chord_band_m = side_band * self.radius  # its angle averaged over a band this wide either side [m]
        self.scale = float(process.tensile_strength_mpa) / voce_tensile_strength_mpa()
        self.slip_gain, self.heading_gain = 2.0 / reversal_m, 2.0 / max(HEADING_TURN * self.spacing, reversal_m)
        self.fill_every_m = FILL_EVERY * self.spacing  # the tip's travel between two `_fill`s [m]
        half = math.ceil(self.radius / self.spacing) + 1
        self._offsets = self.spacing * np.arange(-half, half + 1)
        self.reset()

    def reset(self) -> None:
        """A flat sheet, the tool at rest along +x."""
        self.z_m = np.zeros((len(self.y_m), len(self.x_m)))
        self.pressed = np.zeros(self.z_m.shape, dtype=bool)
        self.hanging = np.zeros(self.z_m.shape, dtype=bool)  # the sheet inside the innermost track (`_fill`)
        self._regions = np.array([self.hanging, ~self.hanging])  # the compiled fill's last enclosed and outside nodes
        self._unfilled_m = 0.0  # the tip's travel since `hanging` was found [m]
        self._box = np.array([len(self.y_m), -1, len(self.x_m), -1])  # rows, columns the tool pressed: first, last
        self.slip = np.array([1.0, 0.0])
        self.heading, self.travel = self.slip.copy(), self.slip.copy()
        self._last: np.ndarray | None = None

    def start(self, p_sheet_m: np.ndarray, direction: float) -> None:
        """Where the tool starts [m] and the direction along x it starts to travel (+1 or -1)."""
        self._last = np.asarray(p_sheet_m, dtype=float)[:3].copy()
        self.slip = np.array([float(direction), 0.0])
        self.heading, self.travel = self.slip.copy(), self.slip.copy()

    def membrane_n_per_m(self, alpha: float) -> float:
        """Membrane force per unit width sigma_phi t of a side leaving the tool at `alpha` [rad], in [N/m]."""
        c = math.cos(alpha)
        eps = _PLANE * math.log(1.0 / c)
        return _PLANE * self.scale * float(voce_mpa(eps)) * 1e6 * self.t0 * c

    def springback_m(self, depth_m: float, alpha: float) -> float:
        """Elastic rise [m] of a point at depth `depth_m` [m] on a wall of slope `alpha` [rad]."""
        c = math.cos(alpha)
        sigma_phi = _PLANE * self.scale * float(voce_mpa(_PLANE * math.log(1.0 / c))) * 1e6
        return max(depth_m, 0.0) * sigma_phi * (1.0 - POISSON_RATIO**2) / YOUNGS_MODULUS_PA

    def force(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """Force of the sheet on the tool [N], (3,), sheet frame, at tip `p_sheet_m` [m]; pure."""
        if self.compiled:
            out = np.empty(3)
            x, y, z = p_sheet_m
            last = np.array([x, y, z], dtype=float) if self._last is None else self._last
            kernels.force(self.z_m, self.pressed, self.hanging, self.spacing, self.radius, self.t0, self.scale, self.mu,
                          self.travel, self.slip, last, self.timestep_s, float(x), float(y), float(z), out,
                          self.chord_read_m, self.chord_band_m)
            return out
        return self.force_reference(p_sheet_m)

    def force_reference(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """`force` in Python, operation for operation what the compiled kernel does."""
        x, y, z = (float(v) for v in p_sheet_m)
        r = self.radius
        tx, ty = float(self.travel[0]), float(self.travel[1])
        sides = ((-ty, tx), (ty, -tx))  # left, right of the travel
        met = self.height(x + r * tx, y + r * ty) - z  # the step the tool meets one radius ahead
        # the sides' formed fractions next to the committed tip's own track (near) and under the wall read (far), and
        # how much of the near read is a closed part's inside (hung)
        cx, cy, cz = (x, y, z) if self._last is None else (float(v) for v in self._last)
        near = [self.formed_fraction(cx + FORMED_READ * r * sx, cy + FORMED_READ * r * sy) for sx, sy in sides]
        far = [self.formed_fraction(cx + 2.0 * r * sx, cy + 2.0 * r * sy) for sx, sy in sides]
        hung = [self.hanging_share(cx + FORMED_READ * r * sx, cy + FORMED_READ * r * sy) for sx, sy in sides]
        alpha = [0.0, 0.0]
        for s, o in ((0, 1), (1, 0)):
            chord, slope = self._side_angles(x, y, z, *sides[s], cx, cy)
            # its slope read lands on the hanging bottom; the side is an unsupported bottom itself, flat
            hanging = min(1.0, max(0.0, FORMED_GAIN * (near[o] - far[s] - FORMED_TRACK)))
            bottom = min(1.0, max(0.0, FORMED_GAIN * (near[o] - near[s] - FORMED_TRACK)))
            bottom = max((1.0 - hung[o]) * bottom, hung[s])
            alpha[s] = (1.0 - bottom) * min(max(chord, (1.0 - hanging) * slope), MAX_ANGLE_RAD)
        steep = max(alpha)  # one strip wraps the tool: one tension, the steeper side's, and its front contact
        n, w = self.membrane_n_per_m(steep), r * math.sin(steep)
        up = w * n * (math.sin(alpha[0]) + math.sin(alpha[1]))
        left = w * n * (math.cos(alpha[0]) - math.cos(alpha[1]))
        recovery = max(self.springback_m(-z, steep), MIN_RECOVERY_M)
        elastic = (met + recovery) / recovery  # elastic penetration over the recovery (1: the sheet flows)
        rate = (cz - z) / self.timestep_s  # the penetration rate, the tip's descent since the committed tick [m/s]
        contact = min(1.0, max(0.0, elastic * (1.0 + 1.5 * HUNT_CROSSLEY_ALPHA_S_PER_M * rate)))
        if contact <= 0.0:
            return np.zeros(3)
        friction = -self.mu * up * self.slip
        return contact * np.array([friction[0] - left * ty, friction[1] + left * tx, up])

    def formed_fraction(self, x: float, y: float) -> float:
        """The share [-] of the grid the tool sphere has pressed around (x, y) [m], weighted by the smooth bump
        (1 - (d / rho)^2)^2 over the disc d < rho = FORMED_PATCH R: continuous in (x, y); 0 off the grid."""
        return self._share(self.pressed, x, y, FORMED_PATCH * self.radius)

    def hanging_share(self, x: float, y: float) -> float:
        """The share [-] of the grid around (x, y) [m] that is the hanging bottom (`hanging`), as `formed_fraction`."""
        return self._share(self.hanging, x, y, FORMED_PATCH * self.radius)

    def _side_angles(self, x: float, y: float, z: float, sx: float, sy: float, cx: float, cy: float
                     ) -> tuple[float, float]:
        """Angles [rad] at which the sheet leaves the tool at (x, y, z) towards (sx, sy): the chord to the surface
        `chord_read_m` away (its angle averaged over `BAND_READS` reads `chord_band_m` either side of it, where that
        is not 0), and its slope from R to 2R off the committed tip (cx, cy) (a wall); 0 where falling."""
        r, k, b = self.radius, self.chord_read_m, self.chord_band_m
        n = BAND_READS if b > 0.0 else 1
        reads = [k + b * (2.0 * i - (n - 1)) / max(n - 1, 1) for i in range(n)]
        chord = sum(math.atan2(max(self.height(x + d * sx, y + d * sy) - z, 0.0), d) for d in reads) / n
        w1 = self.height(cx + r * sx, cy + r * sy)
        w2 = self.height(cx + 2.0 * r * sx, cy + 2.0 * r * sy)
        return chord, math.atan2(max(w2 - w1, 0.0), r)

    def advance(self, p_sheet_m: np.ndarray) -> None:
        """Commit: the tool tip passed through `p_sheet_m` [m]: the surface under the sphere, the travel state."""
        if not self.compiled:
            self.advance_reference(p_sheet_m)
            return
        x, y, z = (float(v) for v in p_sheet_m)
        if self._last is not None:
            dx, dy = x - float(self._last[0]), y - float(self._last[1])
            self._unfilled_m += math.hypot(dx, dy)
            kernels.turned(self.slip, self.slip_gain, dx, dy)
            kernels.turned(self.heading, self.heading_gain, dx, dy)
            norm = float(np.hypot(*self.heading))
            if norm > 0.1:
                self.travel = self.heading / norm
        self._last = np.array([x, y, z])
        kernels.press(self.z_m, self.pressed, self._box, self.x_m, self.y_m, self.spacing, self.radius,
                      len(self._offsets) // 2, x, y, z)
        if self._unfilled_m >= self.fill_every_m:
            kernels.fill(self.pressed, self._box, self.hanging, self._regions, self.radius / self.spacing)
            self._unfilled_m = 0.0

    def advance_reference(self, p_sheet_m: np.ndarray) -> None:
        """`advance` in Python, operation for operation what the compiled kernels do."""
        p = np.asarray(p_sheet_m, dtype=float)
        if self._last is not None:
            self._unfilled_m += float(np.hypot(*(p[:2] - self._last[:2])))
            self.slip = turned(self.slip, self.slip_gain * (p[:2] - self._last[:2]))
            self.heading = turned(self.heading, self.heading_gain * (p[:2] - self._last[:2]))
            norm = float(np.hypot(*self.heading))
            if norm > 0.1:
                self.travel = self.heading / norm
        self._last = p[:3].copy()
        self._press(p)
        if self._unfilled_m >= self.fill_every_m:
            self._fill()
            self._unfilled_m = 0.0

    def _fill(self) -> None:
        """The hanging bottom: the nodes within one tool radius of the unpressed ones the pressed ones enclose (not
        joined to the grid's edge, the clamped frame, through unpressed nodes side by side: 4-connected)."""
        self.hanging = np.zeros(self.z_m.shape, dtype=bool)
        j0, j1, i0, i1 = (int(v) for v in self._box)
        reach = self.radius / self.spacing
        grow = 1 + math.ceil(reach)  # outside the pressed nodes' box so grown, every node is free and out of reach
        rows, cols = slice(max(j0 - grow, 0), j1 + grow + 1), slice(max(i0 - grow, 0), i1 + grow + 1)
        pressed = self.pressed[rows, cols]
        enclosed = ndimage.binary_fill_holes(pressed) & ~pressed
        if j1 >= 0 and enclosed.any():
            self.hanging[rows, cols] = ndimage.distance_transform_edt(~enclosed) <= reach

    def _press(self, p: np.ndarray) -> None:
        """Lower the grid to the tool sphere's underside around the tip."""
        ix, iy = round((p[0] + HALF_SIZE_M) / self.spacing), round((p[1] + HALF_SIZE_M) / self.spacing)
        k = len(self._offsets) // 2
        x0, x1 = max(ix - k, 0), min(ix + k + 1, len(self.x_m))
        y0, y1 = max(iy - k, 0), min(iy + k + 1, len(self.y_m))
        if x0 >= x1 or y0 >= y1:
            return
        box = self._box
        box[:] = min(box[0], y0), max(box[1], y1 - 1), min(box[2], x0), max(box[3], x1 - 1)
        dx, dy = self.x_m[x0:x1] - p[0], self.y_m[y0:y1] - p[1]
        r2 = dy[:, None] ** 2 + dx[None, :] ** 2
        inside = r2 < self.radius**2
        under = p[2] + self.radius - np.sqrt(np.where(inside, self.radius**2 - r2, 0.0))
        patch = self.z_m[y0:y1, x0:x1]
        np.minimum(patch, np.where(inside, under, np.inf), out=patch)
        self.pressed[y0:y1, x0:x1] |= inside

    def unloaded_surface(self) -> np.ndarray:
        """The surface after unclamping [m], (ny, nx): each point risen by its springback, never above 0."""
        gy, gx = np.gradient(self.z_m, self.spacing)
        alpha = np.minimum(np.arctan(np.hypot(gx, gy)), MAX_ANGLE_RAD)
        cos = np.cos(alpha)
        sigma_phi = _PLANE * self.scale * voce_mpa(_PLANE * np.log(1.0 / cos)) * 1e6
        rise = -self.z_m * sigma_phi * (1.0 - POISSON_RATIO**2) / YOUNGS_MODULUS_PA
        return np.minimum(self.z_m + rise, 0.0)
