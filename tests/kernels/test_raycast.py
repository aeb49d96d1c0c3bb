"""Tests pv_ambient/_kernels/raycast.py: the ray-cast kernels' lookups and the tiled CPU driver."""
import numpy as np

import pv_ambient as pa
from pv_ambient.inputs.camera import Camera


def test_three_albedo_lookup_equals_single_lookups():
    from pv_ambient._kernels.preint import d_lookup, tau_coord
    from pv_ambient._kernels.raycast import d_lookup3
    from pv_ambient.stages.preintegration import get_table

    rng = np.random.default_rng(1)
    for g in (0.0, 0.6):
        tab = get_table(g, (0.3, 1.0), quality="preview")
        D, _, a_nodes, lo, dl = tab.lookup_args()
        for _ in range(200):
            c, tau = rng.uniform(-1, 1), rng.choice([0.0, 1e-4, rng.uniform(0, 60)])
            a = rng.uniform(0.2, 1.0, 3)
            a[rng.integers(3)] = a[0]  # equal channels take the shortcut
            it, tt = tau_coord(D.shape[1], lo, dl, tau)
            got = d_lookup3(D, a_nodes, it, tt, c, a[0], a[1], a[2])
            want = [d_lookup(D, a_nodes, lo, dl, c, tau, ac) for ac in a]
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)


def _one_ray_at_a_time(model):
    """A plain serial loop over the rows [r0, r1) and every column, :func:`raycast_pixel` once per
    pixel (no tiles, no stride order, one thread). ``model`` is a constant of the loop, as in the
    CPU drivers (:func:`raycast_driver`): ``raycast_pixel`` is the one compiled for the model, not a
    build with the model a run-time value, which would cost its own cold compile (~30 s) and serve
    this test alone."""
    import numba

    from pv_ambient._kernels import raycast

    @numba.njit
    def rows(baked, mode, view, march, medium, lights, grid, ambient, diffusion, r0, r1, out_rad, out_alpha):
        for j in range(r0, r1):
            for i in range(out_alpha.shape[1]):
                raycast.raycast_pixel(model, baked, mode, view, march, medium, lights, grid, ambient, diffusion, j,
                                      i, out_rad, out_alpha)

    return rows


def test_tiled_driver_renders_each_pixel_of_its_rows_once(monkeypatch):
    """Why: the CPU driver marches TILE² pixel tiles (cache locality), not rows; a band of rows whose
    height and width are no multiple of the tile must still get every pixel, as one ray alone gives
    it (:func:`_one_ray_at_a_time`), and nothing outside the band, with one thread or two."""
    import numba

    from pv_ambient import backend as R
    from pv_ambient._kernels import raycast

    captured = {}
    real = R.run_raycast

    def capture(args, rad, alpha, **kw):
        captured["args"] = args
        return real(args, rad, alpha, **kw)

    monkeypatch.setattr(R, "run_raycast", capture)
    from pv_ambient import datasets

    grid = datasets.cloud(n=16)
    W, H = 2 * raycast.TILE + 5, 2 * raycast.TILE + 13
    pa.render(grid, window_size=(W, H), camera=Camera((2, -3, 1), (0, 0, 0), (0, 0, 1), view_angle=35))
    args = captured["args"]
    r0, r1 = 3, H - 2
    out = []
    n0 = numba.get_num_threads()
    for threads in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
        numba.set_num_threads(threads)
        try:
            rad = np.full((H, W, 3), np.nan, np.float32)
            alpha = np.full((H, W), np.nan, np.float32)
            raycast.raycast_image(*args, r0, r1, rad, alpha)
        finally:
            numba.set_num_threads(n0)
        out.append((rad, alpha))
    ref_rad = np.full_like(rad, np.nan)
    ref_alpha = np.full_like(alpha, np.nan)
    model, baked, mode = raycast.specialisation(args[0], args[5].baked, args[3].mode)
    _one_ray_at_a_time(model)(baked, mode, *args[1:], r0, r1, ref_rad, ref_alpha)
    for rad, alpha in out:  # every thread count: the same pixels, bit for bit
        assert np.isnan(alpha[:r0]).all() and np.isnan(alpha[r1:]).all()
        assert (alpha[r0:r1] > 0).mean() > 0.2  # the volume covers part of the band
        np.testing.assert_array_equal(rad, ref_rad)
        np.testing.assert_array_equal(alpha, ref_alpha)
