"""Tests pv_ambient/stages/propagation.py, the light volumes: optical depth by the upwind sweep against
exact chords; vacuum and fall-off."""
import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient.inputs.grid import Volume
from pv_ambient.inputs.camera import Camera
from pv_ambient.inputs.lights import DirectionalLight, PointLight
from pv_ambient.stages.propagation import make_light_grid, optical_depth, sigma_on_grid
from pv_ambient.inputs.transfer import TransferFunction

N = 33
SIGMA = 2.0


def homogeneous(sigma=SIGMA, n=N):
    vol = Volume(np.ones((n, n, n), np.float32), spacing=(1 / (n - 1),) * 3)
    return vol, TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2 * sigma]).resolve(vol)


def node_points(n=N):
    k = np.arange(n) / (n - 1)
    return np.stack(np.meshgrid(k, k, k, indexing="ij"), -1)


def chord_in_unit_box(a, b):
    """Length inside [0, 1]³ of the segments from a (3,) to every b (..., 3) (exact slab test)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = (0 - a) / d
        hi = (1 - a) / d
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    lo = np.where(np.isnan(lo), -np.inf, lo)
    hi = np.where(np.isnan(hi), np.inf, hi)
    t0 = np.clip(lo.max(-1), 0, 1)
    t1 = np.clip(hi.min(-1), 0, 1)
    return np.linalg.norm(d, axis=-1) * np.clip(t1 - t0, 0, None)


@pytest.mark.parametrize("light_pos", [(0.5, 0.5, 0.5), (0.31, 0.52, 0.77), (-0.5, 0.3, 0.4), (0.5, 0.5, 3.0)])
def test_point_light_optical_depth(light_pos):
    vol, optics = homogeneous()
    grid = make_light_grid(vol.geometry, 1.0)
    tau = optical_depth(sigma_on_grid(optics, grid), grid, vol.geometry, PointLight(light_pos))
    exact = SIGMA * chord_in_unit_box(np.array(light_pos), node_points())
    # the sweep interpolates the path-mean extinction, exact in a homogeneous medium
    assert np.max(np.abs(tau - exact)) < 1e-5


def test_directional_light_optical_depth():
    vol, optics = homogeneous()
    grid = make_light_grid(vol.geometry, 1.0)
    d = np.array([0.2, -0.4, 1.0])
    d /= np.linalg.norm(d)
    tau = optical_depth(sigma_on_grid(optics, grid), grid, vol.geometry, DirectionalLight(d))
    pts = node_points()
    far = pts - 10.0 * d  # a point far toward the light
    exact = SIGMA * np.array([chord_in_unit_box(f, p[None])[0] for f, p in zip(far.reshape(-1, 3), pts.reshape(-1, 3))]
                             ).reshape(tau.shape)
    assert np.max(np.abs(tau - exact)) < 1e-5


@pytest.mark.parametrize("light", [PointLight((0.2, 0.7, 0.4)), PointLight((1.5, -0.4, 0.3)),
                                   DirectionalLight((0.3, 0.5, -0.8))])
def test_heterogeneous_optical_depth_against_quadrature(light):
    # σ(x) = 1 + 3x + 2 y z sampled on the grid (trilinear reproduces it up to the yz term)
    n = N
    k = np.arange(n) / (n - 1)
    X, Y, Z = np.meshgrid(k, k, k, indexing="ij")
    field = (1 + 3 * X + 2 * Y * Z).astype(np.float32)
    vol = Volume(field, spacing=(1 / (n - 1),) * 3)
    from pv_ambient.inputs.transfer import _grid_optics

    optics = _grid_optics(field, np.zeros(field.shape + (6,), np.float32))
    grid = make_light_grid(vol.geometry, 1.0)
    tau = optical_depth(sigma_on_grid(optics, grid), grid, vol.geometry, light)
    rng = np.random.default_rng(5)
    idx = rng.integers(0, n, (40, 3))
    pts = idx / (n - 1)
    for (i, j, kk), p in zip(idx, pts):
        if isinstance(light, PointLight):
            a = np.array(light.position)
        else:
            a = p - 5.0 * np.array(light.direction)
        d = p - a
        with np.errstate(divide="ignore", invalid="ignore"):
            lo, hi = np.minimum(-a / d, (1 - a) / d), np.maximum(-a / d, (1 - a) / d)
        t0 = np.clip(np.nanmax(lo), 0, 1)
        t1 = np.clip(np.nanmin(hi), 0, 1)
        ts = np.linspace(t0, t1, 4001)
        q = a + ts[:, None] * d
        s = 1 + 3 * q[:, 0] + 2 * q[:, 1] * q[:, 2]
        exact = np.trapezoid(s, ts) * np.linalg.norm(d)
        # measured: ≤ 1 % (interpolation of the path-mean extinction across layers)
        assert tau[i, j, kk] == pytest.approx(exact, rel=0.01, abs=1e-6)


def test_vacuum_gives_unit_transmittance_and_inverse_square():
    n = 9
    vol = Volume(np.zeros((n, n, n), np.float32), spacing=(0.25,) * 3)
    tf = TransferFunction.from_table([0.0, 1.0], sigma_t=[0.0, 0.0])
    r = pa.Renderer(vol, transfer_function=tf, lights=[PointLight((1, 1, 5), 2.0), DirectionalLight((0, 1, 0))])
    grid = r.stages.light_grid()
    for lt in r.lights:
        assert np.all(r.stages.optical_depth(lt, grid) == 0.0)


def test_single_scattering_point_light_falloff_is_exact():
    # a thin homogeneous slab with albedo 1, isotropic phase, σ tiny: radiance ≈ ∫ σ I/(4π d²) ds
    from scipy.integrate import quad

    n = 17
    sig = 1e-4
    vol = Volume(np.ones((n, n, n), np.float32), spacing=(1 / (n - 1),) * 3)
    tf = TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2 * sig], albedo=(1.0, 1.0, 1.0))
    lp = np.array([0.3, 0.6, 1.8])  # outside the box
    r = pa.Renderer(vol, transfer_function=tf, lights=[PointLight(lp, 3.0)])
    cam = Camera((0.5, -2, 0.5), (0.5, 0.5, 0.5), (0, 0, 1), view_angle=10)
    res = r.render(camera=cam, window_size=(3, 3), model="single_scattering", step=0.001, early_termination=0)
    o, d = cam.rays((3, 3))
    o, d = o[1, 1], d[1, 1]
    with np.errstate(divide="ignore"):
        t0 = np.max(np.minimum(-o / d, (1 - o) / d))
        t1 = np.min(np.maximum(-o / d, (1 - o) / d))
    f = lambda t: sig * 3.0 / np.sum((o + t * d - lp) ** 2) / (4 * np.pi)  # noqa: E731
    expected = quad(f, t0, t1)[0]
    assert res.radiance[1, 1, 0] == pytest.approx(expected, rel=2e-3)


@pytest.mark.parametrize("driver", ["rows", "nodes"])
@pytest.mark.parametrize("light_pos", [(0.5, 0.5, 0.5), (0.21, 0.77, 0.43), (0.0, 0.25, 0.5), (-0.3, 0.6, 0.25),
                                       (0.5, 1.7, -0.2), (0.5, 0.5, 0.0)])
def test_pyramid_sweep_equals_whole_layer_sweep(light_pos, driver, monkeypatch):
    # a point light's sweeps compute only the nodes they write or read (sweep_reach); whole layers
    # (reach = inf everywhere) must give the same bits on a heterogeneous medium with a
    # non-cubic grid and uneven spacing
    from pv_ambient.stages import propagation

    rng = np.random.default_rng(11)
    field = rng.random((47, 41, 17)).astype(np.float32) * 3.0  # flat: pyramids wider than the z extent
    vol = Volume(field, spacing=(1 / 46, 1 / 40 * 1.3, 1 / 32))
    from pv_ambient.inputs.transfer import _grid_optics

    optics = _grid_optics(field, np.zeros(field.shape + (6,), np.float32))
    grid = make_light_grid(vol.geometry, 1.0)
    sig = sigma_on_grid(optics, grid)
    fast = optical_depth(sig, grid, vol.geometry, PointLight(light_pos), driver=driver)
    monkeypatch.setattr(propagation, "sweep_reach", lambda shape, light, axis, sign, jump: np.full((shape[axis], 2), np.inf))
    whole = optical_depth(sig, grid, vol.geometry, PointLight(light_pos), driver=driver)
    assert np.array_equal(fast, whole)


@pytest.mark.parametrize("jump", [1, 2, 5])
def test_pyramid_sweep_equals_whole_layer_sweep_for_any_jump(jump, monkeypatch):
    # the reach's integer ranges for other jumps and lights off the nodes (seeded random positions,
    # inside and outside the box), both drivers
    from pv_ambient.stages import propagation

    rng = np.random.default_rng(jump)
    field = rng.random((23, 31, 19)).astype(np.float32) * 4.0
    vol = Volume(field, spacing=(1 / 22, 1 / 30, 1 / 24))
    from pv_ambient.inputs.transfer import _grid_optics

    optics = _grid_optics(field, np.zeros(field.shape + (6,), np.float32))
    grid = make_light_grid(vol.geometry, 1.0)
    sig = sigma_on_grid(optics, grid)
    lights = [PointLight(tuple(p)) for p in rng.uniform(-0.2, 1.2, (4, 3))]
    fast = {(i, d): optical_depth(sig, grid, vol.geometry, lt, jump=jump, driver=d)
            for i, lt in enumerate(lights) for d in ("rows", "nodes")}
    monkeypatch.setattr(propagation, "sweep_reach", lambda shape, light, axis, sign, jump: np.full((shape[axis], 2), np.inf))
    for (i, d), tau in fast.items():
        assert np.array_equal(tau, optical_depth(sig, grid, vol.geometry, lights[i], jump=jump, driver=d))


def test_point_light_sweeps_compute_few_nodes_beyond_their_pyramids():
    """Why: the reach once widened each layer by 1.5 cells per ``jump`` layers toward the light, and
    a point light's six sweeps computed 1.3× the grid's nodes; by exact integer ranges of the nodes
    the layers ahead read, at most 1.1× on a 96³ grid."""
    from pv_ambient._kernels.lightvol import lateral_range
    from pv_ambient.stages.propagation import JUMP, sweep_reach

    shape = (96, 96, 96)
    for light in [(47.5, 47.5, 47.5), (30.2, 61.7, 50.0)]:
        total = 0
        for a in range(3):
            lat = [i for i in range(3) if i != a]
            for sign in (1, -1):
                reach = sweep_reach(shape, light, a, sign, JUMP)
                for k in range(shape[a]):
                    if reach[k, 0] < 0:
                        continue
                    b0, b1 = lateral_range(shape[lat[0]], light[lat[0]], reach[k, 0])
                    c0, c1 = lateral_range(shape[lat[1]], light[lat[1]], reach[k, 1])
                    total += (b1 - b0 + 1) * (c1 - c0 + 1)
        assert total <= 1.1 * np.prod(shape)


# -- the CPU row driver (pv_ambient/_kernels/lightsweep.py) against exact chords and the per-node driver

#: A non-cubic unit box with unequal cells: every sweep axis of the row driver runs on its own
#: permuted layout.
BOX = (29, 23, 19)
AXIS_DIRECTIONS = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1), (0.3, -0.5, -0.8),
                   (-0.7, 0.7, 0.1), (1, 1, 1)]


def unit_box_volume(field):
    return Volume(field, spacing=tuple(1 / (n - 1) for n in field.shape))


def box_nodes(shape=BOX):
    ax = [np.arange(n) / (n - 1) for n in shape]
    return np.stack(np.meshgrid(*ax, indexing="ij"), -1)


@pytest.mark.parametrize("driver", ["rows", "nodes"])
@pytest.mark.parametrize("light", [PointLight((0.5, 0.5, 0.5)), PointLight((0.13, 0.81, 0.36)), PointLight((1.0, 0.2, 0.7)),
                                   PointLight((-0.4, 0.3, 0.6)), PointLight((0.5, 0.45, 2.5))]
                         + [DirectionalLight(np.array(d) / np.linalg.norm(d)) for d in AXIS_DIRECTIONS])
def test_homogeneous_box_optical_depth_is_exact(light, driver):
    """A homogeneous medium: τ = σ × the chord inside the box toward the light, for a point light inside,
    on a face of and outside the box and a directional light along each axis and sign and obliquely.
    Both drivers interpolate the path-mean extinction, exact in a homogeneous medium: the bound,
    1e-5 of τ ≤ 3.5, is float32 storage plus the trapezoid's rounding."""
    vol = unit_box_volume(np.ones(BOX, np.float32))
    optics = TransferFunction.from_table([0.0, 2.0], sigma_t=[0.0, 2 * SIGMA]).resolve(vol)
    grid = make_light_grid(vol.geometry, 1.0)
    tau = optical_depth(sigma_on_grid(optics, grid), grid, vol.geometry, light, driver=driver)
    pts = box_nodes()
    if isinstance(light, PointLight):
        exact = SIGMA * chord_in_unit_box(np.array(light.position), pts)
    else:
        far = pts - 10.0 * np.array(light.direction)  # a point far toward the light
        exact = SIGMA * np.array([chord_in_unit_box(f, p[None])[0] for f, p in
                                  zip(far.reshape(-1, 3), pts.reshape(-1, 3))]).reshape(tau.shape)
    assert np.max(np.abs(tau - exact)) < 1e-5


