"""The CUDA backend's device cache (:mod:`pv_ambient.backend` launches the kernels): host arrays →
device copies kept between renders, the kernels' records already mapped to those copies, and one
output buffer per image size, so that a camera move uploads the camera's parameters, launches one
kernel and downloads one image (docs/performance.rst, "Host work of a frame").

This module imports without numba-cuda; it imports ``numba.cuda`` only to upload and to ask the
GPU for its free memory.
"""

from __future__ import annotations

import math
import os

import numpy as np


class DeviceMemoryError(MemoryError):
    """A scene does not fit in the GPU's free memory."""


def simulator() -> bool:
    """Whether Numba's CUDA simulator is on (``NUMBA_ENABLE_CUDASIM=1``)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") == "1"


def free_device_memory() -> float:
    """Free bytes on the current GPU (``inf`` in the simulator)."""
    if simulator():
        return float("inf")
    from numba import cuda

    free, _total = cuda.current_context().get_memory_info()
    return float(free)


def check_free(need):
    """Raise :class:`DeviceMemoryError` when ``need`` more bytes would not fit in the GPU's free memory."""
    free = free_device_memory()
    if need > free:
        raise DeviceMemoryError(f"backend='cuda': the scene needs {need / 2**20:.1f} MiB more device memory "
                                f"but only {free / 2**20:.1f} MiB are free; use backend='cpu' (or 'auto', which "
                                "falls back to the CPU) or a smaller volume / light_resolution")


#: Arrays of at most this many bytes (a camera's 16 parameters, the background, a light's position)
#: are known to the device cache by their contents, not their identity: each frame builds them anew,
#: and keyed by identity every frame would upload them again and leave the old copies behind.
SMALL_BYTES = 4096
#: How many small arrays' device copies are kept (the oldest go first).
SMALL_KEEP = 256


def _small_key(arr):
    return (arr.dtype.str, arr.shape, arr.tobytes())


