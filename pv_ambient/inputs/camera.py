"""Pinhole and parallel cameras with VTK's conventions (docs/conventions.rst "Camera").

For image-plane point (u, v) ∈ [0, 1]² (u right, v down) and aspect = W/H::

    fwd = normalize(focal − position); right = normalize(cross(fwd, up)); up' = cross(right, fwd)
    perspective: dir = normalize(fwd + (2u−1)·tan(fov/2)·aspect·right + (1−2v)·tan(fov/2)·up')
    parallel:    origin = position + (2u−1)·scale·aspect·right + (1−2v)·scale·up',  dir = fwd

``view_angle`` is VTK's vertical angle in degrees; ``parallel_scale`` is half the image height
in world units. Pixel (i, j) (column i, row j from the top) is sampled at its centre
``u = (i + ½)/W``, ``v = (j + ½)/H``. The array-core :class:`Camera` needs neither pyvista nor
vtk; :func:`as_camera` converts PyVista/VTK cameras and plotters. :func:`orbit` gives the cameras
of an orbit movie, each frame of :func:`pv_ambient.render_series` seeing the volume from one of
them (docs/series.rst).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .validation import check_int, check_real, check_vector, check_window_size

#: Index of each camera parameter in the float64 array handed to kernels.
CAM_POS, CAM_FWD, CAM_RIGHT, CAM_UP, CAM_TAN, CAM_ASPECT, CAM_PARALLEL, CAM_SCALE = 0, 3, 6, 9, 12, 13, 14, 15


@dataclass(frozen=True, eq=False)
class Camera:
    """A camera given by plain values (VTK conventions).

    Parameters
    ----------
    position, focal_point, view_up : sequence of float
        World position, the point looked at, and the up direction (need not be orthogonal
        to the view direction; it is orthogonalised as VTK does).
    view_angle : float, default: 30.0
        Vertical field of view in degrees (perspective).
    parallel_projection : bool, default: False
        Orthographic projection with half-height ``parallel_scale``.
    parallel_scale : float, default: 1.0
        Half the image height in world units (parallel projection).

    Examples
    --------
    >>> from pv_ambient.inputs.camera import Camera
    >>> cam = Camera(position=(0, -4, 0), focal_point=(0, 0, 0), view_up=(0, 0, 1))
    >>> cam.project([[0.0, 0.0, 0.0]], (64, 48)).round(3).tolist()
    [[32.0, 24.0]]
    """

    position: tuple
    focal_point: tuple
    view_up: tuple = (0.0, 0.0, 1.0)
    view_angle: float = 30.0
    parallel_projection: bool = False
    parallel_scale: float = 1.0

    def __post_init__(self):
        pos = check_vector(self.position, "camera position")
        foc = check_vector(self.focal_point, "camera focal_point")
        up = check_vector(self.view_up, "camera view_up", nonzero=True)
        # Relative test (no absolute tolerance): a scene is valid at any scale, so a camera 1e-9
        # world units from its focal point is fine when the scene is that small.
        dist = np.linalg.norm(foc - pos)
        if dist == 0.0 or dist <= 1e-12 * max(np.linalg.norm(pos), np.linalg.norm(foc)):
            raise ValueError(f"camera position and focal_point coincide at {tuple(pos)}")
        fwd = (foc - pos) / np.linalg.norm(foc - pos)
        right = np.cross(fwd, up)
        if np.linalg.norm(right) < 1e-9 * np.linalg.norm(up):
            raise ValueError(f"camera view_up {tuple(float(v) for v in up)} is parallel to the view direction "
                             f"{tuple(float(v) for v in fwd)}: give a view_up across the view (VTK would leave "
                             "the image's rotation undefined)")
        angle = check_real(self.view_angle, "camera view_angle", lo=0.0, hi=180.0, lo_open=True, hi_open=True)
        scale = check_real(self.parallel_scale, "camera parallel_scale", lo=0.0, lo_open=True)
        object.__setattr__(self, "position", tuple(pos))
        object.__setattr__(self, "focal_point", tuple(foc))
        object.__setattr__(self, "view_up", tuple(up))
        object.__setattr__(self, "view_angle", angle)
        object.__setattr__(self, "parallel_projection", bool(self.parallel_projection))
        object.__setattr__(self, "parallel_scale", scale)

    # -- basis -----------------------------------------------------------------------------
    def basis(self):
        """``(forward, right, up')``: orthonormal camera axes in world space."""
        pos, foc = np.array(self.position), np.array(self.focal_point)
        fwd = (foc - pos) / np.linalg.norm(foc - pos)
        right = np.cross(fwd, np.array(self.view_up))
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        return fwd, right, up

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(np.subtract(self.focal_point, self.position)))

    def params(self, window_size) -> np.ndarray:
        """The 16 float64 numbers the kernels read (see the ``CAM_*`` offsets)."""
        w, h = check_window_size(window_size)
        fwd, right, up = self.basis()
        out = np.zeros(16)
        out[CAM_POS:CAM_POS + 3] = self.position
        out[CAM_FWD:CAM_FWD + 3] = fwd
        out[CAM_RIGHT:CAM_RIGHT + 3] = right
        out[CAM_UP:CAM_UP + 3] = up
        out[CAM_TAN] = np.tan(np.radians(self.view_angle) / 2.0)
        out[CAM_ASPECT] = w / h
        out[CAM_PARALLEL] = 1.0 if self.parallel_projection else 0.0
        out[CAM_SCALE] = self.parallel_scale
        return out

    # -- rays and projection (numpy; the kernels have their own scalar version) ----------------
    def rays(self, window_size):
        """Ray origins and unit directions for every pixel centre, each ``(H, W, 3)``."""
        w, h = check_window_size(window_size)
        fwd, right, up = self.basis()
        u = (np.arange(w) + 0.5) / w
        v = (np.arange(h) + 0.5) / h
        su = (2 * u[None, :] - 1)[..., None]
        sv = (1 - 2 * v[:, None])[..., None]
        aspect = w / h
        if self.parallel_projection:
            s = self.parallel_scale
            org = np.array(self.position) + su * s * aspect * right + sv * s * up
            dirs = np.broadcast_to(fwd, org.shape).copy()
        else:
            t = np.tan(np.radians(self.view_angle) / 2)
            dirs = fwd + su * t * aspect * right + sv * t * up
            dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
            org = np.broadcast_to(np.array(self.position), dirs.shape).copy()
        return org, dirs

    def project(self, points, window_size) -> np.ndarray:
        """Pixel coordinates ``(x, y)`` of world points: x from the left edge, y from the top edge.

        Pixel ``(i, j)``'s centre is at ``(i + ½, j + ½)``.
        """
        w, h = check_window_size(window_size)
        p = np.atleast_2d(np.asarray(points, dtype=np.float64)) - np.array(self.position)
        fwd, right, up = self.basis()
        x, y, z = p @ right, p @ up, p @ fwd
        aspect = w / h
        if self.parallel_projection:
            sx = x / (self.parallel_scale * aspect)
            sy = y / self.parallel_scale
        else:
            t = np.tan(np.radians(self.view_angle) / 2)
            sx = x / (z * t * aspect)
            sy = y / (z * t)
        return np.stack([(sx + 1) / 2 * w, (1 - sy) / 2 * h], axis=-1)

    def to_dict(self) -> dict:
        """The JSON scene form of this camera."""
        return {"position": list(self.position), "focal_point": list(self.focal_point),
                "view_up": list(self.view_up), "view_angle": self.view_angle,
                "parallel_projection": self.parallel_projection, "parallel_scale": self.parallel_scale}

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        known = {"position", "focal_point", "view_up", "view_angle", "parallel_projection", "parallel_scale"}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"camera has unknown keys {sorted(unknown)}; allowed: {sorted(known)}")
        missing = {"position", "focal_point"} - set(d)
        if missing:
            raise ValueError(f"camera is missing {sorted(missing)}")
        return cls(**d)

    @classmethod
    def from_vtk(cls, cam) -> "Camera":
        """From a ``pyvista.Camera`` or ``vtkCamera``."""
        return cls(position=cam.GetPosition(), focal_point=cam.GetFocalPoint(), view_up=cam.GetViewUp(),
                   view_angle=cam.GetViewAngle(), parallel_projection=bool(cam.GetParallelProjection()),
                   parallel_scale=cam.GetParallelScale())

    def to_vtk(self, cam=None):
        """Copy this camera into a ``vtkCamera`` (a new ``pyvista.Camera`` when none is given)."""
        if cam is None:
            import pyvista as pv

            cam = pv.Camera()
        cam.SetPosition(*self.position)
        cam.SetFocalPoint(*self.focal_point)
        cam.SetViewUp(*self.view_up)
        cam.SetViewAngle(self.view_angle)
        cam.SetParallelProjection(self.parallel_projection)
        cam.SetParallelScale(self.parallel_scale)
        return cam


