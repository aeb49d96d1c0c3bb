"""Synthetic volumes as ``pyvista.ImageData``: ``pv_ambient.datasets.<name>(n=64)``.

Thin wrappers over :mod:`datasets_synthetic` (deterministic, seeded, resolution independent:
fields of world position on the cube [−1, 1]³). Each function returns an ``ImageData`` with one
float32 point array (``"density"``, ``"attenuation"`` or ``"signal"``) set active, values in
[0, 1]. :func:`suggested_style` gives the rendering defaults that suit each volume (``cmap``,
``clim``, ``opacity``, ``density_scale``), usable as ``TransferFunction(**style)``.

==================  =======  =================================================================
name                default  what it is
==================  =======  =================================================================
``supernova``       64³      turbulent spherical shell, faint interior, dense core (``density``)
``cloud``           64³      fBm cloud, zero at the domain faces (``density``)
``smoke_plume``     64³      plume rising along +z (``density``)
``ct_phantom``      64³      3D Shepp–Logan-like head phantom (``attenuation``)
``marschner_lobb``  41³      Marschner–Lobb test signal (``signal``)
``haze``            64³      smooth fBm haze filling the cube, zero at the faces (``density``)
``blob``            64³      compact dense object, a lumpy ellipsoid (``density``)
==================  =======  =================================================================

Examples
--------
>>> from pv_ambient import datasets
>>> grid = datasets.cloud(n=16)
>>> grid.dimensions, grid.active_scalars_name
((16, 16, 16), 'density')
>>> sorted(datasets.suggested_style("cloud"))
['clim', 'cmap', 'density_scale', 'opacity']
"""

from __future__ import annotations

import datasets_synthetic as _ds

NAMES = tuple(_ds.names())
"""Names of the synthetic volumes (also accepted by the JSON scene format's ``{"dataset": ...}``)."""


def to_image_data(volume):
    """A :class:`datasets_synthetic.SyntheticVolume` as a ``pyvista.ImageData`` (point data)."""
    import pyvista as pv

    grid = pv.ImageData(dimensions=volume.dimensions, spacing=volume.spacing, origin=volume.origin)
    grid.point_data[volume.scalars_name] = volume.values.ravel(order="F")
    grid.set_active_scalars(volume.scalars_name)
    return grid


def load(name, n=64, seed=0):
    """Volume ``name`` (one of :data:`NAMES`) with ``n`` points per axis (int or 3 ints) and ``seed``.

    ``seed`` is ignored by ``marschner_lobb`` (no noise). Raises ``ValueError`` naming the
    available volumes for an unknown name.
    """
    return to_image_data(_ds.load(name, n=n, seed=seed))


def suggested_style(name) -> dict:
    """Rendering defaults of volume ``name``: ``cmap``, ``clim``, ``opacity``, ``density_scale``.

    >>> from pv_ambient import datasets
    >>> datasets.suggested_style("supernova")["cmap"]
    'inferno'
    """
    return _ds.style(name)


def supernova(n=64, seed=0):
    """Turbulent supernova-like shell with a dense core (point array ``"density"`` in [0, 1])."""
    return load("supernova", n=n, seed=seed)


def cloud(n=64, seed=0):
    """fBm cloud, exactly zero on the domain faces (point array ``"density"`` in [0, 1])."""
    return load("cloud", n=n, seed=seed)


def smoke_plume(n=64, seed=0):
    """Smoke plume rising along +z (point array ``"density"`` in [0, 1])."""
    return load("smoke_plume", n=n, seed=seed)


def ct_phantom(n=64, seed=0):
    """CT-like head phantom (point array ``"attenuation"`` in [0, 1]; HU ≈ 2000·v − 1000)."""
    return load("ct_phantom", n=n, seed=seed)


def marschner_lobb(n=41):
    """Marschner–Lobb signal (point array ``"signal"`` in [0, 1])."""
    return load("marschner_lobb", n=n)


def haze(n=64, seed=0):
    """Smooth haze filling the cube, denser near the floor, 0 at the faces (``"density"`` in [0, 1])."""
    return load("haze", n=n, seed=seed)


def blob(n=64, seed=0):
    """Compact, nearly uniform dense object with a lumpy surface (``"density"`` in [0, 1])."""
    return load("blob", n=n, seed=seed)


__all__ = ["NAMES", "blob", "cloud", "ct_phantom", "haze", "load", "marschner_lobb", "smoke_plume", "suggested_style",
           "supernova", "to_image_data"]
