"""Deterministic procedural volumes for tests, examples, the demo and the benchmarks.

numpy only (imports without pyvista, vtk or numba); :mod:`pv_ambient.datasets` wraps them into
``pyvista.ImageData``.

Every volume is a function of world position on the cube [−1, 1]³, sampled at the points
``origin + (i, j, k) * spacing`` with ``origin = (−1, −1, −1)`` and ``spacing = 2/(n − 1)`` per axis
(``n`` an int or ``(nx, ny, nz)``; the domain stays [−1, 1]³, so a non-cubic ``n`` means anisotropic
spacing). Resolutions therefore agree exactly at shared world points, and ``seed`` (a non-negative
int) fixes the noise: same seed, same bytes. Values are float32, shape ``(nx, ny, nz)``, indexed
``[i, j, k]`` with x = ``origin[0] + i * spacing[0]``.

==================  =======  ============  ===========================================================
name                default  values        meaning
==================  =======  ============  ===========================================================
``supernova``       64³      [0, 1]        density of a turbulent spherical shell (fBm-perturbed
                                           radius ≈ 0.6 and clumps), faint interior, dense core
``cloud``           64³      [0, 1]        density of an fBm cloud, exactly 0 at the domain faces
``smoke_plume``     64³      [0, 1]        density of a plume rising along +z: widening, wandering,
                                           turbulent, thinning with height
``ct_phantom``      64³      [0, 1]        normalised attenuation of a modified 3D Shepp–Logan head:
                                           skull 1, brain ≈ 0.2 (textured), ventricles 0, lesions
                                           0.3, 4 dense inclusions 0.85 (HU ≈ 2000·v − 1000)
``marschner_lobb``  41³      [0, 1]        Marschner–Lobb signal, f_M = 6, α = 0.25 (closed form)
``haze``            64³      [0, 1]        density of a smooth fBm haze filling the whole cube,
                                           denser near the floor, 0 at the domain faces
``blob``            64³      [0, 1]        density of a compact dense object: a lumpy ellipsoid
                                           (semi-axes ≈ 0.6, 0.55, 0.5), ≈ 0.9 inside, 0 outside
==================  =======  ============  ===========================================================

Each generator returns a :class:`SyntheticVolume` carrying suggested rendering defaults
(``cmap``, ``clim``, ``opacity`` name as in ``Plotter.add_volume``, and ``density_scale``: σ_t in
1/world-unit at opacity 1, giving an optical depth of a few units across the object).
Noise is seeded gradient noise / fBm on a hashed lattice (:mod:`datasets_synthetic.noise`);
256³ volumes generate in about a second.

>>> import datasets_synthetic as ds
>>> ds.names()
['supernova', 'cloud', 'smoke_plume', 'ct_phantom', 'marschner_lobb', 'haze', 'blob']
>>> vol = ds.load("cloud", n=32, seed=1)
>>> vol.values.shape, vol.values.dtype.name
((32, 32, 32), 'float32')
"""

from __future__ import annotations

from .noise import fbm, fbm_grid, gradient_noise
from .volumes import (
    STYLES,
    SyntheticVolume,
    blob,
    cloud,
    ct_phantom,
    haze,
    marschner_lobb,
    marschner_lobb_formula,
    smoke_plume,
    supernova,
)

REGISTRY = {
    "supernova": supernova,
    "cloud": cloud,
    "smoke_plume": smoke_plume,
    "ct_phantom": ct_phantom,
    "marschner_lobb": marschner_lobb,
    "haze": haze,
    "blob": blob,
}
# Volumes without noise: they take no seed.
_UNSEEDED = frozenset({"marschner_lobb"})


def names() -> list:
    """Names of the available volumes, in registry order."""
    return list(REGISTRY)


def _check_name(name) -> str:
    if name not in REGISTRY:
        raise ValueError(f"name must be one of {names()}, got {name!r}")
    return name


def load(name: str, n=64, seed: int = 0) -> SyntheticVolume:
    """Generate volume ``name`` with ``n`` points per axis (int or 3 ints) and ``seed``.

    ``seed`` is ignored by volumes without noise (``marschner_lobb``).
    """
    fn = REGISTRY[_check_name(name)]
    return fn(n) if name in _UNSEEDED else fn(n, seed=seed)


def style(name: str) -> dict:
    """Suggested rendering defaults of volume ``name``: cmap, clim, opacity, density_scale."""
    return dict(STYLES[_check_name(name)])


__all__ = [
    "REGISTRY", "STYLES", "SyntheticVolume", "blob", "cloud", "ct_phantom", "fbm", "fbm_grid",
    "gradient_noise", "haze", "load", "marschner_lobb", "marschner_lobb_formula", "names",
    "smoke_plume", "style", "supernova",
]
