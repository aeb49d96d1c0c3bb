"""The procedural volumes: each a function of world position sampled at a grid's points.

Every generator evaluates its field at ``x = origin + i·spacing`` on the cube [−1, 1]³
(``origin = −1``, ``spacing = 2/(n−1)`` per axis), so two resolutions agree exactly at the world
points they share. Shapes are built in float64 and returned as float32.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral

import numpy as np

from .noise import fbm, fbm_grid

# Suggested rendering defaults per volume. ``density_scale`` is σ_t (1/world-unit) at opacity 1,
# set so the optical depth along an axis-parallel ray through the object is of order one to a few
# units. Measured at n = 64 (median over axis rays with τ > 0.05, per axis): supernova 2.3–2.6,
# cloud 1.2–1.7, smoke_plume 0.4–0.6, ct_phantom 2.1–2.8, marschner_lobb 3.0–5.7; haze (fills the
# box, a ray crosses all of it) and blob are set the same way, to about 1 and 3.
STYLES = {
    "supernova": dict(cmap="inferno", clim=(0.0, 1.0), opacity="linear", density_scale=12.0),
    "cloud": dict(cmap="bone", clim=(0.0, 1.0), opacity="linear", density_scale=3.0),
    "smoke_plume": dict(cmap="gray", clim=(0.0, 1.0), opacity="linear", density_scale=6.0),
    "ct_phantom": dict(cmap="bone", clim=(0.0, 1.0), opacity="linear", density_scale=8.0),
    "marschner_lobb": dict(cmap="viridis", clim=(0.0, 1.0), opacity="sigmoid", density_scale=3.0),
    "haze": dict(cmap="gray", clim=(0.0, 1.0), opacity="linear", density_scale=1.0),
    "blob": dict(cmap="bone", clim=(0.0, 1.0), opacity="linear", density_scale=3.0),
}


@dataclass(frozen=True, eq=False)
class SyntheticVolume:
    """A sampled procedural volume and suggested rendering defaults.

    Attributes
    ----------
    name : str
        Registry name (``"cloud"``, ...).
    values : numpy.ndarray
        float32, shape ``(nx, ny, nz)``; ``values[i, j, k]`` sits at
        ``origin + (i, j, k) * spacing``.
    origin, spacing : tuple of float
        World position of ``values[0, 0, 0]`` and the point spacing per axis.
    description : str
        What the values mean and their range.
    scalars_name : str
        Name for the point array (``"density"``, ``"attenuation"``, ``"signal"``).
    cmap, clim, opacity :
        Suggested ``Plotter.add_volume`` colour map, scalar range and opacity mapping name.
    density_scale : float
        Suggested extinction σ_t at opacity 1, in 1/world-unit.
    """

    name: str
    values: np.ndarray
    origin: tuple
    spacing: tuple
    description: str
    scalars_name: str = "density"
    cmap: str = "viridis"
    clim: tuple = (0.0, 1.0)
    opacity: str = "linear"
    density_scale: float = 1.0

    @property
    def dimensions(self) -> tuple:
        """Number of points per axis, ``(nx, ny, nz)``."""
        return tuple(self.values.shape)

    def axes(self) -> tuple:
        """World coordinates of the points along x, y and z (three float64 1D arrays)."""
        return tuple(o + np.arange(n) * h for o, n, h in zip(self.origin, self.dimensions, self.spacing))

    def style(self) -> dict:
        """The suggested rendering defaults as a dict (cmap, clim, opacity, density_scale)."""
        return dict(cmap=self.cmap, clim=self.clim, opacity=self.opacity,
                    density_scale=self.density_scale)


# --- helpers -----------------------------------------------------------------------------------

def _shape(n) -> tuple:
    """``n`` (int or 3 ints, each ≥ 2) → (nx, ny, nz)."""
    dims = (n, n, n) if isinstance(n, (Integral, np.integer)) and not isinstance(n, bool) else n
    try:
        dims = tuple(dims)
    except TypeError:
        raise TypeError(f"n must be an int or a sequence of 3 ints, got {type(n).__name__} {n!r}") from None
    if len(dims) != 3 or any(isinstance(d, bool) or not isinstance(d, (Integral, np.integer)) for d in dims):
        raise TypeError(f"n must be an int or a sequence of 3 ints, got {n!r}")
    if min(dims) < 2:
        raise ValueError(f"n must be >= 2 along every axis, got {n!r}")
    return tuple(int(d) for d in dims)


def _seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (Integral, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    return int(seed)


def _grid(n):
    """Shape, origin, spacing and broadcastable world coordinates X, Y, Z of the [−1, 1]³ grid."""
    shape = _shape(n)
    spacing = tuple(2.0 / (d - 1) for d in shape)
    axes = [-1.0 + np.arange(d) * h for d, h in zip(shape, spacing)]
    X, Y, Z = axes[0][:, None, None], axes[1][None, :, None], axes[2][None, None, :]
    return shape, (-1.0, -1.0, -1.0), spacing, axes, (X, Y, Z)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _face_window(values, coords, width):
    """``values`` times a soft window: 1 inside, falling to 0 over the outer ``width`` of each
    face of the cube [-1, 1]³ (``coords``: the X, Y, Z grids)."""
    for c in coords:
        values = values * _smoothstep(0.0, width, 1.0 - np.abs(c))
    return values


def _volume(name, values, origin, spacing, description, scalars_name="density"):
    return SyntheticVolume(name=name, values=np.ascontiguousarray(np.clip(values, 0.0, 1.0), dtype=np.float32),
                           origin=origin, spacing=spacing, description=description,
                           scalars_name=scalars_name, **STYLES[name])


# --- the volumes -------------------------------------------------------------------------------

def supernova(n=64, seed: int = 0) -> SyntheticVolume:
    """Turbulent supernova-remnant shell with a compact hot core; density in [0, 1]."""
    seed = _seed(seed)
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    r = np.sqrt(X * X + Y * Y + Z * Z)
    # Shell radius 0.6 perturbed by low-frequency fBm; Gaussian cross-section of width 0.07.
    radius = 0.6 + 0.35 * fbm_grid(*axes, seed=seed, name="supernova.radius", frequency=1.5, octaves=4)
    shell = np.exp(-(((r - radius) / 0.07) ** 2))
    # Clumpy, filamentary density along the shell; a faint ejecta fill inside it.
    clumps = np.clip(0.5 + 2.2 * fbm_grid(*axes, seed=seed, name="supernova.clumps", frequency=4.0), 0.0, 1.0)
    inside = 0.12 * clumps * _smoothstep(0.05, -0.1, r - radius)
    core = np.exp(-((r / 0.1) ** 2))
    values = shell * (0.2 + 0.8 * clumps) + inside + core
    return _volume("supernova", values, origin, spacing,
                   "Supernova-like remnant: an fBm-perturbed spherical shell (radius ≈ 0.6, "
                   "width ≈ 0.07) with clumpy density, a faint interior and a dense core of "
                   "radius ≈ 0.1 at the origin. Values: density in [0, 1].")


def cloud(n=64, seed: int = 0) -> SyntheticVolume:
    """fBm cumulus-like cloud that fades to exactly 0 at the domain faces; density in [0, 1]."""
    seed = _seed(seed)
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    # A flattened ellipsoid (positive inside), roughened by fBm, then a soft threshold.
    body = 1.0 - np.sqrt((X / 0.75) ** 2 + (Y / 0.75) ** 2 + ((Z + 0.1) / 0.5) ** 2)
    d = body + 0.9 * fbm_grid(*axes, seed=seed, name="cloud", frequency=2.5)
    values = _smoothstep(0.0, 0.3, d)
    values = _face_window(values, (X, Y, Z), 0.2)  # density 0 at the faces
    return _volume("cloud", values, origin, spacing,
                   "fBm cloud: a flattened ellipsoid (semi-axes 0.75, 0.75, 0.5) with turbulent, "
                   "soft edges; density falls to exactly 0 at the domain boundary. "
                   "Values: density in [0, 1].")


def smoke_plume(n=64, seed: int = 0) -> SyntheticVolume:
    """Rising smoke plume along +z: widening, wandering, turbulent, thinning with height."""
    seed = _seed(seed)
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    h = (Z + 1.0) / 2.0  # height above the floor, 0..1
    # Centre line: a drift in +x with height plus a 1D fBm wander that grows with height.
    zs = axes[2]
    wander = [fbm(0.0, 0.0, zs, seed=seed, name=f"smoke_plume.wander_{a}", frequency=1.0, octaves=3)
              for a in "xy"]
    cx = (0.3 * h**2 + 0.6 * h * wander[0][None, None, :])
    cy = 0.6 * h * wander[1][None, None, :]
    width = 0.06 + 0.3 * h
    rho2 = ((X - cx) ** 2 + (Y - cy) ** 2) / width**2
    turb = fbm_grid(*axes, seed=seed, name="smoke_plume", frequency=3.0)
    # Gaussian profile, density thinning with height, turbulence growing with height.
    values = np.exp(-rho2) * np.exp(-1.2 * h) * (1.0 + (0.8 + 2.5 * h) * turb)
    values = 1.1 * values * _smoothstep(-1.0, -0.9, Z)
    return _volume("smoke_plume", values, origin, spacing,
                   "Smoke plume rising along +z from a source near (0, 0, −0.95): Gaussian "
                   "cross-section widening from 0.06 to 0.36, drifting in +x, wandering and "
                   "turbulent, density decaying with height. Values: density in [0, 1].")


# Modified 3D Shepp–Logan (Toft 1996, as in Schabel's phantom3d.m): value change A, semi-axes
# (a, b, c), centre (x0, y0, z0), rotation phi (degrees, about z).
_SHEPP_LOGAN = np.array([
    # A      a       b      c      x0     y0      z0     phi
    [1.0,  0.6900, 0.920, 0.810, 0.00,  0.0000, 0.00,   0.0],   # skull (outer)
    [-0.8, 0.6624, 0.874, 0.780, 0.00, -0.0184, 0.00,   0.0],   # brain (inner)
    [-0.2, 0.1100, 0.310, 0.220, 0.22,  0.0000, 0.00, -18.0],   # ventricles
    [-0.2, 0.1600, 0.410, 0.280, -0.22, 0.0000, 0.00,  18.0],
    [0.1,  0.2100, 0.250, 0.410, 0.00,  0.3500, -0.15,  0.0],   # lesions
    [0.1,  0.0460, 0.046, 0.050, 0.00,  0.1000, 0.25,   0.0],
    [0.1,  0.0460, 0.046, 0.050, 0.00, -0.1000, 0.25,   0.0],
    [0.1,  0.0460, 0.023, 0.050, -0.08, -0.6050, 0.00,  0.0],
    [0.1,  0.0230, 0.023, 0.020, 0.00, -0.6060, 0.00,   0.0],
    [0.1,  0.0230, 0.046, 0.020, 0.06, -0.6050, 0.00,   0.0],
])


def _inside_ellipsoid(X, Y, Z, a, b, c, x0, y0, z0, phi_deg):
    """Boolean mask of points inside an ellipsoid rotated by phi about z around its centre."""
    phi = np.deg2rad(phi_deg)
    dx, dy, dz = X - x0, Y - y0, Z - z0
    u = np.cos(phi) * dx + np.sin(phi) * dy
    v = -np.sin(phi) * dx + np.cos(phi) * dy
    return (u / a) ** 2 + (v / b) ** 2 + (dz / c) ** 2 <= 1.0


def ct_phantom(n=64, seed: int = 0) -> SyntheticVolume:
    """CT-like head phantom: Shepp–Logan ellipsoids, tissue texture and dense inclusions; [0, 1]."""
    seed = _seed(seed)
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    values = np.zeros(shape)
    for A, *params in _SHEPP_LOGAN:
        values += A * _inside_ellipsoid(X, Y, Z, *params)
    # Soft-tissue texture (±0.05) inside the skull's inner surface.
    brain = _inside_ellipsoid(X, Y, Z, *_SHEPP_LOGAN[1, 1:])
    values += brain * 0.25 * fbm_grid(*axes, seed=seed, name="ct_phantom.texture", frequency=6.0, octaves=3)
    # Four small dense (calcification-like) spheres at seeded positions inside the brain.
    rng = np.random.default_rng(seed)
    for _ in range(4):
        centre = rng.uniform(-1.0, 1.0, 3) * (0.4, 0.55, 0.45)
        radius = rng.uniform(0.04, 0.07)
        dense = (X - centre[0]) ** 2 + (Y - centre[1]) ** 2 + (Z - centre[2]) ** 2 <= radius**2
        values = np.where(dense, 0.85, values)
    return _volume("ct_phantom", values, origin, spacing,
                   "CT-like head phantom after the modified 3D Shepp–Logan phantom (ellipsoid "
                   "rotations about z only): skull 1.0, brain ≈ 0.2 with ±0.05 fBm texture, "
                   "ventricles ≈ 0, lesions ≈ 0.3, and 4 seeded dense inclusions 0.85. Values: "
                   "normalised attenuation in [0, 1] (Hounsfield-like: HU ≈ 2000·v − 1000 "
                   "would put air at −1000 and the skull at +1000).",
                   scalars_name="attenuation")


ML_FM, ML_ALPHA = 6.0, 0.25


def marschner_lobb_formula(x, y, z, f_m: float = ML_FM, alpha: float = ML_ALPHA):
    """Marschner & Lobb (1994) test signal at world points; values in [0, 1]."""
    r = np.sqrt(np.asarray(x, dtype=np.float64) ** 2 + np.asarray(y, dtype=np.float64) ** 2)
    rho_r = np.cos(2.0 * np.pi * f_m * np.cos(np.pi * r / 2.0))
    return (1.0 - np.sin(np.pi * np.asarray(z) / 2.0) + alpha * (1.0 + rho_r)) / (2.0 * (1.0 + alpha))


def marschner_lobb(n=41) -> SyntheticVolume:
    """The Marschner–Lobb signal (f_M = 6, α = 0.25) on [−1, 1]³; values in [0, 1]."""
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    return _volume("marschner_lobb", marschner_lobb_formula(X, Y, Z), origin, spacing,
                   "Marschner–Lobb test signal (f_M = 6, α = 0.25): "
                   "(1 − sin(πz/2) + α(1 + cos(2π f_M cos(π r/2)))) / (2(1 + α)), r = √(x² + y²); "
                   "a reconstruction-filter test, usually shown as the 0.5 isosurface. "
                   "Values in [0, 1].", scalars_name="signal")


def haze(n=64, seed: int = 0) -> SyntheticVolume:
    """Smooth haze filling the whole box, denser near the floor; density in [0.05, 1] inside."""
    seed = _seed(seed)
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    # Low-frequency fBm around a level that falls with height (mean ≈ 0.5), never quite clear.
    f = fbm_grid(*axes, seed=seed, name="haze", frequency=1.2, octaves=4)
    values = np.clip(0.5 - 0.2 * Z + 1.6 * f, 0.05, 1.0)
    values = _face_window(values, (X, Y, Z), 0.15)  # density 0 at the faces
    return _volume("haze", values, origin, spacing,
                   "Haze: a smooth, low-frequency fBm density filling the whole cube (level "
                   "0.5 − 0.2 z plus fBm, clipped to [0.05, 1]), falling to exactly 0 over the "
                   "outer 0.15 of each face. Values: density in [0, 1].")


def blob(n=64, seed: int = 0) -> SyntheticVolume:
    """A compact, nearly uniform dense object with a lumpy surface; density in [0, 1]."""
    seed = _seed(seed)
    shape, origin, spacing, axes, (X, Y, Z) = _grid(n)
    # An ellipsoid (semi-axes 0.6, 0.55, 0.5) whose surface is perturbed by low-frequency fBm,
    # with a sharp but smooth edge (0.08 in the body coordinate) and a ±10 % interior texture.
    body = 1.0 - np.sqrt((X / 0.6) ** 2 + (Y / 0.55) ** 2 + (Z / 0.5) ** 2)
    body = body + 0.3 * fbm_grid(*axes, seed=seed, name="blob.surface", frequency=1.5, octaves=3)
    texture = 0.9 + 0.5 * fbm_grid(*axes, seed=seed, name="blob.texture", frequency=4.0, octaves=3)
    values = _smoothstep(0.0, 0.08, body) * np.clip(texture, 0.0, 1.0)
    values = _face_window(values, (X, Y, Z), 0.1)  # density 0 at the faces
    return _volume("blob", values, origin, spacing,
                   "Blob: a compact, nearly uniform dense object — an ellipsoid (semi-axes 0.6, "
                   "0.55, 0.5) with an fBm-perturbed surface and a smooth edge, density ≈ 0.9 "
                   "± 0.1 inside, exactly 0 outside. Values: density in [0, 1].")
