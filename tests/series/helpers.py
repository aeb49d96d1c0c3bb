"""What the series tests share (tests/series and tests/cli/test_series_command.py): a scene, five
time steps on disk, a two-worker LocalCluster, and ``pv-ambient render`` as the reference a frame
must equal (docs/series.rst: each frame is the image ``pv-ambient render`` writes)."""

import json

import numpy as np
import pytest
from PIL import Image

from pv_ambient import cli, datasets

TF = {"kind": "colormap", "cmap": "bone", "clim": [0, 1], "opacity": "linear", "opacity_unit_distance": 0.1,
      "albedo": 0.9, "emission": 0.0}
CAMERA = {"position": [0.4, -3.8, 1.0], "focal_point": [0.0, 0.0, 0.0], "view_up": [0.0, 0.0, 1.0],
          "view_angle": 30.0, "parallel_projection": False, "parallel_scale": 1.0}
N_STEPS = 5


@pytest.fixture(scope="module")
def client():
    """The module's one LocalCluster: 2 worker processes × 1 thread."""
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def steps(tmp_path_factory):
    """Five 24³ time steps of the cloud as .vti files (different seeds)."""
    d = tmp_path_factory.mktemp("steps")
    paths = []
    for s in range(N_STEPS):
        p = d / f"step_{s:02d}.vti"
        datasets.cloud(n=24, seed=s).save(p)
        paths.append(p)
    return paths


def scene_dict(volume, model, size=(32, 24), **extra):
    lit = model != "emission_absorption"  # lights given to EA would (rightly) warn that it ignores them
    return {"version": 1, "volume": str(volume), "transfer_function": TF, "camera": CAMERA,
            **({"lights": [{"kind": "point", "position": [0.0, 0.5, 1.6], "intensity": [3.0, 3.0, 3.0]}]}
               if lit else {}),
            "image": {"width": size[0], "height": size[1]}, "model": model, "quality": "preview",
            "display": {"exposure": 1.0, "tonemap": "reinhard"}, **extra}


def write_scene(path, scene):
    path.write_text(json.dumps(scene))
    return path


def cli_render(scene, tmp, name):
    """``pv-ambient render SCENE.json -o PNG --radiance NPY``: (PNG pixels, radiance)."""
    sp = write_scene(tmp / f"{name}.json", scene)
    png, npy = tmp / f"{name}.png", tmp / f"{name}.npy"
    assert cli.main(["render", str(sp), "-o", str(png), "--radiance", str(npy)]) == 0
    return np.asarray(Image.open(png)), np.load(npy)


def frame(out, i):
    return np.asarray(Image.open(out / f"frame_{i:04d}.png")), np.load(out / f"frame_{i:04d}.npy")


def assert_same(model, got, ref, what):
    (png, rad), (png_ref, rad_ref) = got, ref
    assert rad.dtype == np.float32 and rad.shape == rad_ref.shape
    assert rad_ref.max() > 0, what
    if model == "diffusion":  # the CG solve stops at a relative residual of 1e-6
        np.testing.assert_allclose(rad, rad_ref, rtol=1e-4, atol=1e-6 * rad_ref.max(), err_msg=what)
        assert np.abs(png.astype(int) - png_ref.astype(int)).max() <= 1, what
    else:
        np.testing.assert_array_equal(rad, rad_ref, err_msg=what)
        np.testing.assert_array_equal(png, png_ref, err_msg=what)

