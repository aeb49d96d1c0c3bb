"""Tests pv_ambient/inputs/transfer.py: same classification as add_volume, opacity→σt, physical arrays,
NaN policy."""
import numpy as np
import pytest
import pyvista as pv
from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
from vtkmodules.vtkRenderingCore import vtkColorTransferFunction, vtkVolumeProperty

from pv_ambient.inputs.grid import volume_from_image
from pv_ambient.inputs.transfer import COL_COLOR, COL_SIGMA, MODE_GRID, TransferFunction, pyvista_default_unit_distance


@pytest.fixture
def grid():
    g = pv.ImageData(dimensions=(9, 7, 5), spacing=(0.3, 0.2, 0.5), origin=(-1, 0, 2))
    g["density"] = np.linspace(-2.0, 3.0, g.n_points).astype(np.float32)
    return g


def test_colormap_args_match_add_volume_actor(grid):
    kw = dict(cmap="magma", opacity="sigmoid", clim=(-1.0, 2.5), opacity_unit_distance=0.7)
    pl = pv.Plotter(off_screen=True)
    actor = pl.add_volume(grid, **kw)
    a = TransferFunction(**kw).resolve(grid)
    b = TransferFunction.from_volume_property(actor).resolve(grid)
    assert a.table.shape == b.table.shape and a.table.shape[0] >= 1024
    assert np.allclose(a.table, b.table, atol=1e-6)
    assert (a.lut_lo, a.lut_inv) == pytest.approx((b.lut_lo, b.lut_inv))
    pl.close()


def test_default_unit_distance_is_pyvistas(grid):
    pl = pv.Plotter(off_screen=True)
    actor = pl.add_volume(grid, opacity="linear")
    ours = pyvista_default_unit_distance(volume_from_image(grid).geometry)
    assert ours == pytest.approx(actor.prop.GetScalarOpacityUnitDistance(), rel=1e-12)
    # and the TF built with no unit distance uses it: σt = −ln(1 − α)/u at the top entry
    o = TransferFunction(opacity="linear").resolve(grid)
    alpha = min(1.0, 255 / 255 * 0.998)
    assert o.table[-1, COL_SIGMA] == pytest.approx(-np.log1p(-alpha) / ours, rel=1e-5)
    pl.close()


def test_sigma_from_volume_property_nodes():
    ctf = vtkColorTransferFunction()
    ctf.AddRGBPoint(0.0, 1, 0, 0)
    ctf.AddRGBPoint(10.0, 0, 0, 1)
    otf = vtkPiecewiseFunction()
    otf.AddPoint(0.0, 0.0)
    otf.AddPoint(10.0, 0.5)
    prop = vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(2.0)
    g = pv.ImageData(dimensions=(3, 3, 3))
    g["s"] = np.linspace(0, 10, 27)
    o = TransferFunction.from_volume_property(prop).resolve(g)
    # entry for scalar 4.0: alpha 0.2 → σt = −ln(0.8)/2 (exact on the table's nodes, ±1 entry linear)
    k = (4.0 - o.lut_lo) * o.lut_inv
    sig = np.interp(k, np.arange(o.table.shape[0]), o.table[:, COL_SIGMA])
    assert sig == pytest.approx(-np.log(0.8) / 2.0, rel=1e-3)
    col = [np.interp(k, np.arange(o.table.shape[0]), o.table[:, COL_COLOR + c]) for c in range(3)]
    assert col == pytest.approx([0.6, 0.0, 0.4], abs=2e-3)


def test_density_scale(grid):
    o = TransferFunction(opacity=0.5, density_scale=4.0).resolve(grid)
    assert np.allclose(o.table[:, COL_SIGMA], 4.0 * 127 / 255, rtol=1e-6)  # PyVista's LUT opacity is 8-bit: 0.5 → 127


def test_albedo_and_emission_follow_colour(grid):
    o = TransferFunction(cmap="viridis", albedo=0.5, emission=2.0, density_scale=1.0).resolve(grid)
    col = o.table[:, COL_COLOR:COL_COLOR + 3]
    assert np.allclose(o.table[:, 1:4], 0.5 * col, atol=1e-7)
    assert np.allclose(o.table[:, 4:7], 2.0 * col, atol=1e-6)
    o2 = TransferFunction(albedo=(0.1, 0.2, 0.3), density_scale=1.0).resolve(grid)
    assert np.allclose(o2.table[:, 1:4], [0.1, 0.2, 0.3])


def test_physical_arrays():
    g = pv.ImageData(dimensions=(4, 4, 4))
    g["sigma_t"] = np.linspace(0, 5, 64)
    g["albedo"] = np.full(64, 0.7)
    g["emission"] = np.tile([1.0, 0.5, 0.0], (64, 1))
    o = TransferFunction.physical().resolve(g)
    assert o.mode == MODE_GRID
    assert np.allclose(o.field.ravel(order="F"), g["sigma_t"])
    assert np.allclose(o.aux[..., 0:3], 0.7) and np.allclose(o.aux[..., 3:6], [1.0, 0.5, 0.0])
    g["albedo"] = np.full(64, 1.5)
    with pytest.raises(ValueError, match="'albedo' must be <= 1"):
        TransferFunction.physical().resolve(g)
    del g.point_data["albedo"]
    with pytest.raises(ValueError, match="needs a point array 'albedo'"):
        TransferFunction.physical().resolve(g)