#: Row driver vs per-node driver: the same samples summed in another order, stored as float32
#: (measured ≤ 1.1e-7 of the largest τ).
ROWS_VS_NODES = 1e-6


@pytest.mark.parametrize("light", [PointLight((0.5, 0.5, 0.5)), PointLight((0.21, 0.77, 0.43)), PointLight((0.0, 0.25, 0.5)),
                                   PointLight((-0.3, 0.6, 0.25)), PointLight((0.5, 1.7, -0.2)), PointLight((0.5, 0.5, 0.0))]
                         + [DirectionalLight(np.array(d) / np.linalg.norm(d)) for d in AXIS_DIRECTIONS])
def test_row_driver_equals_node_driver_on_random_medium(light):
    """The CPU row driver computes the per-node rule (the GPU's kernel, lightvol.sweep_node) on a
    random heterogeneous medium (fixed seed), non-cubic grid, uneven spacing: equal up to rounding."""
    from pv_ambient.inputs.transfer import _grid_optics

    field = np.random.default_rng(3).random((47, 41, 29)).astype(np.float32) * 3.0
    vol = Volume(field, spacing=(1 / 46, 1 / 40 * 1.3, 1 / 32))
    optics = _grid_optics(field, np.zeros(field.shape + (6,), np.float32))
    grid = make_light_grid(vol.geometry, 1.0)
    sig = sigma_on_grid(optics, grid)
    rows = optical_depth(sig, grid, vol.geometry, light, driver="rows")
    nodes = optical_depth(sig, grid, vol.geometry, light, driver="nodes")
    assert np.max(np.abs(rows - nodes)) <= ROWS_VS_NODES * np.max(np.abs(nodes))
    assert np.all((rows == 0) == (nodes == 0))  # the same nodes written (the point light's own node: 0)


