"""The driver (pv_ambient.series.driver, ``render_series``) on a real dask LocalCluster.

Issue 18's acceptance: a worker killed during a frame → every frame present and identical to the
serial run; in-memory volumes on the cluster equal the serial run; an orbit without lights or
exposure keeps one light rig and one exposure; skipped frames, bad arguments, the cluster's Numba
threads. The frames' equality with ``pv-ambient render`` is tested through the command line
(tests/cli/test_series_command.py).
"""

import os
import signal
import threading
import time

import numpy as np
import pytest

import pv_ambient as pa
from pv_ambient import datasets
from pv_ambient.series import orbit, render_series
from pv_ambient.series.driver import open_client

from .helpers import CAMERA, TF, frame

pv = pytest.importorskip("pyvista")
distributed = pytest.importorskip("distributed")


def test_worker_killed_mid_frame_frames_all_there_and_identical(client, steps, tmp_path):
    kw = dict(transfer_function=TF, camera=CAMERA, lights=[pa.PointLight((0.0, 0.5, 1.6), 3.0)],
              model="single_scattering", window_size=(200, 160), radiance=True, progress_bar=False)
    vols = [str(p) for p in steps] * 2  # 10 frames
    serial = render_series(vols, out_dir=tmp_path / "serial", client="synchronous", **kw)
    assert serial.n_rendered == 10
    pids = client.run(os.getpid)
    killed = {}

    def killer():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            busy = client.run(lambda dask_worker: [str(k) for k in
                                                   (ts.key for ts in dask_worker.state.executing)])
            for addr, keys in busy.items():
                if any("pv-ambient-frame" in k for k in keys):
                    killed.update(addr=addr, key=keys[0])
                    os.kill(pids[addr], signal.SIGKILL)
                    return
            time.sleep(0.01)

    t = threading.Thread(target=killer)
    t.start()
    res = render_series(vols, out_dir=tmp_path / "cluster", client=client, **kw)
    t.join()
    client.wait_for_workers(2, timeout=60)
    assert killed, "no frame was running on a worker to kill"
    assert (res.n_rendered, res.n_failed) == (10, 0), [f.error for f in res.frames]
    # the killed frame was rendered by another worker process
    idx = int(killed["key"].split("-")[3])
    assert res.frames[idx].worker != killed["addr"]
    assert not list((tmp_path / "cluster").glob(".*")), "a temporary file was left"
    for i in range(10):
        for name in (f"frame_{i:04d}.png", f"frame_{i:04d}.npy"):
            a, b = (tmp_path / "cluster" / name).read_bytes(), (tmp_path / "serial" / name).read_bytes()
            assert a == b, name



def test_skip_overwrite_and_radiance_added_later(tmp_path):
    grid = datasets.supernova(n=16)
    kw = dict(out_dir=tmp_path, client="synchronous", window_size=(16, 12), progress_bar=False,
              cameras=orbit(grid, 3))
    assert render_series(grid, **kw).n_rendered == 3
    assert render_series(grid, **kw).n_skipped == 3
    # the .npy is missing: those frames are not done
    res = render_series(grid, radiance=True, **kw)
    assert res.n_rendered == 3 and len(list(tmp_path.glob("*.npy"))) == 3
    assert render_series(grid, overwrite=True, **kw).n_rendered == 3
    stale = tmp_path / ".frame_0001.0123456789ab.part.png"
    stale.write_bytes(b"half")
    assert render_series(grid, **kw).n_skipped == 3 and not stale.exists()


def test_in_memory_volumes_on_the_cluster_equal_serial(client, tmp_path):
    grids = [datasets.cloud(n=16, seed=s) for s in range(3)]
    kw = dict(window_size=(20, 16), radiance=True, progress_bar=False, transfer_function=TF,
              model="ambient_scattering", lights=[pa.PointLight((0.0, 0.5, 1.6), 3.0)], quality="preview")
    a = render_series(grids, out_dir=tmp_path / "a", client=client, **kw)
    b = render_series(grids, out_dir=tmp_path / "b", client="synchronous", **kw)
    assert a.n_rendered == b.n_rendered == 3
    for i in range(3):
        np.testing.assert_array_equal(np.load(a.frames[i].paths[0]), np.load(b.frames[i].paths[0]))


