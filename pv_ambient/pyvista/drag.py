"""The ray step of an interactive drag (docs/jupyter.rst, "Server rendering"): while the camera
is dragged the picture is rendered at a longer ray step, chosen so that a frame fits the time the
render window asks for, as VTK's ``AutoAdjustSampleDistances`` does for its own mappers; and the
window drawn without multisampling meanwhile (:func:`drag_multisamples`).
"""

from __future__ import annotations

#: A render window asking for at least this many frames per second is drawing an interactive frame
#: (a camera drag): VTK's interactors ask for 15 during a drag and 0.0001 when the camera rests.
MOVING_RATE = 1.0

#: A drag frame slower than this fraction of the frame time the render window asks for doubles its
#: ray step (up to ``interactive_step``); one whose predicted time at half the step — the frame
#: plus its ray cast once more, the ray cast's samples doubling — is below ``2·STEP_SHRINK`` of it
#: halves the step (a frame whose time is all ray cast: below ``STEP_SHRINK`` of it).
STEP_GROW = 1.0
STEP_SHRINK = 0.45


def first_factor(rest_seconds, resolution, budget, cap):
    """The first drag frame's ray step, in resting steps: a ray cast costs about its pixels times
    its samples, so a frame at ``resolution`` of the window per axis and ``k`` resting steps takes
    about ``rest_seconds · resolution² / k``. Returns the smallest power of two ``k ≤ cap`` that
    brings it within ``budget`` seconds (``cap`` when none does).

    Examples
    --------
    >>> from pv_ambient.pyvista.drag import first_factor
    >>> first_factor(1.0, 0.5, 0.1, 16)   # 0.25 s at the resting step: 4 steps make 0.0625 s
    4
    >>> first_factor(1.0, 0.5, 0.01, 16)  # never within 10 ms: the cap
    16
    """
    predicted = rest_seconds * resolution ** 2
    k = 1
    while predicted / k > STEP_GROW * budget and 2 * k <= cap:
        k *= 2
    return k


def adapted_factor(factor, seconds, budget, cap, cast=None):
    """The next drag frame's ray step after one at ``factor`` resting steps took ``seconds``, of
    which ``cast`` the ray cast (all of it when None): doubled while frames are slower than
    ``budget`` (up to ``cap``), halved when the frame at half the step, ``seconds + cast``, would
    take less than ``2·STEP_SHRINK`` of it. Why the ray cast apart: the rest of a frame (the
    texture, VTK's own render) does not grow with the samples, and a draft frame's ray cast is
    short next to it.

    Examples
    --------
    >>> from pv_ambient.pyvista.drag import adapted_factor
    >>> adapted_factor(2, 0.2, 0.066, 16), adapted_factor(2, 0.01, 0.066, 16), adapted_factor(16, 0.2, 0.066, 16)
    (4, 1, 16)
    >>> adapted_factor(16, 0.035, 0.066, 16), adapted_factor(16, 0.035, 0.066, 16, cast=0.019)
    (16, 8)
    """
    if seconds > STEP_GROW * budget and 2 * factor <= cap:
        return 2 * factor
    if seconds + (seconds if cast is None else cast) < 2.0 * STEP_SHRINK * budget and factor > 1:
        return factor // 2
    return factor


class DragStep:
    """The drag-step policy of :class:`~pv_ambient.pyvista.plotter.AmbientVolume` (its base): reads
    ``moving``, ``model``, ``options``, ``renderer``, ``plotter``, ``interactive_resolution``,
    ``interactive_step``, and keeps ``step_factor``, ``rest_seconds`` and ``dragged``."""

    @property
    def _step_adapts(self) -> bool:
        """Whether the ray step follows the frame time now: the camera moves, the model ray-casts."""
        return self.moving and self.model != "path_traced"

    def _moving_step(self):
        """The ray step of a drag frame (``step_factor`` resting steps), or None: the resting step."""
        if not self._step_adapts or self.step_factor == 1:
            return None
        step = self.options.get("step")
        if step is None:
            step = self.renderer.default_step(self.options.get("quality", "balanced"))
        return step * self.step_factor

    def _first_drag_step(self):
        """At the first drag frame: the step predicted from the resting picture (:func:`first_factor`)."""
        if self.dragged or not self._step_adapts:
            return
        self.dragged = True
        if self.rest_seconds:
            self.step_factor = first_factor(self.rest_seconds, self.interactive_resolution, self._budget(),
                                            self.interactive_step)

    def _adapt_step(self, seconds, cast=None):
        """After a drag frame that took ``seconds``, ``cast`` of it the ray cast: the next frame's
        step (:func:`adapted_factor`)."""
        if self._step_adapts:
            self.step_factor = adapted_factor(self.step_factor, seconds, self._budget(), self.interactive_step, cast)

    def _budget(self):
        return 1.0 / self.plotter.ren_win.GetDesiredUpdateRate()


def drag_multisamples(window, moving, held):
    """Render window ``window``'s multisampling for this frame, and the setting held back (returned;
    None when none is): a drag frame (``moving``) renders without it, the resting frame with the
    window's own (docs/guide.rst, "In a plotter"). The picture is a textured plane, smoothed by the
    ray cast; with a software OpenGL (Mesa's llvmpipe, a server without a GPU) 4× multisampling is
    most of the window's time per frame. Other meshes' edges alias until the camera rests."""
    if window is None:
        return held
    if moving:
        if held is None and window.GetMultiSamples() > 0:
            held = window.GetMultiSamples()
            window.SetMultiSamples(0)
    elif held is not None:
        window.SetMultiSamples(held)
        held = None
    return held