def test_driver_is_checked():
    vol, optics = homogeneous(n=5)
    grid = make_light_grid(vol.geometry, 1.0)
    with pytest.raises(ValueError, match="driver"):
        optical_depth(sigma_on_grid(optics, grid), grid, vol.geometry, PointLight((0.5, 0.5, 0.5)), driver="fast")


@pytest.mark.parametrize("jump", [0, 1, 2, 7])
@pytest.mark.parametrize("shape", [(23, 19, 17), (9, 2, 13)])
@pytest.mark.parametrize("light", [PointLight((0.4, 0.6, 0.3)), PointLight((1.3, 0.5, -0.2)),
                                   DirectionalLight(np.array((0.2, 0.9, -0.4)) / np.linalg.norm((0.2, 0.9, -0.4))),
                                   DirectionalLight((0.0, 0.0, 1.0))])
def test_row_driver_equals_node_driver_for_any_jump_and_thin_grids(light, shape, jump):
    """The row driver's grouping of layers (a layer reads the layer ``jump`` back) and its runs hold
    for every ``jump``, and on a grid two nodes thick."""
    from pv_ambient.inputs.transfer import _grid_optics

    field = np.random.default_rng(7).random(shape).astype(np.float32) * 2.0
    vol = Volume(field, spacing=(0.05, 0.07, 0.04))
    optics = _grid_optics(field, np.zeros(field.shape + (6,), np.float32))
    grid = make_light_grid(vol.geometry, 1.0)
    sig = sigma_on_grid(optics, grid)
    lt = PointLight(tuple(np.array(light.position) * np.array(vol.geometry.box_hi - vol.geometry.box_lo)
                          + vol.geometry.box_lo)) if isinstance(light, PointLight) else light
    rows = optical_depth(sig, grid, vol.geometry, lt, jump=jump, driver="rows")
    nodes = optical_depth(sig, grid, vol.geometry, lt, jump=jump, driver="nodes")
    assert np.max(np.abs(rows - nodes)) <= ROWS_VS_NODES * np.max(np.abs(nodes))
