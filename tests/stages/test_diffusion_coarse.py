"""The diffusion solve on a coarser grid (pv_ambient.stages.diffusion.coarse; docs/diffusion.rst,
"Solve resolution"): the transfers against a dense construction, the held layer of the box
around a point light, and the coarse solve against the full-resolution one."""

import numpy as np
import pytest

from pv_ambient.inputs.grid import make_geometry
from pv_ambient.inputs.lights import PointLight
from pv_ambient.stages.diffusion import DiffusionMedium, coarse as dc, solve_in_medium
from pv_ambient.stages.diffusion.solve import mean_chord


def _dense_axis(n, m, association):
    """Trilinear prolongation of one axis as a dense (n × m) matrix, from the coarse nodes' data
    positions (an independent construction: hat functions evaluated at the samples)."""
    if n == m:
        return np.eye(n)
    if association == "point":
        pos = np.arange(m) * (n - 1) / (m - 1)
    else:
        pos = -0.5 + (np.arange(m) + 0.5) * n / m
    step = pos[1] - pos[0]
    x = np.clip(np.arange(n), pos[0], pos[-1])[:, None]
    return np.clip(1.0 - np.abs(x - pos[None, :]) / step, 0.0, None)


@pytest.mark.parametrize("shape, association", [((9, 8, 3), "point"), ((10, 7, 5), "cell"), ((6, 6, 6), "point")])
def test_transfers_match_a_dense_construction(shape, association):
    geo = make_geometry(shape if association == "point" else tuple(n + 1 for n in shape),
                        np.diag([0.5, 0.25, 1.0, 1.0]), association=association)
    co = dc.Coarsening.of(geo)
    P = [_dense_axis(n, m, association) for n, m in zip(shape, co.shape)]
    rng = np.random.default_rng(4)
    xc = rng.random(co.shape + (2,))
    want = np.einsum("ia,jb,kc,abcl->ijkl", *P, xc)
    assert np.allclose(co.prolong(xc), want, atol=1e-12)
    xf = rng.random(shape)
    W = np.einsum("ia,jb,kc->abc", *P)  # Σ P over the samples: the normalisation
    want_r = np.einsum("ia,jb,kc,ijk->abc", *P, xf) / W
    assert np.allclose(co.restrict(xf), want_r, atol=1e-12)
    assert np.allclose(co.restrict(np.full(shape, 3.5)), 3.5)


def _cloud(n, seed=1, albedo_dtype=np.float64):
    """σt (float64), the RGB albedo (``albedo_dtype``) and the spacing of a cloud on [−1, 1]³. The
    tests of the coarse solve against the full one take a float32 albedo, as a render's medium has:
    their solves then run the kernels the render tests compile (a float64 albedo with the float32
    sources of ``source_in_medium`` compiled a set of its own for them, ~25 s cold)."""
    rng = np.random.default_rng(seed)
    x = np.linspace(-1, 1, n)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    r = np.sqrt(X ** 2 + Y ** 2 + Z ** 2)
    sig = 6.0 * np.exp(-((r - 0.55) / 0.2) ** 2) + 0.5 + 0.3 * rng.random((n, n, n))
    alb = np.stack([np.full((n, n, n), a) for a in (0.95, 0.9, 0.8)], axis=-1).astype(albedo_dtype)
    return sig, alb, 2.0 / (n - 1)