class DeviceCache:
    """Host arrays → device copies, kept between renders, and the kernels' records with their
    arrays replaced by those copies.

    A large array is known by its identity (the host array is held, so its id cannot be reused),
    an array of at most :data:`SMALL_BYTES` by its contents. A record (:mod:`._kernels.records`) is
    known by its type, its values and its arrays' keys: a camera move finds the volume's, the
    lights' and the tables' records already mapped to device arrays and uploads nothing but the
    camera's parameters (docs/performance.rst, "Host work of a frame"). A record or array unused for
    ``keep`` launches is dropped at the next sweep, which runs every ``keep`` launches — not at every
    frame.

    .. versionchanged:: 0.4.0
       Records mapped once, small arrays by their contents, the ray cast's output kept per image
       size.
    """

    def __init__(self, keep=8):
        self._items = {}  # id(host) -> (host, device copy, last launch)
        self._small = {}  # small_key -> device copy (insertion order: the oldest first)
        self._records = {}  # record key -> [host record, device record, last launch, ids of its large arrays]
        self._outputs = {}  # (h, w) -> (flat buffer, radiance view, alpha view)
        self.launch_memo = {}  # id(device record or array) -> (it, Numba type, launch parameters): cuda_launch
        self._launch = 0
        self.keep = keep

    @property
    def nbytes(self) -> int:
        """Bytes held on the device."""
        return int(sum(d.nbytes for _h, d, _t in self._items.values()) + sum(d.nbytes for d in self._small.values())
                   + sum(o[0].nbytes for o in self._outputs.values()))

    def need(self, arrays) -> int:
        """Bytes that uploading ``arrays`` would add (each large array once; small ones count as
        nothing)."""
        seen = {}
        for a in arrays:
            if isinstance(a, np.ndarray) and a.nbytes > SMALL_BYTES and id(a) not in self._items:
                seen[id(a)] = a.nbytes
        return int(sum(seen.values()))

    def get(self, arr):
        """The device copy of ``arr`` (uploaded on first use)."""
        from numba import cuda

        if arr.nbytes <= SMALL_BYTES:
            key = _small_key(arr)
            dev = self._small.get(key)
            if dev is None:
                dev = self._small[key] = cuda.to_device(np.ascontiguousarray(arr))
                if len(self._small) > SMALL_KEEP:
                    del self._small[next(iter(self._small))]
            return dev
        item = self._items.get(id(arr))
        if item is None or item[0] is not arr:
            item = (arr, cuda.to_device(np.ascontiguousarray(arr)), self._launch)
        self._items[id(arr)] = (item[0], item[1], self._launch)
        return item[1]

    def put(self, arr, dev):
        """Register ``dev`` as the device copy of host array ``arr`` (computed on the GPU); the
        records that held another copy of it are mapped again at their next use. An array of at
        most :data:`SMALL_BYTES` (a small grid's majorant) is registered by its contents too, as
        :meth:`get` finds it."""
        if arr.nbytes <= SMALL_BYTES:
            self._small[_small_key(arr)] = dev
            if len(self._small) > SMALL_KEEP:
                del self._small[next(iter(self._small))]
        self._items[id(arr)] = (arr, dev, self._launch)
        self._forget_records({id(arr)})  # after the new copy is in: the memo then drops the old one

    def forget(self, arr):
        """Drop the device copy of host array ``arr`` (changed in place on the host: the next use
        uploads it again) and the records that held it."""
        if self._items.pop(id(arr), None) is not None:
            self._forget_records({id(arr)})

    def args(self, args, extra_bytes=0):
        """``args`` (records and values) with every numpy array, at any depth of its records,
        replaced by its device copy: records seen before are found whole, by :func:`_record_key`;
        the others are mapped (:func:`pv_ambient._kernels.records.map_arrays`) and kept.

        Raises :class:`DeviceMemoryError`, before uploading anything, when the arrays to upload plus
        ``extra_bytes`` would not fit in the GPU's free memory — asked only when there is
        something to upload."""
        from ._kernels.records import arrays, map_arrays

        out, todo = list(args), []
        for i, rec in enumerate(args):
            if not isinstance(rec, (tuple, np.ndarray)):
                continue
            key = _record_key(rec) if isinstance(rec, tuple) else None  # a bare array: mapped at each use
            hit = None if key is None else self._records.get(key)
            if hit is not None:
                hit[2] = self._launch
                out[i] = hit[1]
            else:
                todo.append((i, key, rec))
        need = int(extra_bytes) + (self.need([a for _i, _k, rec in todo for a in arrays(rec)]) if todo else 0)
        if need:
            check_free(need)
        for i, key, rec in todo:
            out[i] = map_arrays(self.get, rec)
            if key is not None:
                ids = frozenset(id(a) for a in arrays(rec) if a.nbytes > SMALL_BYTES)
                self._records[key] = [rec, out[i], self._launch, ids]
        return tuple(out)

    def output(self, h, w):
        """The ray cast's device outputs for an ``h`` × ``w`` image, ``(flat, rad, alpha)``: one
        float32 buffer of h·w·4 values, radiance (h, w, 3) its first h·w·3 and alpha (h, w) the
        rest — both C-contiguous, as the kernel takes them — so one copy brings the image home.
        Allocated once per image size; the last two sizes are kept (a plotter's drag frames and its
        resting frame may differ)."""
        out = self._outputs.get((h, w))
        if out is None:
            from numba import cuda

            while len(self._outputs) >= 2:
                del self._outputs[next(iter(self._outputs))]
            self._prune_memo()
            flat = cuda.device_array(h * w * 4, np.float32)
            n = h * w * 3
            out = self._outputs[(h, w)] = (flat, _device_view(flat, 0, (h, w, 3)), _device_view(flat, n, (h, w)))
        return out

    def output_bytes(self, h, w) -> int:
        """Bytes :meth:`output` would allocate for an ``h`` × ``w`` image (0 when it holds them)."""
        return 0 if (h, w) in self._outputs else h * w * 16

    def tick(self):
        """End of a launch; every ``keep`` launches, drop what was unused for ``keep`` launches."""
        self._launch += 1
        if self._launch % self.keep == 0:
            self._sweep()

    def _sweep(self):
        old = self._launch - self.keep
        for key, (_rec, _dev, t, ids) in list(self._records.items()):
            if t < old:
                del self._records[key]
                continue
            for i in ids:  # an array a kept record uses stays
                item = self._items.get(i)
                if item is not None and item[2] < t:
                    self._items[i] = (item[0], item[1], t)
        gone = {k for k, (_h, _d, t) in self._items.items() if t < old}
        for k in gone:
            del self._items[k]
        self._forget_records(gone)
        self._prune_memo()

    def _prune_memo(self):
        """Keep the launch memo (:mod:`pv_ambient.cuda_launch`) to what the cache still holds, so
        that it keeps no dropped device copy alive."""
        if self.launch_memo:
            live = ({id(r[1]) for r in self._records.values()} | {id(d) for d in self._small.values()}
                    | {id(d) for _h, d, _t in self._items.values()} | {id(v) for o in self._outputs.values() for v in o})
            for k in [k for k in self.launch_memo if k not in live]:
                del self.launch_memo[k]

    def _forget_records(self, ids):
        if ids:
            for key in [k for k, r in self._records.items() if r[3] & ids]:
                del self._records[key]
            self._prune_memo()

    def clear(self):
        self._items.clear()
        self._small.clear()
        self._records.clear()
        self._outputs.clear()
        self.launch_memo.clear()