def test_nan_policy(grid):
    grid["density"][5] = np.nan
    grid["density"][7] = np.inf
    with pytest.raises(ValueError, match="2 non-finite values.*nan_policy='vacuum'"):
        TransferFunction(density_scale=1.0).resolve(grid)
    o = TransferFunction(density_scale=1.0, clim=(-2, 3)).resolve(grid, nan_policy="vacuum")
    assert o.mode == MODE_GRID
    flat = o.field.ravel(order="F")
    assert flat[5] == 0 and flat[7] == 0 and np.all(np.isfinite(flat))
    with pytest.raises(ValueError, match="nan_policy"):
        TransferFunction().resolve(grid, nan_policy="ignore")


@pytest.mark.parametrize("kwargs, err, match", [
    (dict(opacity_unit_distance=1.0, density_scale=1.0), ValueError, "not both"),
    (dict(albedo=1.5), ValueError, "albedo"),
    (dict(albedo=(0.5, 2.0, 0.1)), ValueError, "albedo"),
    (dict(opacity_unit_distance=0.0), ValueError, "opacity_unit_distance"),
    (dict(clim=(2.0, 1.0)), ValueError, "clim"),
    (dict(emission=-1.0), ValueError, "emission"),
])
def test_bad_arguments(kwargs, err, match):
    with pytest.raises(err, match=match):
        TransferFunction(**kwargs)


def test_bad_opacity_name(grid):
    with pytest.raises(ValueError, match="opacity"):
        TransferFunction(opacity="not-a-ramp").resolve(grid)


def test_classified_grids_match_numpy_interp():
    # sigma_grid/albedo_grid (a parallel kernel) against np.interp of the table over its entries,
    # scalars below, inside and above the table's range
    from pv_ambient.inputs.grid import Volume

    rng = np.random.default_rng(4)
    s = (rng.random((13, 11, 7)) * 1.4 - 0.2).astype(np.float32)
    tf = TransferFunction(cmap="viridis", clim=(0.0, 1.0), density_scale=3.0, albedo=(0.2, 0.5, 0.9))
    optics = tf.resolve(Volume(s))
    table = optics.table.astype(np.float64)
    u = np.clip((s.astype(np.float64) - optics.lut_lo) * optics.lut_inv, 0, table.shape[0] - 1)
    entries = np.arange(table.shape[0])
    sig = np.interp(u, entries, table[:, 0])
    alb = np.stack([np.interp(u, entries, table[:, 1 + c]) for c in range(3)], -1)
    assert optics.sigma_grid().dtype == np.float32 and optics.albedo_grid().shape == s.shape + (3,)
    np.testing.assert_allclose(optics.sigma_grid(), sig, rtol=1e-6, atol=1e-7 * sig.max())
    np.testing.assert_allclose(optics.albedo_grid(), alb, rtol=1e-6, atol=1e-7)
    assert len(np.unique(sig)) > 100 and sig.min() == 0.0 and not np.allclose(alb[..., 0], alb[..., 2])


def test_large_fields_copied_in_parallel_equal_numpy_and_bounds_the_used_entries():
    # a grid's x-fastest point data (Fortran-ordered) of any dtype, copied to C-ordered float32 by
    # the parallel kernel: NumPy's copy exactly; and the table bounds that model="auto" reads
    # (sigma_max, albedo_max) from the field's extremes equal those over every value
    from pv_ambient.inputs.grid import as_float32_c
    from pv_ambient.inputs.transfer import COL_ALBEDO

    rng = np.random.default_rng(5)
    for a in (np.asfortranarray(rng.integers(-300, 300, (70, 50, 40)).astype(np.int16)),
              np.asfortranarray(rng.random((41, 33, 65))), rng.random((64, 64, 20)).astype(np.float32)):
        got = as_float32_c(a)
        assert got.flags.c_contiguous and got.dtype == np.float32
        assert np.array_equal(got, np.ascontiguousarray(a, dtype=np.float32))
    g = pv.ImageData(dimensions=(48, 40, 36))
    g["density"] = rng.uniform(0.2, 0.7, g.n_points).astype(np.float32)
    tf = TransferFunction(cmap="viridis", opacity="linear", clim=(0.0, 1.0))
    optics = tf.resolve(g)
    s = optics.field
    x = np.clip((s - float(optics.lut_lo)) * optics.lut_inv, 0, optics.table.shape[0] - 1)
    used = optics.table[int(np.floor(x.min())):int(np.ceil(x.max())) + 1]
    assert optics.sigma_max == float(used[:, COL_SIGMA].max()) > 0
    assert optics.albedo_max == float(used[used[:, COL_SIGMA] > 0, COL_ALBEDO:COL_ALBEDO + 3].max())
    assert optics.sigma_max < float(optics.table[:, COL_SIGMA].max())  # the clim reaches past the data


def test_scattering_channel_is_sigma_times_the_albedo_channel_to_the_bit():
    # the ball grid's σ·a per channel in one pass (LUT mode) equals NumPy's float32 product of the
    # σt and albedo arrays; a physical transfer function forms that product itself
    g = pv.ImageData(dimensions=(30, 20, 25))
    rng = np.random.default_rng(6)
    g["density"] = rng.uniform(-0.5, 1.5, g.n_points).astype(np.float32)
    optics = TransferFunction(cmap="magma", opacity="sigmoid", clim=(0.0, 1.0)).resolve(g)
    sigma = optics.sigma_grid()
    for c in range(3):
        assert np.array_equal(optics.scattering_channel(c, sigma),
                              np.multiply(sigma, optics.albedo_channel(c), dtype=np.float32))
    assert np.any(optics.scattering_channel(0, sigma) > 0)
