"""The benchmarks' timing, in one place: the warm-up-then-median rule (:func:`median_time`) and VTK,
the peer every speed figure is a ratio to (:class:`VtkPeer`, :func:`interleaved`).

The peer is VTK's own volume render (``fixed_point`` unless another mapper is asked for) of the
renderer's transfer function, classification, linear interpolation and sample distance
(``pv_ambient.pyvista.vtk_bridge.add_vtk_volume``), off screen, black background. VTK's frame time
drifts by several × on a shared machine, so a benchmark measures it *interleaved* with its own
frames — one VTK frame, then one of ours, and the median of each side (:func:`interleaved`), or
VTK frames right before each timed render as that render's time unit (:meth:`VtkPeer.unit`) — never
once per run.

numpy-free and pyvista imported only by :class:`VtkPeer`, so ``benchmarks/gpu.py`` still runs on
the array core alone.
"""

from __future__ import annotations

import statistics
import time


def median_time(fn, repeats):
    """Median wall time of ``fn(k)`` for k = 1…repeats, after the warm-up ``fn(0)``."""
    fn(0)
    times = []
    for k in range(1, repeats + 1):
        t = time.perf_counter()
        fn(k)
        times.append(time.perf_counter() - t)
    return float(statistics.median(times))


class VtkPeer:
    """VTK's volume render of ``renderer``'s scene, kept open: one frame per :meth:`frame`.

    ``mapper``: VTK's ``"fixed_point"`` (the benchmarks' time unit) or ``"gpu"``. ``read_back``:
    each frame's image is read back inside the clock (a GPU mapper's frame is only finished then)
    and kept as :attr:`image` (H, W, 3) uint8. ``camera``: render ``warm_up`` frames from it now (the
    mapper's set-up), not kept in :attr:`times`. Every later frame's time is kept in :attr:`times`.
    """

    #: Degrees the camera is turned by when a frame asks for the camera of the frame before: VTK
    #: does not render again when nothing changed.
    NUDGE = 0.05

    def __init__(self, grid, renderer, size, step, *, mapper="fixed_point", read_back=False, camera=None,
                 warm_up=1):
        import pyvista as pv
        from pyvista.plotting.utilities import image_from_window

        from pv_ambient.pyvista.vtk_bridge import add_vtk_volume
        from scenes import orbit

        self._orbit, self._read_image = orbit, image_from_window
        self.plotter = pv.Plotter(off_screen=True, window_size=tuple(size))
        self.plotter.set_background("black")
        add_vtk_volume(self.plotter, grid, renderer, step=step, mapper=mapper)
        self.read_back, self.image, self.times = read_back, None, []
        self._last, self._nudged = None, False
        if camera is not None:
            for _ in range(warm_up):
                self.frame(camera)
            self.times.clear()

    def frame(self, camera) -> float:
        """Wall time of one render from ``camera`` (turned by :data:`NUDGE` degrees every other
        time it repeats the last frame's camera)."""
        key = camera.to_dict()
        self._nudged = key == self._last and not self._nudged
        self._last = key
        pl = self.plotter
        (self._orbit(camera, self.NUDGE) if self._nudged else camera).to_vtk(pl.camera)
        pl.renderer.ResetCameraClippingRange()
        t = time.perf_counter()
        pl.ren_win.Render()
        if self.read_back:
            self.image = self._read_image(pl.ren_win, ignore_alpha=True)
        t = time.perf_counter() - t
        self.times.append(t)
        return t

    def unit(self, camera, frames=3) -> float:
        """Median time of ``frames`` frames from ``camera`` rendered now: the time unit of the
        render timed right after them."""
        return float(statistics.median([self.frame(camera) for _ in range(frames)]))

    def median(self) -> float:
        """Median of every frame timed so far (warm-up excluded)."""
        return float(statistics.median(self.times))

    def close(self):
        self.plotter.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def interleaved(peer, ours, peer_camera, repeats):
    """Medians (ours, VTK) over ``repeats`` pairs after a warm-up pair: for k = 0…repeats, one frame
    of ``peer`` from ``peer_camera(k)``, then ``ours(k)``, timed here. ``peer`` None: ours only
    (VTK's median nan)."""
    mine, theirs = [], []
    for k in range(repeats + 1):
        tv = peer.frame(peer_camera(k)) if peer is not None else float("nan")
        if peer is not None and not k:
            peer.times.pop()  # the warm-up frame
        t = time.perf_counter()
        ours(k)
        to = time.perf_counter() - t
        if k:
            mine.append(to)
            theirs.append(tv)
    return float(statistics.median(mine)), float(statistics.median(theirs))
