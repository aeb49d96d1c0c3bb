"""Transfer functions: scalars → extinction σt, albedo, emission and display colour (docs/transfer_function.rst).

A :class:`TransferFunction` is a *specification*; :meth:`TransferFunction.resolve` turns it into
:class:`Optics`, the arrays the kernels read, once the data (for ``clim=None``) and the grid
(for PyVista's default ``opacity_unit_distance``) are known.

Three ways to build one:

* PyVista habits — ``TransferFunction(cmap="magma", clim=..., opacity="sigmoid",
  opacity_unit_distance=...)``: the colour and opacity functions are built by exactly the code
  ``Plotter.add_volume`` uses (``pyvista.LookupTable`` → ``VolumeProperty``), then read back, so a
  TF and an ``add_volume`` call with the same arguments classify identically.
* :meth:`TransferFunction.from_volume_property` — read back an existing ``vtkVolumeProperty``
  or ``add_volume`` actor (colour TF, scalar opacity, unit distance).
* :meth:`TransferFunction.physical` — point arrays ``sigma_t`` (1/world unit), ``albedo``
  (1 or 3 components) and optionally ``emission`` (RGB radiance) used as they are.

Opacity to extinction: VTK's opacity α is the opacity of a slab one ``unit_distance`` thick, so
``σt = −ln(1 − α)/unit_distance`` (α clipped to 1 − 1e-6 so σt stays finite); with
``density_scale`` instead, ``σt = α · density_scale``.

Scattering and emission: ``albedo`` is a scalar that scales the TF colour (the default, 1.0,
makes the scattering colour the colormap's colour) or an RGB triple used as a constant;
``emission`` likewise (default 0: no emission). The source of the emission–absorption model is
``σt · color`` (Max's model, what VTK renders); the physical models use ``σa · Le`` with
``Le = emission`` (docs/conventions.rst).

Kernels evaluate the TF by a lookup table of ≥ 1024 entries with linear interpolation in the
scalar (post-classification, as VTK with linear interpolation): table columns are
``[σt, albedo rgb, emission rgb, color rgb]``. A physical TF instead stores σt as the
interpolated field and albedo/emission in an auxiliary grid.

NaN policy (``nan_policy``): ``"raise"`` (default) refuses non-finite scalars with an error
that counts them; ``"vacuum"`` treats NaN/±inf voxels as empty space (σt = 0): the TF is then
baked per voxel and the optical properties are interpolated (pre-classification).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from .validation import check_real, check_rgb

ALPHA_MAX = 1.0 - 1e-6
MIN_LUT = 1024
COL_SIGMA, COL_ALBEDO, COL_EMISSION, COL_COLOR = 0, 1, 4, 7
NCOL = 10
MODE_LUT, MODE_GRID = 0, 1


@dataclass(frozen=True, eq=False)
class Optics:
    """Resolved optical properties: what the kernels read (array core, no pyvista).

    Attributes
    ----------
    mode : int
        ``MODE_LUT`` (``field`` holds scalars, classified through ``table``) or ``MODE_GRID``
        (``field`` holds σt, ``aux`` holds albedo rgb and emission rgb per voxel).
    field : numpy.ndarray
        float32 (nx, ny, nz), C-contiguous.
    table : numpy.ndarray
        float32 (N, 10) lookup table (mode LUT); a 2-row identity in mode GRID (unused).
    lut_lo, lut_inv : float
        Scalar of entry 0 and entries per scalar unit: entry = (s − lut_lo)·lut_inv.
    aux : numpy.ndarray
        float32 (nx, ny, nz, 6) albedo rgb + emission rgb (mode GRID), else (1, 1, 1, 6) zeros.
    """

    mode: int
    field: np.ndarray
    table: np.ndarray
    lut_lo: float
    lut_inv: float
    aux: np.ndarray
    sigma_max: float
    albedo_max: float
    emission_max: float
    key: str = field(default="")

    @property
    def has_scattering(self) -> bool:
        return self.albedo_max > 0 and self.sigma_max > 0

    @property
    def has_emission(self) -> bool:
        return self.emission_max > 0 and self.sigma_max > 0

    def sigma_grid(self) -> np.ndarray:
        """σt at every sample (float32), e.g. for summed-area tables and light volumes."""
        if self.mode == MODE_GRID:
            return self.field
        return _lookup(self, self.field, COL_SIGMA, 1)[..., 0]

    def albedo_grid(self) -> np.ndarray:
        """Albedo rgb at every sample, (nx, ny, nz, 3) float32."""
        if self.mode == MODE_GRID:
            return self.aux[..., 0:3]
        return _lookup(self, self.field, COL_ALBEDO, 3)

    def albedo_channel(self, c) -> np.ndarray:
        """Albedo channel ``c`` (0 red, 1 green, 2 blue) at every sample, (nx, ny, nz) float32: one
        channel at a time, for stages that reduce the albedo per channel (the ball grid), so the
        (nx, ny, nz, 3) grid of :meth:`albedo_grid` is never held. A view of ``aux`` in mode GRID
        (read-only use)."""
        if self.mode == MODE_GRID:
            return self.aux[..., c]
        return _lookup(self, self.field, COL_ALBEDO + c, 1)[..., 0]

    def scattering_channel(self, c, sigma) -> np.ndarray:
        """σs of albedo channel ``c`` at every sample, ``sigma`` (σt on the samples, float32) times
        :meth:`albedo_channel`, (nx, ny, nz) float32, a new array: in mode LUT one parallel pass
        (:func:`pv_ambient._kernels.medium.scattering_column`) with no albedo array."""
        sigma = np.asarray(sigma)
        if self.mode == MODE_GRID or sigma.dtype != np.float32 or not sigma.flags.c_contiguous:
            return np.multiply(sigma, self.albedo_channel(c), dtype=np.float32)
        from .._kernels.medium import scattering_column

        out = np.empty(sigma.shape, np.float32)
        scattering_column(np.ascontiguousarray(self.field), self.table, float(self.lut_lo), float(self.lut_inv),
                          int(COL_ALBEDO + c), sigma, out)
        return out

    def albedo_same_as_previous(self) -> tuple:
        """For each albedo channel, whether it equals the channel before it everywhere (channel 0:
        False): a grey albedo reduces one channel and copies it. From the table's columns in mode
        LUT (equal columns give equal lookups), by comparing the channels in mode GRID."""
        if self.mode == MODE_GRID:
            return (False,) + tuple(bool(np.array_equal(self.aux[..., c], self.aux[..., c - 1])) for c in (1, 2))
        t = self.table
        return (False,) + tuple(bool(np.array_equal(t[:, COL_ALBEDO + c], t[:, COL_ALBEDO + c - 1])) for c in (1, 2))

    def albedo_as_colour(self) -> "Optics":
        """The same σt with the colour (the emission–absorption source) replaced by the scattering
        albedo: its emission–absorption image is ``∫ T σt a dt``, the expected albedo at each ray's
        first collision times its coverage (the denoiser's albedo guide)."""
        if self.mode == MODE_GRID:  # physical TF: aux = albedo rgb, emission rgb; EA colour = emission
            aux = self.aux.copy()
            aux[..., 3:6] = self.aux[..., 0:3]
            return dataclasses.replace(self, aux=aux)
        table = self.table.copy()
        table[:, COL_COLOR:COL_COLOR + 3] = self.table[:, COL_ALBEDO:COL_ALBEDO + 3]
        return dataclasses.replace(self, table=table)


def _lookup(optics, s, col, ncomp):
    """The kernels' table lookup (linear interpolation, clamped) of columns ``col … col + ncomp − 1``
    at every sample of the 3-D scalar array ``s``: (nx, ny, nz, ncomp) float32, in parallel."""
    from .._kernels.medium import classify_columns

    out = np.empty(s.shape + (ncomp,), np.float32)
    classify_columns(np.ascontiguousarray(s), optics.table, float(optics.lut_lo), float(optics.lut_inv), int(col),
                     out)
    return out


def _digest(*arrays, extra="") -> str:
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.shape).encode())
        h.update(str(a.dtype).encode())
        h.update(memoryview(a).cast("B"))
    h.update(extra.encode())
    return h.hexdigest()