def test_held_layer_reproduces_the_full_solve():
    """A box whose held layer is the full solve's φ gives back the full solve inside (the same
    discretisation): the Dirichlet layer is exact."""
    n = 24
    sig, alb, h = _cloud(n)
    a = alb[..., 1]
    Q0 = np.zeros((n, n, n))
    Q0[10, 12, 11] = 50.0
    Q0 += 0.1
    full = solve_in_medium(DiffusionMedium.from_arrays(sig, a), 0.0, (h, h, h), Q0, tol=1e-10)
    sl, cut = dc._patch((n, n, n), (10, 12, 11), 6)
    assert cut == ((True, True),) * 3
    floor = 1.0 / mean_chord((n, n, n), np.full(3, h))
    phi, F, ghost = dc._solve_patch(sig[sl], a[sl], 0.0, floor, np.full(3, h), "point", Q0[sl], None, None,
                                    np.ascontiguousarray(full.phi[sl]), cut, 1e-10)
    assert np.allclose(phi, full.phi[sl], rtol=1e-7, atol=1e-12 * full.phi.max())
    inner = ~ghost
    Ff = full.flux[sl]
    assert np.allclose(F[inner], Ff[inner], rtol=1e-4, atol=1e-5 * np.abs(Ff).max())
    # a box on the grid's face keeps the medium's own (Marshak) face there
    sl2, cut2 = dc._patch((n, n, n), (0, 12, 11), 6)
    assert cut2[0] == (False, True)
    phi2, _, _ = dc._solve_patch(sig[sl2], a[sl2], 0.0, floor, np.full(3, h), "point", Q0[sl2], None, None,
                                 np.ascontiguousarray(full.phi[sl2]), cut2, 1e-10)
    assert np.allclose(phi2, full.phi[sl2], rtol=1e-7, atol=1e-12 * full.phi.max())


def test_coarse_solve_against_the_full_resolution():
    """A point light inside a 65³ cloud: the coarse solve with the box around the light against the
    full-resolution solve, σs-weighted relative error of φ: ≤ 0.5 % within 8 samples of the light
    (inside the box), ≤ 2 % over the whole grid (measured 0.25 % and 0.53 %); the coarse source keeps
    the data grid's power to 1 % (measured 6e-5)."""
    from pv_ambient.stages.diffusion.sources import direct_irradiance, source_in_medium, unit_irradiance
    from types import SimpleNamespace

    n = 65
    sig, alb, h = _cloud(n, albedo_dtype=np.float32)
    geo = make_geometry((n, n, n), np.diag([h, h, h, 1.0]))
    pos = (0.1, -0.05, 0.0)
    light = PointLight(tuple(p + 1.0 for p in pos), (1.0, 1.0, 1.0))  # world: index · h, box at 0
    pl = np.array(light.position) / h
    # exact optical depth from the light on a light grid equal to the data grid
    idx = np.indices((n, n, n)).transpose(1, 2, 3, 0) * h
    tau = np.zeros((n, n, n))  # a thin medium's τ is not needed exactly: the same τ feeds both solves
    tau += 0.5 * np.linalg.norm(idx - np.array(light.position), axis=-1)
    grid = SimpleNamespace(lo=np.zeros(3), inv_step=np.ones(3))
    med = DiffusionMedium.from_arrays(sig, alb)
    E, om = direct_irradiance(light, geo, tau, grid, sigma_t=sig)
    Q0, _ = source_in_medium(med, 0.0, E, om, first_moment=False)
    full = solve_in_medium(med, 0.0, (h, h, h), Q0, tol=1e-6)
    co = dc.Coarsening.of(geo)
    assert co.shape == (33, 33, 33)
    floor = 1.0 / mean_chord((n, n, n), np.full(3, h))

    def solve(m, sp, q0, q1, x0):
        return solve_in_medium(m, 0.0, sp, q0, q1, x0=x0, tol=1e-6, sigma_floor=floor)

    e, _, power = unit_irradiance(light, geo, tau, grid, sigma_t=sig, direction=False)
    assert np.allclose(e[..., None] * power, E)
    sol = dc.solve_coarse(solve, med, co.medium(med), co, 0.0, (h, h, h), [(e, power)], None, [pl], floor=floor,
                          tol=1e-6)
    assert sol.flux is None and sol.phi.dtype == np.float32
    assert sol.phi.shape == full.phi.shape
    ss = sig[..., None] * alb
    d = np.max(np.abs(np.indices((n, n, n)).transpose(1, 2, 3, 0) - pl), axis=-1)

    def err(mask):
        m = mask[..., None] & np.ones(3, bool)
        return np.sum(ss[m] * np.abs(sol.phi[m] - full.phi[m])) / np.sum(ss[m] * full.phi[m])

    assert err(d < 8) < 5e-3
    assert err(d >= 0) < 2e-2
    assert np.allclose(sol.power["source"], full.power["source"], rtol=1e-2)