def test_orbit_without_lights_or_exposure_keeps_its_lighting_and_exposure(client, tmp_path):
    # lights not given: the default rig placed once from the first camera (every frame, every
    # worker); exposure not given: the first frame's "auto" exposure for every PNG (no flicker)
    from pv_ambient.inputs.lights import default_lights

    grid = datasets.cloud(n=16, seed=2)
    cams = orbit(grid, 4, elevation=20.0, start=CAMERA)
    res = render_series(grid, cameras=cams, out_dir=tmp_path / "o", client=client, radiance=True,
                        progress_bar=False, transfer_function=TF, model="single_scattering", window_size=(20, 16),
                        quality="preview")
    assert res.n_rendered == 4 and res.n_failed == 0
    rig = default_lights(cams[0])
    refs = [pa.render(grid, transfer_function=TF, lights=rig, camera=c, window_size=(20, 16),
                      model="single_scattering", quality="preview") for c in cams]
    e0 = refs[0].display_exposure("auto")
    autos = [r.display_exposure("auto") for r in refs]
    assert max(autos) - min(autos) > 1e-3  # per-frame auto exposures differ: fixing it matters
    for i, ref in enumerate(refs):
        png, rad = frame(tmp_path / "o", i)
        np.testing.assert_array_equal(rad, ref.radiance)
        np.testing.assert_array_equal(png, ref.to_uint8(exposure=e0))


@pytest.mark.parametrize("kwargs, err, match", [
    (dict(cameras=[CAMERA] * 3), ValueError, "cameras has 3 cameras for 2 volumes"),
    (dict(camera=CAMERA, cameras=[CAMERA]), ValueError, "not both"),
    (dict(windowsize=(4, 4)), TypeError, "windowsize"),
    (dict(model="fancy"), ValueError, "model must be one of"),
    (dict(display={"gamma": 2}), ValueError, "display must hold only"),
    (dict(client=3), TypeError, "client must be"),
    (dict(out_dir=None), TypeError, "out_dir is required"),
])
def test_bad_arguments_name_the_argument(tmp_path, kwargs, err, match):
    grids = [datasets.cloud(n=8, seed=s) for s in range(2)]
    kw = {"out_dir": tmp_path, "client": "synchronous", "progress_bar": False, **kwargs}
    with pytest.raises(err, match=match):
        render_series(grids, **kw)



def test_own_cluster_workers_start_with_their_numba_threads():
    """client=None: the workers' NUMBA_NUM_THREADS is the Numba threads they use (no idle pool
    threads spinning beside the other workers), 1 by default, numba_threads= when given."""
    before = os.environ.get("NUMBA_NUM_THREADS")
    for asked, expected in ((None, 1), (2, 2)):
        c, owned, n, threads = open_client(None, 1, asked)
        assert os.environ.get("NUMBA_NUM_THREADS") == before  # this process' environment as it was
        try:
            got = c.run(lambda: (os.environ.get("NUMBA_NUM_THREADS"), __import__("numba").config.NUMBA_NUM_THREADS))
        finally:
            for thing in owned:
                thing.close()
        assert (n, threads) == (1, expected)
        assert list(got.values()) == [(str(expected), expected)]


def test_default_rig_without_a_camera_comes_from_the_lights_owner(tmp_path):
    # lights and camera not given, a lit model: the rig of inputs.lights, placed once from the default
    # view's direction, the same for every frame whatever each volume's bounds (a volume's own default
    # view gives the same rig)
    from pv_ambient.inputs.camera import default_camera
    from pv_ambient.inputs.lights import as_lights

    grids = [datasets.cloud(n=12, seed=0), datasets.cloud(n=12, seed=1)]
    res = render_series(grids, out_dir=tmp_path, client="synchronous", radiance=True, progress_bar=False,
                        transfer_function=TF, model="single_scattering", window_size=(12, 10), quality="preview")
    assert res.n_rendered == 2
    rig = as_lights(None, camera=default_camera(grids[0].bounds))
    assert len(rig) == 2
    for i, grid in enumerate(grids):
        ref = pa.render(grid, transfer_function=TF, lights=rig, window_size=(12, 10), model="single_scattering",
                        quality="preview")
        np.testing.assert_array_equal(np.load(res.frames[i].paths[0]), ref.radiance)