def _record_key(rec):
    """A record's cache key: its type, then each field's — a large array's identity, a small
    one's contents, a nested record's key, a value itself; None when a field is none of those
    (the record is then mapped at each use)."""
    parts = [type(rec)]
    for f in rec:
        if isinstance(f, np.ndarray):
            parts.append(("#", id(f)) if f.nbytes > SMALL_BYTES else _small_key(f))
        elif isinstance(f, tuple):
            k = _record_key(f)
            if k is None:
                return None
            parts.append(k)
        elif isinstance(f, float):  # -0.0 == 0.0, but the record keeps the one it was given
            parts.append((float, f, math.copysign(1.0, f)))
        elif isinstance(f, (int, bool, str, np.generic)) or f is None:
            parts.append((type(f), f))
        else:
            return None
    return tuple(parts)


def _device_view(flat, start, shape):
    """The C-contiguous device view of ``flat[start:start + prod(shape)]`` as ``shape``."""
    return device_reshape(flat[start:start + int(np.prod(shape))], shape)


def device_reshape(dev, shape):
    """The C-contiguous device array ``dev`` viewed as ``shape`` (no copy): a light's optical depth
    (m0, m1, m2) as the (m0, m1, m2, 1) the kernels' records take."""
    view = dev.reshape(tuple(shape))
    # numba-cuda's reshape is a device array; the simulator's returns the wrapped numpy array
    return view if hasattr(view, "copy_to_host") else type(dev)(view)


def image_buffers(h, w, zero=True):
    """Host radiance (h, w, 3) and alpha (h, w) float32 for a ray cast, both C-contiguous views of
    one buffer laid out as :meth:`DeviceCache.output`'s, so the CUDA backend fills both with one
    download. ``zero=False``: left uninitialised (the ray cast writes every pixel)."""
    flat = (np.zeros if zero else np.empty)(h * w * 4, np.float32)
    return flat[:h * w * 3].reshape(h, w, 3), flat[h * w * 3:].reshape(h, w)


def host_flat(rad, alpha):
    """The one host buffer ``rad`` and ``alpha`` are views of, laid out as the device output's
    (:func:`image_buffers`), else None."""
    h, w = alpha.shape
    base = rad.base
    if (base is None or alpha.base is not base or not isinstance(base, np.ndarray) or base.dtype != np.float32
            or base.shape != (h * w * 4,) or not base.flags.c_contiguous):
        return None
    p = base.__array_interface__["data"][0]
    if rad.__array_interface__["data"][0] != p or alpha.__array_interface__["data"][0] != p + h * w * 12:
        return None
    return base