def test_thin_enough_rule():
    sig = np.full((160, 160, 160), 1.0, np.float32)
    assert dc.thin_enough(sig, (0.2, 0.2, 0.2))  # σt·2h = 0.4
    assert not dc.thin_enough(sig, (0.3, 0.3, 0.3))  # 0.6
    sig[:, :, :2] = 100.0  # 1.25 % of the nodes dense: over the 99.9th percentile
    assert not dc.thin_enough(sig, (0.2, 0.2, 0.2))
    sig[:, :, :2] = 1.0
    sig[:4, :4, :4] = 100.0  # a few dense voxels pass
    assert dc.thin_enough(sig, (0.2, 0.2, 0.2))
    assert not dc.thin_enough(sig[:100], (0.01, 0.01, 0.01))  # too small a grid


def test_doctests():
    import doctest

    res = doctest.testmod(dc, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.failed == 0 and res.attempted > 0


def test_coarse_solve_with_a_first_moment_source():
    """g ≠ 0 (a render keeps the full resolution there, but the function takes it): the first-moment
    source is restricted, F's local part 3DQ1 is the data grid's own, and φ stays within 2 % of the
    full-resolution solve (σs-weighted; measured 0.04 %)."""
    from pv_ambient.stages.diffusion.sources import direct_irradiance, source_in_medium
    from types import SimpleNamespace

    n, g = 65, 0.5
    sig, alb, h = _cloud(n)
    geo = make_geometry((n, n, n), np.diag([h, h, h, 1.0]))
    light = PointLight((1.1, 0.95, 1.0), (1.0, 1.0, 1.0))
    pl = np.array(light.position) / h
    idx = np.indices((n, n, n)).transpose(1, 2, 3, 0) * h
    tau = 0.5 * np.linalg.norm(idx - np.array(light.position), axis=-1)
    grid = SimpleNamespace(lo=np.zeros(3), inv_step=np.ones(3))
    med = DiffusionMedium.from_arrays(sig, alb)
    E, om = direct_irradiance(light, geo, tau, grid, sigma_t=sig)
    Q0, Q1 = source_in_medium(med, g, E, om)
    assert Q1 is not None
    # float64 sources like the float64 albedo: the solver's kernels of an all-float64 call (as
    # tests/stages/test_diffusion.py's), not a float32-source mix compiled for this test alone
    Q0, Q1 = Q0.astype(np.float64), Q1.astype(np.float64)
    full = solve_in_medium(med, g, (h, h, h), Q0, Q1, tol=1e-6)
    co = dc.Coarsening.of(geo)
    floor = 1.0 / mean_chord((n, n, n), np.full(3, h))

    def solve(m, sp, q0, q1, x0):
        return solve_in_medium(m, g, sp, q0, q1, x0=x0, tol=1e-6, sigma_floor=floor)

    sol = dc.solve_coarse(solve, med, co.medium(med), co, g, (h, h, h), [(E[..., 0], np.ones(3))], Q1, [pl],
                          floor=floor, tol=1e-6)
    ss = sig[..., None] * alb
    err = np.sum(ss * np.abs(sol.phi - full.phi)) / np.sum(ss * full.phi)
    assert err < 2e-2
    assert sol.flux.shape == full.flux.shape and np.isfinite(sol.flux).all()


@pytest.mark.parametrize("association", ["point", "cell"])
def test_solve_for_light_on_a_rotated_grid(association, monkeypatch):
    """:func:`solve_for_light` with ``coarse``: a rotated grid of point or cell data, a point light
    inside (its box 12 samples wide, so that it is cut on every side) and a directional light,
    against the same call at full resolution (σs-weighted φ within 1.5 %; measured 0.7–1.2 %). A box
    that covers the whole grid solves it in full."""
    from types import SimpleNamespace
    from pv_ambient.inputs.lights import DirectionalLight
    from pv_ambient.stages.diffusion import solve_for_light

    n = 66
    sig, alb, h = _cloud(n - 1 if association == "cell" else n, albedo_dtype=np.float32)
    c, s = np.cos(0.4), np.sin(0.4)
    M = np.eye(4)
    M[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) * h
    M[:3, 3] = (0.2, -0.1, 0.3)
    geo = make_geometry((n, n, n), M, association=association)
    assert geo.shape == sig.shape
    med = DiffusionMedium.from_arrays(sig, alb)
    grid = SimpleNamespace(lo=np.asarray(geo.box_lo, np.float64), inv_step=np.ones(3))
    idx = np.indices(sig.shape).transpose(1, 2, 3, 0)
    centre = np.array(sig.shape, np.float64) / 2 - 0.3
    lights = [PointLight(tuple(geo.index_to_world[:3, :3] @ centre + geo.index_to_world[:3, 3]), 1.0),
              DirectionalLight((0.3, -0.2, -1.0), 0.5)]
    taus = [0.5 * np.linalg.norm(idx - centre, axis=-1) * h, 0.5 * (idx[..., 2].max() - idx[..., 2]) * h]
    co = dc.Coarsening.of(geo)
    ss = sig[..., None] * alb
    monkeypatch.setattr(dc, "PATCH_RADIUS", 12)
    for lt, tau in zip(lights, taus):
        kw = dict(medium=med, geometry=geo, tau=tau, light_grid=grid, tol=1e-6)
        full = solve_for_light(lt, 0.0, **kw)
        crs = solve_for_light(lt, 0.0, coarse=(co, co.medium(med)), **kw)
        err = np.sum(ss * np.abs(crs.phi - full.phi)) / np.sum(ss * full.phi)
        assert err < 1.5e-2, (association, lt, err)
        assert crs.phi.dtype == np.float32 and crs.flux is None
    monkeypatch.setattr(dc, "PATCH_RADIUS", 40)  # the box is the grid: the full-resolution answer
    kw = dict(medium=med, geometry=geo, tau=taus[0], light_grid=grid, tol=1e-6)
    full = solve_for_light(lights[0], 0.0, **kw)
    crs = solve_for_light(lights[0], 0.0, coarse=(co, co.medium(med)), **kw)
    assert np.allclose(crs.phi, full.phi, rtol=1e-4, atol=1e-6 * full.phi.max())


def test_coarse_medium_keeps_scattering():
    """The coarse medium's σs = a·σt is the restriction of the data grid's (the albedo is the σt-weighted
    mean), its albedo 0 where σt is 0."""
    from pv_ambient.inputs.grid import GridGeometry

    rng = np.random.default_rng(2)
    sig = rng.random((9, 9, 9))
    sig[:3] = 0.0
    alb = rng.random((9, 9, 9, 3)).astype(np.float32)
    geo = GridGeometry((9, 9, 9), np.diag([0.25, 0.25, 0.25, 1.0]), np.zeros(3), np.full(3, 8.0))
    co = dc.Coarsening.of(geo)
    mc = co.medium(DiffusionMedium.from_arrays(sig, alb))
    want = co.restrict(sig[..., None] * alb)
    assert np.allclose(mc.albedo * mc.sigma_t[..., None], want, rtol=1e-6, atol=1e-12)
    assert np.all(mc.albedo[mc.sigma_t == 0] == 0) and np.any(mc.sigma_t == 0)
    assert mc.albedo.dtype == np.float32


@pytest.mark.parametrize("albedo_channels, power", [(3, (2.0, 1.0, 0.5)), (1, (2.0, 1.0, 0.5)), (1, (3.0,))])
def test_restricted_sources_equal_the_restricted_product(albedo_channels, power):
    """The first-collision source restricted without forming it (one read of each tap for all the
    channels) equals the restriction of ``σt·a_c·e·power_c`` formed on the data grid, summed over
    two lights."""
    from pv_ambient.inputs.grid import GridGeometry

    rng = np.random.default_rng(5)
    shape = (11, 9, 10)
    sig = rng.random(shape)
    alb = rng.random(shape + (albedo_channels,)).astype(np.float32)
    geo = GridGeometry(shape, np.diag([0.25, 0.5, 0.25, 1.0]), np.zeros(3), np.array(shape, float) - 1.0)
    co = dc.Coarsening.of(geo)
    medium = DiffusionMedium.from_arrays(sig, alb if albedo_channels == 3 else alb[..., 0])
    lights = [(rng.random(shape), np.asarray(power)), (rng.random(shape), 0.5 * np.asarray(power))]
    got = co.restrict_sources(medium, lights)
    a = alb.astype(np.float64)
    want = sum(co.restrict(sig[..., None] * a * e[..., None] * p) for e, p in lights)
    assert got.shape == co.shape + (len(power),)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-14)