def _lut_size(n_nodes: int) -> int:
    """Entries so that ``n_nodes`` evenly spaced nodes land exactly on entries, ≥ MIN_LUT."""
    if n_nodes < 2:
        return MIN_LUT
    k = math.ceil((MIN_LUT - 1) / (n_nodes - 1))
    return (n_nodes - 1) * k + 1


def _rgb_or_scale(value, name):
    """(scale, rgb): a scalar scales the TF colour, a triple is a constant colour."""
    if np.ndim(value) == 0:
        return check_real(value, name, lo=0.0), None
    return None, check_rgb(value, name)


class TransferFunction:
    """Map scalars to extinction, albedo, emission and colour.

    Parameters
    ----------
    cmap : str or matplotlib colormap, optional
        Colormap (PyVista's theme default when None).
    clim : (float, float), optional
        Scalar range mapped by the colormap and opacity; the data range when None.
    opacity : str, float or array_like, default: "linear"
        As in :meth:`pyvista.Plotter.add_volume`: a name (``"linear"``, ``"sigmoid"``,
        ``"geom"``, … with ``_r`` to reverse), a constant, or values spread over ``clim``.
    n_colors : int, default: 256
        Number of colormap/opacity nodes, as in ``add_volume``.
    opacity_unit_distance : float, optional
        Thickness of a slab with opacity α (VTK). When neither this nor ``density_scale`` is
        given, PyVista's default ``grid.length / (mean(grid.dimensions) − 1)`` is used.
    density_scale : float, optional
        σt for opacity 1 (σt = α · density_scale); exclusive with ``opacity_unit_distance``.
    albedo : float or RGB, default: 1.0
        Scalar: scattering albedo = albedo · TF colour. RGB triple: constant albedo.
    emission : float or RGB, default: 0.0
        Scalar: emitted radiance = emission · TF colour. RGB: constant emitted radiance.
    flip_scalars : bool, default: False
        Reverse the colormap (as ``add_volume``).
    scalars : str, optional
        Array to classify (the active scalars when None).
    component : int, optional
        Component of a multi-component array (its magnitude when None).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> from pv_ambient import TransferFunction
    >>> grid = pv.ImageData(dimensions=(8, 8, 8))
    >>> grid["density"] = np.linspace(0, 1, grid.n_points)
    >>> tf = TransferFunction(cmap="magma", opacity="linear", density_scale=2.0)
    >>> optics = tf.resolve(grid)
    >>> round(float(optics.sigma_max), 2)  # PyVista's 256-entry "linear" ramp peaks at 0.998
    2.0
    """

    def __init__(self, *, cmap=None, clim=None, opacity="linear", n_colors=256, opacity_unit_distance=None,
                 density_scale=None, albedo=1.0, emission=0.0, flip_scalars=False, scalars=None, component=None):
        if opacity_unit_distance is not None and density_scale is not None:
            raise ValueError("give opacity_unit_distance or density_scale, not both "
                             f"(got {opacity_unit_distance!r} and {density_scale!r})")
        self.kind = "colormap"
        self.cmap = cmap
        self.clim = None if clim is None else self._check_clim(clim)
        self.opacity = opacity
        self.n_colors = int(n_colors)
        if self.n_colors < 2:
            raise ValueError(f"n_colors must be >= 2, got {n_colors!r}")
        self.opacity_unit_distance = (None if opacity_unit_distance is None else
                                      check_real(opacity_unit_distance, "opacity_unit_distance", lo=0.0, lo_open=True))
        self.density_scale = None if density_scale is None else check_real(density_scale, "density_scale", lo=0.0)
        self.albedo = albedo
        self._albedo = _rgb_or_scale(albedo, "albedo")
        if self._albedo[0] is not None and self._albedo[0] > 1:
            raise ValueError(f"albedo must be in [0, 1], got {albedo!r}")
        if self._albedo[1] is not None and np.any(self._albedo[1] > 1):
            raise ValueError(f"albedo components must be in [0, 1], got {albedo!r}")
        self.emission = emission
        self._emission = _rgb_or_scale(emission, "emission")
        self.flip_scalars = bool(flip_scalars)
        self.scalars = scalars
        self.component = component
        self._property = None  # set by from_volume_property
        self._table = None     # set by from_table
        self._physical = None  # set by physical

    @staticmethod
    def _check_clim(clim):
        if np.ndim(clim) == 0:
            c = check_real(clim, "clim")
            clim = (-c, c)
        try:
            lo, hi = (float(x) for x in clim)
        except (TypeError, ValueError):
            raise ValueError(f"clim must be (min, max), got {clim!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
            raise ValueError(f"clim must be finite with min <= max, got {clim!r}")
        return (lo, hi)

    # -- alternative constructors ------------------------------------------------------------
    @classmethod
    def from_volume_property(cls, prop, *, albedo=1.0, emission=0.0, scalars=None, component=None):
        """Read back a ``vtkVolumeProperty`` (or an ``add_volume`` actor / ``pyvista.Volume``).

        Examples
        --------
        >>> import numpy as np, pyvista as pv
        >>> from pv_ambient import TransferFunction
        >>> grid = pv.ImageData(dimensions=(8, 8, 8))
        >>> grid["density"] = np.linspace(0, 1, grid.n_points)
        >>> pl = pv.Plotter(off_screen=True)
        >>> actor = pl.add_volume(grid, cmap="viridis", opacity="sigmoid")
        >>> tf = TransferFunction.from_volume_property(actor)
        >>> tf.kind
        'volume_property'
        """
        if hasattr(prop, "GetProperty") and not hasattr(prop, "GetScalarOpacity"):
            prop = prop.GetProperty()
        if not hasattr(prop, "GetScalarOpacity") or not hasattr(prop, "GetRGBTransferFunction"):
            raise TypeError(f"prop must be a vtkVolumeProperty or a volume actor, got {type(prop).__name__}")
        tf = cls(albedo=albedo, emission=emission, scalars=scalars, component=component)
        tf.kind = "volume_property"
        tf._property = prop
        return tf

    @classmethod
    def from_table(cls, values, *, sigma_t, color=None, albedo=1.0, emission=0.0, scalars=None, component=None):
        """A TF given by explicit nodes: ``sigma_t`` (1/world unit) and ``color`` at scalar ``values``.

        Linear between nodes, clamped outside. Useful without pyvista.

        Examples
        --------
        >>> from pv_ambient import TransferFunction
        >>> tf = TransferFunction.from_table([0.0, 1.0], sigma_t=[0.0, 5.0])
        >>> tf.kind
        'table'
        """
        values = np.asarray(values, np.float64)
        sig = np.asarray(sigma_t, np.float64)
        if values.ndim != 1 or values.size < 2 or np.any(np.diff(values) <= 0) or not np.all(np.isfinite(values)):
            raise ValueError(f"values must be >= 2 finite increasing numbers, got {values!r}")
        if sig.shape != values.shape or np.any(sig < 0) or not np.all(np.isfinite(sig)):
            raise ValueError(f"sigma_t must be {values.size} finite non-negative numbers, got {sigma_t!r}")
        col = np.ones((values.size, 3)) if color is None else np.asarray(color, np.float64)
        if col.shape != (values.size, 3) or np.any(col < 0) or not np.all(np.isfinite(col)):
            raise ValueError(f"color must be {values.size} RGB triples >= 0, got shape {col.shape}")
        tf = cls(albedo=albedo, emission=emission, scalars=scalars, component=component)
        tf.kind = "table"
        tf._table = (values, sig, col)
        return tf

    @classmethod
    def physical(cls, sigma_t="sigma_t", albedo="albedo", emission="emission"):
        """Optical properties given per voxel by named arrays, used as they are.

        ``sigma_t`` (1/world unit, ≥ 0), ``albedo`` (1 or 3 components in [0, 1]) and, if the
        grid has it, ``emission`` (3 components, radiance ≥ 0; absent means none).

        Examples
        --------
        >>> from pv_ambient import TransferFunction
        >>> TransferFunction.physical().kind
        'physical'
        """
        tf = cls()
        tf.kind = "physical"
        tf._physical = (sigma_t, albedo, emission)
        return tf

    @property
    def physical_arrays(self):
        """``(sigma_t, albedo, emission)``: the array names of a :meth:`physical` TF; None for the
        other kinds."""
        return self._physical

    @classmethod
    def from_dict(cls, d: dict) -> "TransferFunction":
        """The JSON scene form (``"kind"``: ``"colormap"`` or ``"physical"``)."""
        d = dict(d)
        kind = d.pop("kind", "colormap")
        if kind == "physical":
            allowed = {"sigma_t", "albedo", "emission"}
            bad = set(d) - allowed
            if bad:
                raise ValueError(f"transfer_function (physical) has unknown keys {sorted(bad)}; allowed: {sorted(allowed)}")
            return cls.physical(**d)
        if kind != "colormap":
            raise ValueError(f"transfer_function kind must be 'colormap' or 'physical', got {kind!r}")
        allowed = {"cmap", "clim", "opacity", "n_colors", "opacity_unit_distance", "density_scale", "albedo",
                   "emission", "flip_scalars", "scalars", "component"}
        bad = set(d) - allowed
        if bad:
            raise ValueError(f"transfer_function has unknown keys {sorted(bad)}; allowed: {sorted(allowed)}")
        return cls(**d)

    def __repr__(self):
        if self.kind == "physical":
            return f"TransferFunction.physical{self._physical}"
        return (f"TransferFunction(kind={self.kind!r}, cmap={self.cmap!r}, clim={self.clim!r}, "
                f"opacity={self.opacity!r}, albedo={self.albedo!r}, emission={self.emission!r})")

    # -- resolution --------------------------------------------------------------------------
    def resolve(self, grid, *, scalars=None, component=None, nan_policy="raise", preference="point") -> Optics:
        """The :class:`Optics` of ``grid`` (a pyvista.ImageData or a :class:`~pv_ambient.inputs.grid.Volume`)."""
        from .grid import Volume, as_float32_c, select_scalars, volume_from_image

        volume = grid if isinstance(grid, Volume) else volume_from_image(grid, preference=preference)
        if nan_policy not in ("raise", "vacuum"):
            raise ValueError(f"nan_policy must be 'raise' or 'vacuum', got {nan_policy!r}")
        if self.kind == "physical":
            return self._resolve_physical(volume, nan_policy)
        s = select_scalars(volume, scalars if scalars is not None else self.scalars,
                           component=component if component is not None else self.component)
        s32 = as_float32_c(s)
        finite = np.isfinite(s32)
        nbad = int(s32.size - np.count_nonzero(finite))
        if nbad and nan_policy == "raise":
            raise ValueError(f"scalars contain {nbad} non-finite values (NaN or inf) of {s32.size}; "
                             "clean them or pass nan_policy='vacuum' to treat them as empty space")
        lo, hi, values, sig, alb, em, col = self._nodes(volume, s32, finite)
        n = _lut_size(values.size) if values.size <= 4096 else values.size
        entries = np.linspace(lo, hi, n)
        table = np.zeros((n, NCOL), np.float32)
        table[:, COL_SIGMA] = np.interp(entries, values, sig)
        for c in range(3):
            table[:, COL_ALBEDO + c] = np.interp(entries, values, alb[:, c])
            table[:, COL_EMISSION + c] = np.interp(entries, values, em[:, c])
            table[:, COL_COLOR + c] = np.interp(entries, values, col[:, c])
        inv = (n - 1) / (hi - lo) if hi > lo else 0.0
        optics = Optics(mode=MODE_LUT, field=s32, table=table, lut_lo=float(lo), lut_inv=float(inv),
                        aux=np.zeros((1, 1, 1, 6), np.float32), sigma_max=0.0, albedo_max=0.0, emission_max=0.0)
        if nbad:
            return self._bake(optics, finite)
        # bounds over the entries the data actually reaches (used by model="auto"): every value is
        # finite here, and the entry index is monotone in the value, so the extremes suffice
        # (in float32, as the elementwise clip of every value was: the same rounding)
        ext = (s32.min(), s32.max()) if s32.size else (np.float32(lo), np.float32(lo))
        x0, x1 = (float(np.clip((v - lo) * inv, 0, n - 1)) for v in ext)
        k0, k1 = int(np.floor(x0)), min(int(np.ceil(x1)), n - 1)
        used = table[k0:k1 + 1]
        sigma_max = float(used[:, COL_SIGMA].max())
        has_sig = used[:, COL_SIGMA] > 0
        albedo_max = float(used[has_sig, COL_ALBEDO:COL_ALBEDO + 3].max()) if has_sig.any() else 0.0
        emission_max = float(used[has_sig, COL_EMISSION:COL_EMISSION + 3].max()) if has_sig.any() else 0.0
        key = _digest(s32, table, extra=f"lut{lo!r}{inv!r}")
        return Optics(mode=MODE_LUT, field=s32, table=table, lut_lo=float(lo), lut_inv=float(inv),
                      aux=optics.aux, sigma_max=sigma_max, albedo_max=albedo_max, emission_max=emission_max,
                      key=key)

    def _nodes(self, volume, s32, finite):
        """Node positions and per-node σt, albedo, emission, colour (float64)."""
        if self.kind == "table":
            values, sig, col = self._table
        elif self.kind == "volume_property":
            values, sig, col = _read_property(self._property, self.clim)
        else:
            values, sig, col = self._colormap_nodes(volume, s32, finite)
        values = np.asarray(values, np.float64)
        lo, hi = float(values[0]), float(values[-1])
        if hi <= lo:  # a single-valued range: widen so the table is well defined
            hi = lo + 1.0
            values = np.array([lo, hi])
            sig = np.repeat(sig[:1], 2)
            col = np.repeat(col[:1], 2, axis=0)
        scale, rgb = self._albedo
        alb = np.clip(col * scale if rgb is None else np.broadcast_to(rgb, col.shape), 0.0, 1.0)
        scale, rgb = self._emission
        em = col * scale if rgb is None else np.broadcast_to(rgb, col.shape).astype(np.float64)
        return lo, hi, values, sig, alb, em, col

    def _colormap_nodes(self, volume, s32, finite):
        import pyvista as pv
        from pyvista.plotting.volume_property import VolumeProperty

        if self.clim is not None:
            clim = self.clim
        else:
            vals = s32[finite]
            if vals.size == 0:
                raise ValueError("scalars have no finite values; cannot infer clim")
            clim = (float(vals.min()), float(vals.max()))
        cmap = self.cmap if self.cmap is not None else pv.global_theme.cmap
        lut = pv.LookupTable()
        cmap_obj = pv.plotting.colors.get_cmap_safe(cmap) if isinstance(cmap, str) else cmap
        if self.flip_scalars:
            cmap_obj = cmap_obj.reversed()
        lut.apply_cmap(cmap_obj, self.n_colors)
        try:
            lut.apply_opacity(self.opacity)
        except (ValueError, TypeError, KeyError) as exc:
            raise ValueError(f"opacity {self.opacity!r} is not valid: {exc}") from None
        lut.scalar_range = clim
        prop = VolumeProperty(lookup_table=lut, opacity_unit_distance=1.0)
        values, alpha, col = _read_property_raw(prop, clim)
        return values, self._sigma_from_alpha(alpha, volume), col

    def _sigma_from_alpha(self, alpha, volume):
        alpha = np.clip(alpha, 0.0, 1.0)
        if self.density_scale is not None:
            return alpha * self.density_scale
        unit = self.opacity_unit_distance
        if unit is None:
            unit = pyvista_default_unit_distance(volume.geometry)
        return -np.log1p(-np.minimum(alpha, ALPHA_MAX)) / unit

    def _bake(self, optics, finite):
        """Pre-classify per voxel (NaN policy 'vacuum'): σt field + albedo/emission grid."""
        s = np.where(finite, optics.field, optics.lut_lo)
        sig = _lookup(optics, s, COL_SIGMA, 1)[..., 0]
        sig[~finite] = 0.0
        aux = np.empty(s.shape + (6,), np.float32)
        aux[..., 0:3] = _lookup(optics, s, COL_ALBEDO, 3)
        aux[..., 3:6] = _lookup(optics, s, COL_EMISSION, 3)
        aux[~finite] = 0.0
        return _grid_optics(np.ascontiguousarray(sig), np.ascontiguousarray(aux))

    def _resolve_physical(self, volume, nan_policy):
        names = self._physical
        arrays = volume.arrays
        for role, nm in zip(("sigma_t", "albedo"), names[:2]):
            if nm not in arrays:
                raise ValueError(f"physical transfer function needs a {volume.association} array "
                                 f"{nm!r} ({role}); available: {sorted(arrays)}")
        sig = np.asarray(arrays[names[0]], np.float32)
        if sig.ndim != 3:
            raise ValueError(f"{names[0]!r} (sigma_t) must have one component, got shape {sig.shape}")
        alb = np.asarray(arrays[names[1]], np.float32)
        if alb.ndim == 3:
            alb = np.repeat(alb[..., None], 3, axis=3)
        if alb.shape[3] != 3:
            raise ValueError(f"{names[1]!r} (albedo) must have 1 or 3 components, got {alb.shape[3]}")
        if names[2] in arrays:
            em = np.asarray(arrays[names[2]], np.float32)
            if em.ndim == 3:
                em = np.repeat(em[..., None], 3, axis=3)
            if em.shape[3] != 3:
                raise ValueError(f"{names[2]!r} (emission) must have 1 or 3 components, got {em.shape[3]}")
        else:
            em = np.zeros(sig.shape + (3,), np.float32)
        finite = np.isfinite(sig) & np.all(np.isfinite(alb), axis=3) & np.all(np.isfinite(em), axis=3)
        nbad = int(finite.size - np.count_nonzero(finite))
        if nbad and nan_policy == "raise":
            raise ValueError(f"physical arrays contain {nbad} voxels with non-finite values; clean them or "
                             "pass nan_policy='vacuum' to treat them as empty space")
        sig = np.where(finite, sig, 0.0).astype(np.float32)
        for nm, a, hi in ((names[0], sig, None), (names[1], alb[finite], 1.0), (names[2], em[finite], None)):
            if a.size and a.min() < 0:
                raise ValueError(f"{nm!r} must be non-negative, got minimum {float(a.min())}")
            if hi is not None and a.size and a.max() > hi:
                raise ValueError(f"{nm!r} must be <= {hi}, got maximum {float(a.max())}")
        aux = np.concatenate([alb, em], axis=3)
        aux[~finite] = 0.0
        return _grid_optics(np.ascontiguousarray(sig), np.ascontiguousarray(aux, dtype=np.float32))


def _grid_optics(sig, aux) -> Optics:
    has = sig > 0
    albedo_max = float(aux[..., 0:3][has].max()) if has.any() else 0.0
    emission_max = float(aux[..., 3:6][has].max()) if has.any() else 0.0
    table = np.zeros((2, NCOL), np.float32)
    table[1, COL_SIGMA] = 1.0
    return Optics(mode=MODE_GRID, field=sig, table=table, lut_lo=0.0, lut_inv=1.0, aux=aux,
                  sigma_max=float(sig.max()) if sig.size else 0.0, albedo_max=albedo_max,
                  emission_max=emission_max, key=_digest(sig, aux, extra="grid"))


def pyvista_default_unit_distance(geometry) -> float:
    """``grid.length / (mean(grid.dimensions) − 1)``: what ``add_volume`` uses by default."""
    b = np.asarray(geometry.bounds).reshape(3, 2)
    length = float(np.linalg.norm(b[:, 1] - b[:, 0]))
    dims = np.asarray(geometry.shape) + (1 if geometry.association == "cell" else 0)
    denom = float(np.mean(dims)) - 1.0
    if length <= 0 or denom <= 0:
        return 1.0
    return length / denom


def _read_property_raw(prop, clim=None):
    """Sample a volume property's colour and opacity functions: (values, alpha, rgb)."""
    ctf = prop.GetRGBTransferFunction(0)
    otf = prop.GetScalarOpacity(0)
    nodes = []
    for fn, width in ((ctf, 6), (otf, 4)):
        for i in range(fn.GetSize()):
            v = [0.0] * width
            fn.GetNodeValue(i, v)
            nodes.append(v[0])
    if not nodes:
        raise ValueError("the volume property has empty colour and opacity functions")
    nodes = np.unique(np.asarray(nodes))
    lo, hi = (float(nodes[0]), float(nodes[-1])) if clim is None else clim
    if hi <= lo:
        hi = lo + 1.0
    inside = nodes[(nodes >= lo) & (nodes <= hi)]
    steps = np.diff(inside)
    uniform = inside.size >= 2 and np.allclose(steps, steps.mean(), rtol=1e-6, atol=0) \
        and np.isclose(inside[0], lo) and np.isclose(inside[-1], hi)
    n = _lut_size(inside.size) if uniform else 4096
    rgb = np.zeros(3 * n)
    alpha = np.zeros(n)
    ctf.GetTable(lo, hi, n, rgb)
    otf.GetTable(lo, hi, n, alpha)
    return np.linspace(lo, hi, n), alpha, rgb.reshape(n, 3)


def _read_property(prop, clim=None):
    values, alpha, rgb = _read_property_raw(prop, clim)
    unit = prop.GetScalarOpacityUnitDistance(0)
    sig = -np.log1p(-np.minimum(np.clip(alpha, 0, 1), ALPHA_MAX)) / unit
    return values, sig, rgb


def as_transfer_function(tf) -> TransferFunction:
    """A TransferFunction from None (PyVista defaults), a TF, a dict, or a volume property/actor."""
    if tf is None:
        return TransferFunction()
    if isinstance(tf, TransferFunction):
        return tf
    if isinstance(tf, dict):
        return TransferFunction.from_dict(tf)
    if hasattr(tf, "GetScalarOpacity") or hasattr(tf, "GetProperty"):
        return TransferFunction.from_volume_property(tf)
    raise TypeError("transfer_function must be a TransferFunction, a dict, a vtkVolumeProperty or a volume "
                    f"actor, got {type(tf).__name__}")
