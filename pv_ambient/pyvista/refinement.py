"""Interactive mode's refinement of a Monte Carlo picture (``path_traced``, ``progressive``) while
the camera rests: passes of samples added to one view, averaged, and — for ``progressive`` — shown
as its thresholded or denoised picture (docs/progressive.rst)."""

from __future__ import annotations

import numpy as np

from ..rendering.presets import DEFAULT_SPP
from ..rendering.result import RenderResult
from ..stages.refine import HeldOutPasses


class Refinement:
    """The samples taken so far for one view.

    Parameters
    ----------
    model : {"path_traced", "progressive"}
    options : dict
        The volume's render options (``samples_per_pixel``, ``target_error``, ``seed``,
        ``unbiased``, ``denoise``).
    samples_per_pass : int
        Samples per pixel each pass adds (at least 2: a pass's own variance).
    render : callable
        ``render(camera, size, **options)`` → :class:`~pv_ambient.RenderResult`: the volume's render.
    """

    def __init__(self, model, options, samples_per_pass, render):
        self.model, self.options, self.samples_per_pass = model, options, samples_per_pass
        self._render = render
        self.passes = None  # HeldOutPasses: even and odd passes are denoise's held-out halves
        self.view = None  # (camera, window size) the samples are taken with

    def reset(self):
        """Forget the samples (the camera moved)."""
        self.passes = None

    @property
    def total(self) -> int:
        return int(self.options.get("samples_per_pixel", DEFAULT_SPP))

    def done(self, shown) -> bool:
        """Whether ``samples_per_pixel`` are reached, or the relative error of ``shown`` (the
        picture on screen) is within ``target_error``."""
        if self.passes.all.samples >= self.total:
            return True
        target = self.options.get("target_error")
        return (target is not None and self.passes.all.passes > 1
                and shown.metadata.get("relative_error", np.inf) <= target)

    def add_pass(self, cam, size) -> RenderResult:
        """Render one more pass (the next seed) of the view ``(cam, size)`` — a new view when no
        samples are held — and return the picture of all passes so far."""
        passes = self.passes
        k = 0 if passes is None else passes.all.passes
        done = 0 if passes is None else passes.all.samples
        n = max(2, min(self.samples_per_pass, self.total - done))
        # progressive: averaged first (unbiased), thresholded or denoised after
        extra = {"unbiased": True, "denoise": False} if self.model == "progressive" else {}
        res = self._render(cam, size, samples_per_pixel=n, seed=int(self.options.get("seed", 0)) + k,
                           target_error=None, **extra)
        if passes is None:
            passes = self.passes = HeldOutPasses()
            self.view = (cam, size)
        passes.add(res.radiance, res.std_error, res.alpha, samples=n)
        acc = passes.all
        mean, se, alpha = acc.mean, acc.std_error, acc.alpha
        meta = dict(res.metadata, spp=acc.samples, passes=acc.passes, relative_error=acc.relative_error)
        if self.model == "progressive" and not self.options.get("unbiased", False):
            # the mean of all passes so far, its correction kept where it stands out — or, with
            # denoise, denoised where the held-out halves say it is closer (docs/progressive.rst)
            base = self._render(cam, size, samples_per_pixel=0).radiance  # the view's cached base
            mean, pm = passes.picture(base, denoise=bool(self.options.get("denoise", False)))
            meta.update(pm, denoised=pm["residual"] == "denoised")
        return RenderResult(radiance=mean.astype(np.float32), alpha=alpha.astype(np.float32), camera=cam,
                            metadata=meta, std_error=se.astype(np.float32))