def test_sweeps_remainder_on_the_coarse_grid():
    """:func:`solve_for_light` with transport sweeps and ``coarse_remainder``: the light scattered
    more than K = 2 times diffused on the coarse grid, a point light inside a 65³ cloud thin enough
    per coarse cell (no box around the light: order K's fluence is smooth there), against the whole
    solve at the data resolution: σs-weighted φ within 1 % (measured 0.60 %; 0.77 % at K = 1,
    0.37 % at K = 4), φ float64 and F float32 on the data grid. A phase function with g ≠ 0 is
    refused (its first-moment source has voxel-scale structure)."""
    from types import SimpleNamespace
    from pv_ambient.stages.diffusion import solve_for_light

    n = 65
    sig, alb, h = _cloud(n, albedo_dtype=np.float32)
    assert np.percentile(sig, 99.9) * 2 * h <= dc.COARSE_SIGMA_H  # thin enough per coarse cell
    geo = make_geometry((n, n, n), np.diag([h, h, h, 1.0]))
    med = DiffusionMedium.from_arrays(sig, alb)
    grid = SimpleNamespace(lo=np.asarray(geo.box_lo, np.float64), inv_step=np.ones(3))
    idx = np.indices(sig.shape).transpose(1, 2, 3, 0)
    centre = np.array(sig.shape, np.float64) / 2 - 0.3
    lt = PointLight(tuple(geo.index_to_world[:3, :3] @ centre + geo.index_to_world[:3, 3]), 1.0)
    tau = 0.5 * np.linalg.norm(idx - centre, axis=-1) * h
    co = dc.Coarsening.of(geo)
    kw = dict(medium=med, geometry=geo, tau=tau, light_grid=grid, tol=1e-6, sweep_orders=2,
              sweep_directions=16, flux_limited=True)
    full = solve_for_light(lt, 0.0, **kw)
    crs = solve_for_light(lt, 0.0, coarse_remainder=(co, co.medium(med)), **kw)
    ss = sig[..., None] * alb
    err = np.sum(ss * np.abs(crs.phi - full.phi)) / np.sum(ss * full.phi)
    assert err < 1e-2, err
    assert crs.phi.shape == full.phi.shape and crs.phi.dtype == np.float64
    assert crs.flux.shape == full.flux.shape and crs.flux.dtype == np.float32
    with pytest.raises(ValueError, match="isotropic"):
        solve_for_light(lt, 0.5, coarse_remainder=(co, co.medium(med)), **kw)
