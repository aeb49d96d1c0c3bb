"""Tests pv_ambient/stages/diffusion/ordinates.py, the diffusion stage's transport sweep
(docs/diffusion.rst §5): the once-scattered light by discrete ordinates, against closed forms, and its
use by the diffusion model."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from pv_ambient._kernels.phase import HENYEY_GREENSTEIN, ISOTROPIC
from pv_ambient.stages import diffusion as dm
from pv_ambient.stages.diffusion.ordinates import fibonacci_directions, sweep_once


def _hg(g, mu):
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * mu) ** 1.5)


def _slab_once_scattered(z, Z, sig, sig_s, g):
    """Exact fluence and flux (z) of the once-scattered light in a slab [0, Z] lit at normal
    incidence by a unit collimated beam (source σs e^{−σz} p(μ)): for μ > 0 the light from
    [0, z], ∫ e^{−σz'} e^{−σ(z−z')/μ} dz'/μ = (e^{−σz} − e^{−σz/μ})/(σ(1 − μ)), and for μ < 0
    from [z, Z] likewise; the μ integral by adaptive quadrature."""
    def up(mu):  # μ > 0
        if 1.0 - mu < 1e-12:
            return z * math.exp(-sig * z)
        return (math.exp(-sig * z) - math.exp(-sig * z / mu)) / (sig * (1.0 - mu))

    def down(mu):  # direction −μ, μ > 0
        return (math.exp(-sig * z) - math.exp(-sig * Z * (1 + 1 / mu) + sig * z / mu)) / (sig * (1.0 + mu))

    kw = dict(limit=400, points=[1e-3, 1e-2, 0.1])
    phi = quad(lambda m: _hg(g, m) * up(m), 0, 1, **kw)[0] + quad(lambda m: _hg(g, -m) * down(m), 0, 1, **kw)[0]
    F = quad(lambda m: m * _hg(g, m) * up(m), 0, 1, **kw)[0] - quad(lambda m: m * _hg(g, -m) * down(m), 0, 1, **kw)[0]
    return 2 * math.pi * sig_s * phi, 2 * math.pi * sig_s * F


def _slab_errors(n, g, M=128, Z=1.0, sig=4.0, albedo=0.8):
    h = Z / (n - 1)
    z = np.arange(n) * h
    q0 = (albedo * sig * np.exp(-sig * z))[None, None, :]
    om = np.zeros((1, 1, n, 3))
    om[..., 2] = 1.0
    phi, F = sweep_once(np.full((1, 1, n), sig), q0, om, HENYEY_GREENSTEIN, g, (1.0, 1.0, h), directions=M)
    idx = list(range(0, n, (n - 1) // 10))
    ex = np.array([_slab_once_scattered(z[i], Z, sig, albedo * sig, g) for i in idx])
    return (float(np.max(np.abs(phi[0, 0, idx] / ex[:, 0] - 1))),
            float(np.max(np.abs(F[0, 0, idx, 2] - ex[:, 1]) / ex[:, 0])))


def test_slab_isotropic_second_order():
    """Isotropic scattering, τ = 4 slab, normal incidence: the relative error of φ₁ at 11 depths
    (faces included) converges at second order (the linear source and σt along each
    characteristic; the direction set's error is below it, the μ-integrand being smooth).
    Measured at 51 / 101 / 201 nodes: 5.3e-4, 1.4e-4, 3.8e-5; F₁ (relative to φ₁) 3.0e-4, 7.0e-5."""
    e51, f51 = _slab_errors(51, 0.0)
    e101, f101 = _slab_errors(101, 0.0)
    assert e101 < 2.5e-4 and f101 < 1.5e-4, (e101, f101)
    assert e51 / e101 > 3.0, (e51, e101)


def test_slab_forward_scattering():
    """Henyey–Greenstein g = 0.6, same slab, 101 nodes: the 128-direction set integrates the
    phase function's lobe to about 1e-3 (the error no longer falls with the grid: 8.1e-4 at 101
    nodes, 9.1e-4 at 201); bound 2e-3 for φ₁ and for F₁ relative to φ₁ (measured 9.1e-4)."""
    e, f = _slab_errors(101, 0.6)
    assert e < 2e-3 and f < 2e-3, (e, f)


def _cube_exact(x, sig, dirs):
    """φ₁ and F₁ at x in the unit cube, uniform σt and an isotropic unit source: the radiance
    along ω is (1 − e^{−σ t})/(4π σ), t the distance back to the box along −ω."""
    t = np.full(len(dirs), np.inf)
    for i in range(3):
        with np.errstate(divide="ignore", invalid="ignore"):
            ti = np.where(dirs[:, i] < 0, (1 - x[i]) / -dirs[:, i], np.where(dirs[:, i] > 0, x[i] / dirs[:, i], np.inf))
        t = np.minimum(t, ti)
    L = (1 - np.exp(-sig * t)) / sig
    return float(np.mean(L)), np.mean(L[:, None] * dirs, axis=0)


def test_cube_interior_against_quadrature():
    """A unit cube, σt = 2, uniform isotropic source, 128 directions: φ₁ at the centre and at an
    off-centre interior node against a 10⁶-direction quadrature of the exact radiance. Measured
    relative errors: centre 1.05e-3 at 17³, 33³ and 65³ (the direction set's); off centre −1.30e-2,
    −6.5e-3, −3.6e-3 (first order: bilinear interpolation across the kinks that the box's edges
    cast); F₁ within 7.1e-4 of φ₁ there."""
    dirs = fibonacci_directions(1_000_000)
    sig = 2.0
    err = {}
    for n in (33, 65):
        h = 1.0 / (n - 1)
        phi, F = sweep_once(np.full((n, n, n), sig), np.ones((n, n, n)), np.zeros((n, n, n, 3)),
                                HENYEY_GREENSTEIN, 0.0, (h, h, h), directions=128)
        for name, idx in (("centre", (n // 2,) * 3), ("off", (n // 4, n // 2, n // 3))):
            e, f = _cube_exact(np.array(idx) * h, sig, dirs)
            err[name, n] = phi[idx] / e - 1
            assert np.max(np.abs(F[idx] - f)) / e < 1.5e-3, (name, n, F[idx], f)
    assert abs(err["centre", 33]) < 2e-3 and abs(err["off", 33]) < 1e-2, err
    assert abs(err["off", 65]) < 0.7 * abs(err["off", 33]), err


def test_sweep_conserves_power_in_an_absorber():
    """With albedo 0 nothing scatters again: the once-scattered light is absorbed or leaves, so
    Σ σt φ₁ V + (escaping flux) = Σ q V. The escape through the faces is Σ_faces A F₁·n at the
    boundary nodes (half control volumes). Checked to 2 % on a 33³ cube of σt = 3 with a
    Gaussian source (measured −0.18 %, 64 directions)."""
    n = 33
    h = 1.0 / (n - 1)
    x = np.arange(n) * h
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    q = np.exp(-((X - 0.4) ** 2 + (Y - 0.5) ** 2 + (Z - 0.6) ** 2) / 0.02)
    sig = 3.0
    phi, F = sweep_once(np.full((n, n, n), sig), q, np.zeros((n, n, n, 3)), HENYEY_GREENSTEIN, 0.0, (h,) * 3)
    w = np.ones(n)
    w[0] = w[-1] = 0.5
    V = (w[:, None, None] * w[None, :, None] * w[None, None, :]) * h ** 3
    src = float(np.sum(q * V))
    absorbed = float(np.sum(sig * phi * V))
    A = (w[:, None] * w[None, :]) * h * h
    esc = (np.sum(A * F[-1, :, :, 0]) - np.sum(A * F[0, :, :, 0]) + np.sum(A * F[:, -1, :, 1])
           - np.sum(A * F[:, 0, :, 1]) + np.sum(A * F[:, :, -1, 2]) - np.sum(A * F[:, :, 0, 2]))
    assert absorbed + esc == pytest.approx(src, rel=0.02), (absorbed, esc, src)


def test_grey_channels_share_the_sweep_and_rotation_rotates_flux():
    """Equal channels run one sweep (the same φ₁ per channel). A grid whose index axes point
    along rotated world axes (``direction``, a cyclic permutation) with the light turned alike
    is the same problem: the same φ₁ and a rotated F₁, to the direction set's error (the
    Fibonacci set is not invariant under the rotation). Measured (128 directions) relative
    2-norm differences
    1.1e-3 (φ₁) and 2.0e-3 (F₁); ignoring ``direction`` gives 0.48 and 0.93. Bound 1e-2."""
    n = 17
    x = np.linspace(0, 1.6, n)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    sig = 0.5 + 4 * np.exp(-((X - 0.6) ** 2 + (Y - 0.9) ** 2 + (Z - 0.8) ** 2) / 0.2)
    q = np.exp(-((X - 0.5) ** 2 + (Y - 0.8) ** 2 + (Z - 1.0) ** 2) / 0.1)
    om = np.zeros((n, n, n, 3))
    om[..., 0] = 1.0
    kw = dict(directions=128)
    phi, F = sweep_once(sig, np.repeat(q[..., None], 3, axis=3), om, HENYEY_GREENSTEIN, 0.5, (0.1,) * 3, **kw)
    phi1, F1 = sweep_once(sig, q, om, HENYEY_GREENSTEIN, 0.5, (0.1,) * 3, **kw)
    assert np.array_equal(phi[..., 2], phi1) and np.array_equal(F[..., 1, :], F1)
    P = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)  # index axis i points along world P[:, i]
    omr = np.zeros((n, n, n, 3))
    omr[...] = P[:, 0]  # the light along index axis 0, as before
    phir, Fr = sweep_once(sig, q, omr, HENYEY_GREENSTEIN, 0.5, (0.1,) * 3, direction=P, **kw)
    assert np.linalg.norm(phir - phi1) / np.linalg.norm(phi1) < 1e-2
    assert np.linalg.norm(Fr @ P - F1) / np.linalg.norm(F1) < 1e-2


def test_sweep_orders_model_option():
    """``sweep_orders`` on the renderer: a different image from plain diffusion (cached apart
    from it), the option in the metadata, and a non-integer or negative value refused."""
    import pyvista as pv

    import pv_ambient as pa
    from pv_ambient import PointLight

    n = 16
    g = pv.ImageData(dimensions=(n, n, n), spacing=(2 / (n - 1),) * 3, origin=(-1, -1, -1))
    rad = np.linalg.norm(g.points, axis=1)
    g["sigma_t"] = (4.0 * np.exp(-(rad / 0.6) ** 2)).astype(np.float32)
    g["albedo"] = np.full((g.n_points, 3), 0.9, np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    r = pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=[PointLight((0, -2, 1), intensity=4.0)])
    cam = pa.Camera((0, -4, 0.5), (0, 0, 0), (0, 0, 1), view_angle=35)
    plain = r.render(camera=cam, window_size=(16, 16), model="diffusion", phase=0.5)
    sw = r.render(camera=cam, window_size=(16, 16), model="diffusion", phase=0.5, sweep_orders=2)
    assert sw.metadata["sweep_orders"] == 2 and plain.metadata["sweep_orders"] == 0
    assert not np.array_equal(sw.radiance, plain.radiance)
    assert np.all(np.isfinite(sw.radiance)) and sw.radiance.min() >= 0
    with pytest.raises(TypeError, match="sweep_orders"):
        r.render(camera=cam, window_size=(16, 16), model="diffusion", phase=0.5, sweep_orders=True)
    with pytest.raises(ValueError, match="sweep_orders"):
        r.render(camera=cam, window_size=(16, 16), model="diffusion", phase=0.5, sweep_orders=-1)


def test_orders_in_an_infinite_medium():
    """A homogeneous cube 40 mean free paths across with a uniform isotropic first-order source:
    far from the faces (leakage ~e^{−20}) each order is the last times the albedo, φ_k =
    a^{k−1} q/σt with flux g^k φ_k along the light (the first source's lobe, g = 0.5), and
    diffusion from order K's source adds a^K q/σa: the total is q/σa, the infinite medium's.
    Discretisation does not enter (uniform fields), only the direction set's quadrature of the
    phase function's lobe (128 directions here): φ to 1e−3, F to 3e−3 of φ (the set's first
    moment of the lobe leans off the axis by up to 0.2 %, measured; 0.6 % with 64 directions
    and 1.2 % after two orders of 32, the defaults)."""
    from pv_ambient.stages.diffusion.ordinates import scattering_orders

    n, sig, a, q = 17, 40.0, 0.7, 2.0
    h = 1.0 / (n - 1)
    shape = (n, n, n)
    om = np.zeros(shape + (3,))
    om[..., 2] = 1.0
    src = [(np.full(shape + (3,), q), om)]
    alb = np.full(shape + (3,), a)
    c = (n // 2,) * 3
    for K in (1, 2, 3):
        phi, F, phi_k, F_k = scattering_orders(np.full(shape, sig), alb, src, HENYEY_GREENSTEIN, 0.5, (h,) * 3, K,
                                               directions=128)
        assert phi_k[c][0] == pytest.approx(a ** (K - 1) * q / sig, rel=1e-3)
        assert phi[c][0] == pytest.approx(q / sig * (1 - a ** K) / (1 - a), rel=1e-3)
        # each scattering multiplies the first moment by g (the beam-and-isotropic mixture keeps it)
        assert F_k[c][0] == pytest.approx([0.0, 0.0, 0.5 ** K * phi_k[c][0]], abs=3e-3 * phi_k[c][0])
    medium = dm.DiffusionMedium.from_arrays(np.full(shape, sig), alb)
    # F_k is float32: the first-moment source as float64, like the rest (the solver's all-float64
    # kernels, not a mix compiled for this test alone: ~10 s of cold compiling)
    sol = dm.solve_in_medium(medium, 0.5, (h,) * 3, a * sig * phi_k, 0.5 * a * sig * F_k.astype(np.float64))
    assert phi[c][0] + sol.phi[c][0] == pytest.approx(q / ((1 - a) * sig), rel=1e-3)


def _hat_renderer(v, tf, lights):
    import pyvista as pv

    import pv_ambient as pa

    n = v.shape[0]
    g = pv.ImageData(dimensions=v.shape, spacing=(1 / (n - 1),) * 3, origin=(0, 0, 0))
    g["v"] = v.ravel(order="F").astype(np.float32)
    return pa.Renderer(g, transfer_function=tf, lights=lights)


def test_hat_medium_keeps_the_classified_integral():
    """The sweeps' medium (node means over the hat functions, classified at half-index
    sub-samples): for a physical (trilinear) medium its integral Σ σ̄ V is the nodes' exactly; for
    binary data through a transfer function whose σs = σt·albedo is convex in the data it is far
    closer to the classified field's integral (8× finer quadrature) than the node samples are:
    measured +20 % against +116 %."""
    import pyvista as pv

    import pv_ambient as pa
    from pv_ambient.stages.diffusion import hat_medium

    n = 17
    w = np.ones(n)
    w[0] = w[-1] = 0.5
    V = (w[:, None, None] * w[None, :, None] * w[None, None, :]) / (n - 1) ** 3
    rng = np.random.default_rng(2)
    g = pv.ImageData(dimensions=(n, n, n), spacing=(1 / (n - 1),) * 3)
    g["sigma_t"] = rng.uniform(0, 5, g.n_points).astype(np.float32)
    g["albedo"] = np.full((g.n_points, 3), 0.5, np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    r = pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=[])
    m = hat_medium(r.optics, r.geometry)
    assert np.sum(m.sigma_t * V) == pytest.approx(np.sum(r.optics.sigma_grid() * V), rel=1e-6)
    assert np.allclose(m.albedo, 0.5)

    v = (rng.uniform(0, 1, (n, n, n)) > 0.7).astype(np.float32)
    tf = pa.TransferFunction(cmap="bone", clim=(0, 1), opacity="linear", density_scale=8.0, albedo=0.9)
    r = _hat_renderer(v, tf, [])
    o = r.optics
    m = hat_medium(o, r.geometry)
    from scipy.ndimage import map_coordinates

    f = 8
    N = (n - 1) * f + 1
    c = np.arange(N) / f
    vf = map_coordinates(o.field, np.meshgrid(c, c, c, indexing="ij"), order=1)
    x = np.clip((vf - o.lut_lo) * o.lut_inv, 0, o.table.shape[0] - 1)
    k0 = np.minimum(x.astype(int), o.table.shape[0] - 2)
    tab = o.table[k0] + (o.table[k0 + 1] - o.table[k0]) * (x - k0)[..., None]
    wf = np.ones(N)
    wf[0] = wf[-1] = 0.5
    Wf = wf[:, None, None] * wf[None, :, None] * wf[None, None, :]
    fine = np.sum(tab[..., 0] * tab[..., 1] * Wf) / (N - 1) ** 3
    hat = np.sum(m.sigma_t * m.albedo[..., 0] * V)
    node = np.sum(o.sigma_grid() * o.albedo_grid()[..., 0] * V)
    assert abs(hat / fine - 1) < 0.3 and abs(node / fine - 1) > 1.0, (hat / fine, node / fine)


def test_hat_source_of_a_slab_under_a_directional_light():
    """A uniform medium lit straight down (−z) by a directional light: the hat-projected first
    collision source is σs E0 e^{−σ d} (d the depth) times the hat mean of e^{−σ(z − z_n)},
    2(cosh σh − 1)/(σh)² exactly, which the trapezoid rule on the half-index grid makes
    (1 + cosh(σh/2))/2, low by (σh)²/48 (0.52 % at σh = 0.5). The kernel matches the trapezoid
    value to 1e−5 (measured 1e−7: the light grid's τ is exact for a slab), the exact one to
    (σh)²/40; the direction is the light's."""
    import pyvista as pv

    import pv_ambient as pa
    from pv_ambient import DirectionalLight
    from pv_ambient.stages.diffusion import hat_medium, hat_source

    n, sig, a = 17, 8.0, 0.6
    h = 1.0 / (n - 1)
    g = pv.ImageData(dimensions=(n, n, n), spacing=(h,) * 3)
    g["sigma_t"] = np.full(g.n_points, sig, np.float32)
    g["albedo"] = np.full((g.n_points, 3), a, np.float32)
    g["emission"] = np.zeros((g.n_points, 3), np.float32)
    light = DirectionalLight((0.0, 0.0, -1.0), irradiance=2.0)
    r = pa.Renderer(g, transfer_function=pa.TransferFunction.physical(), lights=[light])
    grid = r.stages.light_grid()
    med = hat_medium(r.optics, r.geometry)
    q, w = hat_source(light, r.geometry, r.stages.optical_depth(light, grid), grid, r.optics, med)
    z = np.arange(n) * h
    base = a * sig * 2.0 * np.exp(-sig * (1.0 - z))
    sh = sig * h
    inner = slice(1, n - 1)
    got = q[n // 2, n // 2, inner, 0] / base[inner]
    assert np.max(np.abs(got / ((1 + np.cosh(sh / 2)) / 2) - 1)) < 1e-5, got
    assert np.max(np.abs(got / (2 * (np.cosh(sh) - 1) / sh ** 2) - 1)) < sh ** 2 / 40, got
    assert np.allclose(w[n // 2, n // 2, inner], [0, 0, -1])


def test_hat_source_next_to_a_point_light_is_the_control_volume_form():
    """Within ``NEAR + 1`` index units of a point light (1/d² singular) the hat source keeps the
    control-volume form σs·mean(E) of :func:`direct_irradiance` — computed on the box of those
    nodes alone, it equals the whole grid's there (the same control volumes and τ lookups, to the
    rounding of the box's shifted origin); farther out the hat form differs from it."""
    import pv_ambient as pa
    from pv_ambient import PointLight, datasets
    from pv_ambient.stages.diffusion import hat_medium, hat_source
    from pv_ambient.stages.diffusion.sources import NEAR, direct_irradiance

    r = pa.Renderer(datasets.cloud(n=20), transfer_function=pa.TransferFunction(**datasets.suggested_style("cloud")))
    light = PointLight((0.11, -0.07, 0.04), intensity=(2.0, 1.5, 1.0))
    grid = r.stages.light_grid()
    tau = r.stages.optical_depth(light, grid)
    med = hat_medium(r.optics, r.geometry)
    q, w = hat_source(light, r.geometry, tau, grid, r.optics, med)
    E, om = direct_irradiance(light, r.geometry, tau, grid)
    cv = med.albedo * med.sigma_t[..., None] * E
    M = np.asarray(r.geometry.index_to_world, np.float64)
    pl = np.linalg.solve(M[:3, :3], np.asarray(light.position) - M[:3, 3])
    dmax = np.max(np.abs(np.indices(med.sigma_t.shape).transpose(1, 2, 3, 0) - pl), axis=-1)
    near = dmax < NEAR + 1.0 - 1e-6
    assert 8 <= near.sum() < near.size // 50
    assert np.allclose(q[near], cv[near], rtol=1e-12, atol=0.0)
    assert np.allclose(w[near], om[near], rtol=1e-12, atol=1e-15)
    far = (dmax > NEAR + 2.0) & (cv[..., 0] > 1e-3 * cv[..., 0].max())
    assert far.sum() > 100 and not np.allclose(q[far], cv[far], rtol=1e-3)


def test_sweeps_refuse_a_mean_cosine_per_node():
    """The sweeps apply one phase function everywhere: a g per node is refused before any work."""
    import pv_ambient as pa
    from pv_ambient import datasets

    r = pa.Renderer(datasets.cloud(n=8), transfer_function=pa.TransferFunction(**datasets.suggested_style("cloud")))
    grid = r.stages.light_grid()
    light = pa.PointLight((0.1, 0.2, 0.3), 2.0)
    medium = dm.hat_medium(r.optics, r.geometry)
    with pytest.raises(ValueError, match="one phase function"):
        dm.solve_for_light(light, np.full(medium.shape, 0.3), medium=medium, geometry=r.geometry,
                           tau=r.stages.optical_depth(light, grid), light_grid=grid, sweep_orders=2)


def test_scattering_orders_report_each_order_and_keep_their_values(capsys):
    """A long ``auto`` accurate first frame spends most of its time in these sweeps: with
    ``progress_bar`` a bar counts the orders (each sweeps the grid along every direction), and the
    result is the same as without it."""
    from pv_ambient.stages.diffusion.ordinates import scattering_orders

    n, sig, a = 7, 3.0, 0.8
    shape = (n, n, n)
    om = np.zeros(shape + (3,))
    om[..., 0] = 1.0
    src = [(np.full(shape + (3,), 1.5), om)]
    args = (np.full(shape, sig), np.full(shape + (3,), a), src, HENYEY_GREENSTEIN, 0.3, (0.1,) * 3, 3)
    quiet = scattering_orders(*args, directions=16)
    capsys.readouterr()
    shown = scattering_orders(*args, directions=16, progress_bar=True)
    err = capsys.readouterr().err
    assert "transport sweeps" in err and "3/3" in err
    for x, y in zip(quiet, shown):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("per_channel", [True, False])
def test_orders_in_reused_arrays_equal_fresh_sweeps(per_channel):
    """``scattering_orders`` sweeps every order into the same two arrays (``sweep_once``'s ``out``)
    and forms sources and sums on every core where the arrays line up (per-channel albedo); a grey
    albedo broadcasts and keeps NumPy's arithmetic. Either way its sums equal those of
    ``sweep_once`` called order by order into fresh arrays with NumPy's arithmetic, bit for bit."""
    from pv_ambient.stages.diffusion.ordinates import scattering_orders

    rng = np.random.default_rng(3)
    n, sp, K = 9, (0.1,) * 3, 3
    sig = rng.uniform(0.5, 3.0, (n, n, n))
    q0 = rng.uniform(0.0, 1.0, (n, n, n, 3))
    alb = rng.uniform(0.2, 0.9, (n, n, n, 3)) if per_channel else np.full((n, n, n), 0.6)
    phi, F, phi_k, F_k = scattering_orders(sig, alb, [(q0, None)], ISOTROPIC, 0.0, sp, K, directions=16)
    p, f = sweep_once(sig, q0, None, ISOTROPIC, 0.0, sp, directions=16)
    ref_phi, ref_F = p.copy(), f.astype(np.float64)
    sig_s = (alb if per_channel else alb[..., None]) * sig[..., None]
    for _ in range(1, K):
        p, f = sweep_once(sig, sig_s * p, None, ISOTROPIC, 0.0, sp, directions=16)
        ref_phi += p
        ref_F += f
    assert np.array_equal(phi_k, p) and np.array_equal(F_k, f)
    assert np.array_equal(phi, ref_phi) and np.array_equal(F, ref_F.astype(np.float32))


def test_sweep_once_fills_out_in_place():
    """``sweep_once(..., out=(phi, F))`` returns those arrays, zeroed and filled (whatever they held):
    the same values as a sweep into new arrays; arrays of another shape are left alone."""
    rng = np.random.default_rng(4)
    n = 7
    sig = rng.uniform(0.5, 3.0, (n, n, n))
    q = rng.uniform(0.0, 1.0, (n, n, n, 2))
    phi0, F0 = sweep_once(sig, q, None, ISOTROPIC, 0.0, (0.1,) * 3, directions=16)
    out = (np.full(phi0.shape, 7.0), np.full(F0.shape, 7.0, np.float32))
    phi, F = sweep_once(sig, q, None, ISOTROPIC, 0.0, (0.1,) * 3, directions=16, out=out)
    assert phi is out[0] and F is out[1]
    assert np.array_equal(phi, phi0) and np.array_equal(F, F0)
    wrong = (np.full((n, n, n, 3), 7.0), np.full((n, n, n, 3, 3), 7.0, np.float32))
    phi, F = sweep_once(sig, q, None, ISOTROPIC, 0.0, (0.1,) * 3, directions=16, out=wrong)
    assert np.array_equal(phi, phi0) and np.all(wrong[0] == 7.0)