#: PyVista's camera-position strings (``Plotter.camera_position = "xy"`` …, pyvista's
#: ``view_vectors``): the direction from the focal point to the camera, and the view up.
VIEW_STRINGS = {
    "iso": ((1.0, 1.0, 1.0), (0.0, 0.0, 1.0)),
    "xy": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)), "yx": ((0.0, 0.0, -1.0), (1.0, 0.0, 0.0)),
    "xz": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)), "zx": ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
    "yz": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)), "zy": ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
}


def default_camera(bounds, view="iso") -> Camera:
    """PyVista's view of ``bounds`` named ``view`` (:data:`VIEW_STRINGS`; default the isometric
    direction (1, 1, 1), z up), reset to fit.

    Uses VTK's own ``vtkRenderer.ResetCamera(bounds)`` (no window needed), so the framing is
    exactly what ``Plotter.show()`` (or ``Plotter.camera_position = view``) would pick.

    Examples
    --------
    >>> from pv_ambient.inputs.camera import default_camera
    >>> cam = default_camera((-1, 1, -1, 1, -1, 1), "xy")
    >>> [round(float(v), 6) for v in cam.focal_point], [float(v) for v in cam.view_up], bool(cam.position[2] > 1)
    ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], True)
    """
    from vtkmodules.vtkRenderingCore import vtkRenderer

    key = view.lower() if isinstance(view, str) else view
    if key not in VIEW_STRINGS:
        raise ValueError(f"camera {view!r} is not one of PyVista's camera strings {list(VIEW_STRINGS)}")
    direction, view_up = VIEW_STRINGS[key]
    b = [float(x) for x in bounds]
    center = np.array([(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2])
    ren = vtkRenderer()
    cam = ren.GetActiveCamera()
    cam.SetFocalPoint(*center)
    cam.SetPosition(*(center + np.array(direction)))
    cam.SetViewUp(*view_up)
    ren.ResetCamera(b)
    return Camera.from_vtk(cam)


def as_camera(camera, *, window_size=None, bounds=None):
    """Resolve ``camera`` (and the window size) from what a PyVista user might hold.

    Parameters
    ----------
    camera : Camera, pyvista.Camera, vtkCamera, pyvista.Plotter, dict, list, str or None
        ``None`` gives PyVista's default isometric view of ``bounds``; a string ``"iso"``,
        ``"xy"``, ``"xz"``, ``"yz"``, ``"yx"``, ``"zx"`` or ``"zy"`` the view PyVista's
        ``Plotter.camera_position`` gives it. A plotter contributes its
        active camera and, unless ``window_size`` is given, its window size; a plotter whose
        camera was never set gets PyVista's default camera first (as ``show()`` would). A list
        ``[position, focal_point, view_up]`` is PyVista's ``camera_position``; a dict is the JSON
        scene form.
    window_size : (int, int), optional
        ``(width, height)``; default (512, 512) unless the plotter gives one.
    bounds : sequence of 6 float, optional
        Volume bounds for the default camera.

    Returns
    -------
    tuple of (Camera, (int, int))
    """
    size = None
    if camera is None or isinstance(camera, str):
        if bounds is None:
            raise ValueError(f"camera is {camera!r} and no bounds are known to place it")
        cam = default_camera(bounds, "iso" if camera is None else camera)
    elif isinstance(camera, Camera):
        cam = camera
    elif isinstance(camera, dict):
        cam = Camera.from_dict(camera)
    elif isinstance(camera, (list, tuple)) and len(camera) == 3 and all(np.size(c) == 3 for c in camera):
        cam = Camera(position=camera[0], focal_point=camera[1], view_up=camera[2])
    elif hasattr(camera, "GetViewAngle") and hasattr(camera, "GetFocalPoint"):
        cam = Camera.from_vtk(camera)
    elif hasattr(camera, "renderer") and hasattr(camera, "window_size"):
        plotter = camera
        if not getattr(plotter, "camera_set", True):
            plotter.camera_position = plotter.get_default_cam_pos()
            plotter.reset_camera()
            plotter.camera_set = True
        cam = Camera.from_vtk(plotter.renderer.GetActiveCamera())
        # the active renderer's share of the window (subplots): its viewport in normalised units
        x0, y0, x1, y1 = plotter.renderer.GetViewport()
        w, h = plotter.window_size
        size = (max(1, int(round((x1 - x0) * w))), max(1, int(round((y1 - y0) * h))))
    else:
        raise TypeError("camera must be a pv_ambient.Camera, pyvista.Camera, vtkCamera, pyvista.Plotter, "
                        f"a dict, [position, focal_point, view_up], one of {list(VIEW_STRINGS)} or None; "
                        f"got {type(camera).__name__}")
    if window_size is not None:
        size = check_window_size(window_size)
    elif size is None:
        size = (512, 512)
    return cam, size


def orbit(grid, n_frames, *, elevation=None, start=None, view_up=None, distance=None, degrees=360.0):
    """Cameras on a circle around the volume: the camera path of an orbit movie.

    As PyVista's ``Plotter.generate_orbital_path``, the cameras move on a circle in the plane
    normal to ``view_up`` around the focal point, looking at it; here the circle starts at a
    camera (``start``: PyVista's default view of the volume when None) so frame 0 is the view
    the user set up, and the frames are ``degrees / n_frames`` apart (360: the last frame is one
    step before the first, so the movie loops).

    Parameters
    ----------
    grid : pyvista.ImageData, pv_ambient.inputs.grid.Volume or sequence of 6 float
        The volume (or its bounds); it places the default start camera.
    n_frames : int
        Number of cameras (≥ 1).
    elevation : float, optional
        Angle in degrees of the cameras above the orbit's plane through the focal point; the
        start camera's when None.
    start : Camera, pyvista.Camera, dict or list, optional
        The first camera (its focal point, distance, view angle and projection are kept).
    view_up : sequence of 3 float, optional
        The orbit's axis and every camera's view-up; the start camera's when None.
    distance : float, optional
        Camera distance from the focal point; the start camera's when None.
    degrees : float, default: 360.0
        The arc the orbit covers.

    Returns
    -------
    list of Camera

    Examples
    --------
    >>> import numpy as np
    >>> from pv_ambient import orbit
    >>> cams = orbit([-1, 1, -1, 1, -1, 1], 4, elevation=0.0,
    ...              start={"position": [0, -4, 0], "focal_point": [0, 0, 0], "view_up": [0, 0, 1]})
    >>> [(np.round(c.position, 6) + 0.0).tolist() for c in cams]
    [[0.0, -4.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [-4.0, 0.0, 0.0]]
    """
    n = check_int(n_frames, "n_frames", lo=1)
    degrees = check_real(degrees, "degrees")
    if start is None:
        bounds = getattr(grid, "bounds", None)
        if bounds is None and getattr(grid, "geometry", None) is not None:
            bounds = grid.geometry.bounds
        if bounds is None:
            bounds = grid
        try:
            bounds = [float(b) for b in bounds]
        except TypeError:
            raise TypeError(f"grid must be an ImageData, a Volume or 6 bounds, got {type(grid).__name__}") from None
        if len(bounds) != 6:
            raise ValueError(f"grid bounds must be 6 numbers, got {len(bounds)}")
        start = default_camera(bounds)
    else:
        start, _ = as_camera(start)
    focal = np.array(start.focal_point)
    axis = np.array(start.view_up if view_up is None else view_up, dtype=np.float64)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0:
        raise ValueError(f"view_up must be a non-zero 3-vector, got {view_up!r}")
    axis = axis / np.linalg.norm(axis)
    offset = np.array(start.position) - focal
    radius = np.linalg.norm(offset) if distance is None else check_real(distance, "distance", lo=0.0, lo_open=True)
    height = float(offset @ axis)
    flat = offset - height * axis
    if np.linalg.norm(flat) < 1e-12 * np.linalg.norm(offset):
        # the start camera looks along the axis: begin the circle on any direction normal to it
        flat = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 = flat / np.linalg.norm(flat)
    e2 = np.cross(axis, e1)
    if elevation is None:
        elev = np.arctan2(height, np.linalg.norm(offset - height * axis))
    else:
        elev = np.radians(check_real(elevation, "elevation", lo=-90.0, hi=90.0, lo_open=True, hi_open=True))
    cams = []
    for k in range(n):
        phi = np.radians(degrees) * k / n
        ring = np.cos(phi) * e1 + np.sin(phi) * e2
        pos = focal + radius * (np.cos(elev) * ring + np.sin(elev) * axis)
        cams.append(Camera(position=tuple(pos), focal_point=tuple(focal), view_up=tuple(axis),
                           view_angle=start.view_angle, parallel_projection=start.parallel_projection,
                           parallel_scale=start.parallel_scale))
    return cams
