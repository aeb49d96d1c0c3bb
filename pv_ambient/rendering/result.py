"""RenderResult: linear radiance + alpha, and the explicit conversions to display and PyVista."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..inputs.validation import check_choice, check_real

TONEMAPS = ("clip", "reinhard", "aces")
#: Keywords of :meth:`RenderResult.to_uint8` that a ``display`` mapping may hold (a plotter's
#: ``display=``, a scene file's ``"display"``, ``render_series(display=...)``).
DISPLAY_KEYS = ("exposure", "tonemap", "srgb")
#: ``exposure="auto"``: the AUTO_PERCENTILE-th percentile of the luminance over the pixels the
#: volume covers (alpha > AUTO_ALPHA) is mapped to AUTO_WHITE (below white, so highlights keep
#: their colour): docs/display.rst.
AUTO_PERCENTILE, AUTO_WHITE, AUTO_ALPHA = 99.0, 0.8, 0.05
#: Rec. 709 luminance weights of linear RGB.
LUMINANCE = (0.2126, 0.7152, 0.0722)


def unknown_display_keys(display) -> list:
    """The keys of ``display`` that are not :data:`DISPLAY_KEYS`, sorted (what callers report).

    >>> unknown_display_keys({"exposure": 1, "gamma": 2.2})
    ['gamma']
    """
    return sorted(set(display) - set(DISPLAY_KEYS))


def auto_exposure(radiance, alpha=None) -> float:
    """The exposure (stops) of ``exposure="auto"``: the 99th percentile of the luminance over the
    pixels with ``alpha > 0.05`` (every pixel when none) maps to 0.8; 0 for a black image.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.rendering.result import auto_exposure
    >>> auto_exposure(np.full((4, 4, 3), 0.1))   # 0.1 · 2**3 = 0.8
    3.0
    """
    rad = np.asarray(radiance, dtype=np.float64)
    lum = np.nan_to_num(rad @ np.array(LUMINANCE), nan=0.0, posinf=0.0)
    if alpha is not None and np.any(np.asarray(alpha) > AUTO_ALPHA):
        lum = lum[np.asarray(alpha) > AUTO_ALPHA]
    top = float(np.percentile(lum, AUTO_PERCENTILE)) if lum.size else 0.0
    if not top > 0.0:
        top = float(lum.max()) if lum.size else 0.0  # a few bright pixels on black
    if not top > 0.0:
        return 0.0
    return float(np.log2(AUTO_WHITE / top))


def is_lit_model(model) -> bool:
    """Whether ``model`` (a name from ``metadata["model"]``) uses lights: its default display
    exposure is ``"auto"`` (emission–absorption and ambient occlusion keep VTK's 0)."""
    from .presets import MODEL_SPECS

    spec = MODEL_SPECS.get(model)
    return bool(spec is not None and spec.lit)


def srgb_encode(x):
    """Linear [0, 1] → sRGB-encoded [0, 1] (IEC 61966-2-1)."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def tonemap_values(x, tonemap="clip"):
    """Map linear radiance ≥ 0 to [0, 1]: ``clip``, ``reinhard`` (x/(1+x)) or ``aces`` (Narkowicz fit)."""
    check_choice(tonemap, "tonemap", TONEMAPS)
    x = np.maximum(x, 0.0)
    if tonemap == "reinhard":
        return x / (1.0 + x)
    if tonemap == "aces":
        return np.clip((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)
    return np.clip(x, 0.0, 1.0)


@dataclass(eq=False)
class RenderResult:
    """What a render returns: linear float32 radiance and alpha, top row first (docs/conventions.rst).

    Attributes
    ----------
    radiance : numpy.ndarray
        ``(H, W, 3)`` float32 linear RGB radiance, background included, not premultiplied.
    alpha : numpy.ndarray
        ``(H, W)`` float32, ``1 − transmittance`` along each pixel's ray.
    camera : pv_ambient.inputs.camera.Camera
        The camera the image was rendered with.
    metadata : dict
        Model, timings (s), quality knobs, backend and the like.
    std_error : numpy.ndarray or None
        ``(H, W, 3)`` per-pixel standard error (Monte Carlo models).

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient.rendering.result import RenderResult
    >>> res = RenderResult(np.full((2, 3, 3), 0.5, np.float32), np.ones((2, 3), np.float32), None)
    >>> res.to_uint8()[0, 0].tolist()
    [128, 128, 128]
    """

    radiance: np.ndarray
    alpha: np.ndarray
    camera: object
    metadata: dict = field(default_factory=dict)
    std_error: np.ndarray | None = None

    @property
    def shape(self):
        return self.alpha.shape

    @property
    def window_size(self):
        """``(width, height)``."""
        return (self.alpha.shape[1], self.alpha.shape[0])

    def rgba(self) -> np.ndarray:
        """``(H, W, 4)`` float32: radiance and alpha."""
        return np.concatenate([self.radiance, self.alpha[..., None]], axis=2)

    def __repr__(self):
        m = self.metadata or {}
        w, h = self.window_size
        parts = [f"model={m.get('model', '?')!r}", f"window_size=({w}, {h})"]
        if "lights" in m:
            parts.append(f"lights={m['lights']}")
        if "spp" in m:
            parts.append(f"spp={m['spp']}")
        t = m.get("time_prepare", 0.0) + m.get("time_render", m.get("time", 0.0))
        lum = self.radiance.astype(np.float64) @ np.array(LUMINANCE) if self.radiance.size else np.zeros(1)
        parts += [f"time={t:.3g} s", f"luminance max={float(np.nanmax(lum)) if lum.size else 0.0:.3g}",
                  f"coverage={float(np.mean(self.alpha > 0.5)) if self.alpha.size else 0.0:.0%}"]
        return f"RenderResult({', '.join(parts)})"

    def display_exposure(self, exposure=None) -> float:
        """The exposure in stops that :meth:`to_uint8` applies for ``exposure``.

        None (the default) is ``"auto"`` for the lit models and 0 (VTK's convention) for
        emission–absorption and ambient occlusion; ``"auto"`` is :func:`auto_exposure` of this
        image (computed from the radiance every time: to keep a series of frames steady, resolve it
        once and pass the number); a number is returned as it is.
        """
        if exposure is None:
            exposure = "auto" if is_lit_model((self.metadata or {}).get("model")) else 0.0
        if isinstance(exposure, str):
            if exposure != "auto":
                raise ValueError(f"exposure must be a number of stops or 'auto', got {exposure!r}")
            return auto_exposure(self.radiance, self.alpha)
        return check_real(exposure, "exposure")

    def to_uint8(self, *, exposure=None, tonemap="clip", srgb=False, alpha=False) -> np.ndarray:
        """Display image: ``radiance · 2**exposure`` → tone map → optional sRGB → uint8.

        The lit models' default exposure is ``"auto"`` (since 0.3.0): the 99th percentile of
        the luminance over the volume's pixels is mapped to 0.8 (docs/display.rst), so lights
        of any physical strength give a visible picture; the radiance itself is never changed.
        Emission–absorption and ambient occlusion keep VTK's convention (no exposure, clip, no
        sRGB encoding, in which a colour value is written to the frame buffer as it is) — use
        it to compare with VTK.

        Parameters
        ----------
        exposure : float or "auto", optional
            Exposure in stops; None: ``"auto"`` for lit models, 0 otherwise
            (:meth:`display_exposure`).
        tonemap : {"clip", "reinhard", "aces"}, default: "clip"
        srgb : bool, default: False
            Apply the sRGB transfer curve.
        alpha : bool, default: False
            Return RGBA (alpha channel = ``alpha``) instead of RGB.
        """
        explicit = exposure is not None and not isinstance(exposure, str)
        exposure = self.display_exposure(exposure)
        x = tonemap_values(self.radiance.astype(np.float64) * 2.0 ** exposure, tonemap)
        if explicit and is_lit_model((self.metadata or {}).get("model")):
            _warn_if_black(self, x, exposure)
        if srgb:
            x = srgb_encode(x)
        img = np.round(x * 255.0).astype(np.uint8)
        if alpha:
            a = np.round(np.clip(self.alpha, 0, 1) * 255.0).astype(np.uint8)
            img = np.concatenate([img, a[..., None]], axis=2)
        return img

    def to_image(self):
        """A 2D ``pyvista.ImageData`` (W × H × 1) with point arrays ``radiance`` and ``alpha``.

        VTK images are bottom-row-first, so rows are flipped: point (i, j) is pixel column i,
        row H−1−j.
        """
        import pyvista as pv

        h, w = self.alpha.shape
        img = pv.ImageData(dimensions=(w, h, 1))
        img.point_data["radiance"] = self.radiance[::-1].reshape(-1, 3)
        img.point_data["alpha"] = self.alpha[::-1].reshape(-1)
        img.set_active_scalars("radiance")
        return img

    def to_plane(self, **display):
        """A textured ``pyvista.PolyData`` plane filling the camera's view at the focal plane.

        Displayed with the same camera and window size (and ``lighting=False``), each pixel
        shows exactly its texel. ``display`` keywords go to :meth:`to_uint8`. The texture
        (:meth:`to_texture`) rides along as ``plane.ambient_texture``: pass it to
        ``Plotter.add_mesh(plane, texture=plane.ambient_texture, lighting=False)``.
        """
        import pyvista as pv

        plane = pv.PolyData(self.plane_corners(), faces=[4, 0, 1, 2, 3])
        plane.active_texture_coordinates = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
        pv.set_new_attribute(plane, "ambient_texture", self.to_texture(**display))
        return plane

    def plane_corners(self) -> np.ndarray:
        """``(4, 3)`` world corners of :meth:`to_plane` (lower left, lower right, upper right, upper
        left): the camera's view at the focal plane."""
        cam = self.camera
        fwd, right, up = cam.basis()
        h, w = self.alpha.shape
        if cam.parallel_projection:
            half_h = cam.parallel_scale
            center = np.array(cam.position) + fwd * cam.distance
        else:
            half_h = cam.distance * np.tan(np.radians(cam.view_angle) / 2)
            center = np.array(cam.focal_point)
        half_w = half_h * w / h
        return np.array([center - half_w * right - half_h * up,
                         center + half_w * right - half_h * up,
                         center + half_w * right + half_h * up,
                         center - half_w * right + half_h * up])

    def to_texture(self, **display):
        """A ``pyvista.Texture`` of the display image (nearest-texel, no repeat)."""
        import pyvista as pv

        tex = pv.Texture(np.ascontiguousarray(self.to_uint8(**display)))  # top row first, as screenshots
        tex.interpolate = False
        tex.repeat = False
        return tex

    def save(self, path, **display):
        """Write ``.png`` (display image, ``display`` keywords as :meth:`to_uint8`), ``.npy``
        (linear radiance ``(H, W, 3)`` float32) or ``.npz`` (radiance, alpha, std_error, metadata)."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix == ".png":
            from PIL import Image

            Image.fromarray(self.to_uint8(**display)).save(path)
        elif suffix == ".npy":
            np.save(path, self.radiance.astype(np.float32))
        elif suffix == ".npz":
            extra = {} if self.std_error is None else {"std_error": self.std_error}
            np.savez_compressed(path, radiance=self.radiance, alpha=self.alpha,
                                metadata=np.array(json.dumps(self.metadata, default=str)), **extra)
        else:
            raise ValueError(f"path must end in .png, .npy or .npz, got {path.name!r}")
        return path


def _warn_if_black(result, shown, exposure):
    """Warn when a lit picture displays black at an explicit exposure although its radiance is not
    zero (the issue of physical lights in large world units: 1 W/sr at 300 mm gives ~1e-5)."""
    covered = result.alpha > AUTO_ALPHA
    if not covered.any() or np.max(shown[covered], initial=0.0) * 255.0 >= 0.5:
        return
    peak = float(np.max(result.radiance[covered], initial=0.0))
    if peak > 0.0:
        import warnings

        warnings.warn(f"the picture is black at exposure={exposure:g}: the radiance peaks at {peak:.3g} (lights are "
                      "physical: a point light of intensity I lights a point d world units away with I/d², so "
                      "large world units such as millimetres need large intensities); use exposure='auto' (the "
                      f"default), or about exposure={auto_exposure(result.radiance, result.alpha):.1f}",
                      UserWarning, stacklevel=3)
