"""RenderResult: linear radiance + alpha, and the explicit conversions to display and PyVista."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..inputs.validation import check_choice, check_real

TONEMAPS = ("clip", "reinhard", "aces")


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

    def to_uint8(self, *, exposure=0.0, tonemap="clip", srgb=False, alpha=False) -> np.ndarray:
        """Display image: ``radiance · 2**exposure`` → tone map → optional sRGB → uint8.

        The defaults (no exposure, clip, no sRGB encoding) are VTK's convention, in which a
        colour value is written to the frame buffer as it is — use them to compare with VTK.

        Parameters
        ----------
        exposure : float, default: 0.0
            Exposure in stops.
        tonemap : {"clip", "reinhard", "aces"}, default: "clip"
        srgb : bool, default: False
            Apply the sRGB transfer curve.
        alpha : bool, default: False
            Return RGBA (alpha channel = ``alpha``) instead of RGB.
        """
        exposure = check_real(exposure, "exposure")
        x = tonemap_values(self.radiance.astype(np.float64) * 2.0 ** exposure, tonemap)
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
        corners = np.array([center - half_w * right - half_h * up,
                            center + half_w * right - half_h * up,
                            center + half_w * right + half_h * up,
                            center - half_w * right + half_h * up])
        plane = pv.PolyData(corners, faces=[4, 0, 1, 2, 3])
        plane.active_texture_coordinates = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
        pv.set_new_attribute(plane, "ambient_texture", self.to_texture(**display))
        return plane

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
