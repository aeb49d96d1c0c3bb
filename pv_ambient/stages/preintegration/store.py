"""The disk store of table slices: the cache, the shipped default and :func:`get_table`.

Slices are cached as ``.npz`` under ``$PV_AMBIENT_CACHE``, else the user cache directory
(``platformdirs`` when importable, else ``~/.cache/pv_ambient``), named by a format version and a
hash of every parameter; files are written atomically (temporary file + ``os.replace``) and a
corrupt or mismatched file is recomputed with a :class:`UserWarning`.
``pv_ambient/data/default_table.npz`` ships the ``"balanced"``, ``seed=0`` slices for the phase
functions in :data:`DEFAULT_PHASES` (isotropic; HG g = 0.3, 0.6, 0.9) over all albedo nodes;
:func:`get_table` serves a request from it, sliced to the requested albedo nodes, whenever every
other parameter matches (a slice computed for those nodes alone would hold other random numbers —
Russian roulette depends on the largest albedo — but estimates the same quantities). Rebuild it
reproducibly (same arrays) with::

    python -m pv_ambient.preintegration --build-default

This module imports only numpy, the kernels and (lazily) platformdirs: no pyvista or vtk.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from ..._kernels import preint as _k
from ...inputs.phase import HenyeyGreenstein, Isotropic, as_phase
from ...inputs.validation import check_bool, check_choice, check_int, check_real
from .estimator import BEAM_MIX, MIX_AXIS, MIX_UNIFORM, N_CHUNKS
from .table import (
    ALBEDO_NODES,
    PATH_BOOST,
    PATH_BOOST_TAU2,
    QUALITY_PRESETS,
    TABLE_ARRAYS,
    TAU_MAX,
    TAU_MIN,
    PreintegratedTable,
    albedo_nodes_for,
    compute_table,
)

__all__ = [
    "DEFAULT_PHASES",
    "DEFAULT_TABLE_PATH",
    "FORMAT_VERSION",
    "build_default",
    "cache_dir",
    "get_table",
]

FORMAT_VERSION = 1
"""Bumped whenever the estimator, the layout or the node sets change (invalidates caches)."""

DEFAULT_PHASES = (Isotropic(), HenyeyGreenstein(0.3), HenyeyGreenstein(0.6), HenyeyGreenstein(0.9))
"""Phase functions whose ``"balanced"`` slices ship in ``data/default_table.npz``."""

DEFAULT_TABLE_PATH = Path(__file__).parents[2] / "data" / "default_table.npz"
"""``pv_ambient/data/default_table.npz``."""


# --- cache ----------------------------------------------------------------------------------


def cache_dir() -> Path:
    """The table cache directory: ``$PV_AMBIENT_CACHE``, else the user cache directory."""
    env = os.environ.get("PV_AMBIENT_CACHE")
    if env:
        return Path(env).expanduser()
    try:
        import platformdirs
    except ImportError:
        return Path.home() / ".cache" / "pv_ambient"
    return Path(platformdirs.user_cache_dir("pv_ambient"))


def _key(kind, g, quality, seed, a_nodes, params) -> dict:
    """Every parameter that determines a slice's numbers (a_nodes excluded: see _key_hash)."""
    return {
        "format": FORMAT_VERSION,
        "kind": int(kind),
        "g": float(g).hex(),
        "quality": quality,
        "seed": int(seed),
        "n_tau": int(params["n_tau"]),
        "n_theta": int(params["n_theta"]),
        "n_paths": int(params["n_paths"]),
        "tau_range": [TAU_MIN, TAU_MAX],
        "path_boost": [PATH_BOOST, PATH_BOOST_TAU2],
        "n_chunks": N_CHUNKS,
        "mix": [MIX_UNIFORM, MIX_AXIS, BEAM_MIX],
        "w_rr": _k.W_RR,
        "a_nodes": [float(x) for x in a_nodes],
    }


def _key_hash(key: dict) -> str:
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]


def _cache_path(directory: Path, key: dict) -> Path:
    return directory / f"preint-v{FORMAT_VERSION}-k{key['kind']}-{key['quality']}-{_key_hash(key)}.npz"


def _table_to_arrays(table: PreintegratedTable, key: dict, prefix: str = "") -> dict:
    out = {prefix + name: np.asarray(getattr(table, name)) for name in TABLE_ARRAYS}
    out[prefix + "meta"] = np.array(json.dumps({"key": key, "kind": table.kind, "g": table.g}))
    return out


def _table_from_arrays(data, key: dict, prefix: str = "") -> PreintegratedTable:
    """Rebuild a table from npz arrays, checking the key and every shape (raises ValueError)."""
    meta = json.loads(str(data[prefix + "meta"][()]))
    if meta.get("key") != key:
        raise ValueError("cache key mismatch")
    arrs = {name: np.array(data[prefix + name]) for name in TABLE_ARRAYS}
    n_a, n_tau, n_t = len(arrs["a_nodes"]), len(arrs["tau_nodes"]), len(arrs["theta_nodes"])
    if n_tau != key["n_tau"] or not np.array_equal(arrs["a_nodes"], np.array(key["a_nodes"])):
        raise ValueError("node sets do not match the key")
    for name in ("D", "D_err"):
        if arrs[name].shape != (n_a, n_tau, n_t) or arrs[name].dtype != np.float32:
            raise ValueError(f"{name} has shape {arrs[name].shape}")
    for name in ("F", "F_err", "F_diff"):
        if arrs[name].shape != (n_a, n_tau) or arrs[name].dtype != np.float32:
            raise ValueError(f"{name} has shape {arrs[name].shape}")
    for name in ("D", "F", "F_diff", "D_err", "F_err"):
        if not np.all(np.isfinite(arrs[name])):
            raise ValueError(f"{name} is not finite")
    return PreintegratedTable(
        kind=int(meta["kind"]), g=float(meta["g"]), quality=key["quality"], seed=key["seed"], **arrs
    )


def _save_npz(path: Path, arrays: dict) -> None:
    """Write ``arrays`` to ``path`` atomically: a temporary file in the same directory, then
    ``os.replace`` (readers see the old file or the new one, never a partial one)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; cache and package data are world-readable
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _load_cached(path: Path, key: dict):
    """The cached table, or None if absent; a bad file warns and returns None."""
    if not path.exists():
        return None
    try:
        # Open the file here: np.load leaks its own handle when the zip directory is truncated.
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            return _table_from_arrays(data, key)
    except Exception as exc:  # corrupt, truncated or foreign file: recompute
        warnings.warn(
            f"preintegrated table cache file {str(path)!r} is unreadable ({type(exc).__name__}: {exc}); "
            "recomputing it",
            UserWarning,
            stacklevel=3,
        )
        return None


@functools.lru_cache(maxsize=1)
def _default_slices():
    """The shipped default tables as ``[(key without a_nodes, table)]`` (empty if absent)."""
    if not DEFAULT_TABLE_PATH.exists():
        return ()
    out = []
    with np.load(DEFAULT_TABLE_PATH, allow_pickle=False) as data:
        for i in range(int(data["n_slices"])):
            prefix = f"s{i}_"
            meta = json.loads(str(data[prefix + "meta"][()]))
            table = _table_from_arrays(data, meta["key"], prefix)
            for name in TABLE_ARRAYS:  # shared by every table served from it
                getattr(table, name).flags.writeable = False
            out.append((meta["key"], table))
    return tuple(out)


def _from_default(key: dict):
    """A shipped slice matching ``key`` except for holding a superset of its albedo nodes."""
    want = np.array(key["a_nodes"])
    for skey, table in _default_slices():
        if {k: v for k, v in skey.items() if k != "a_nodes"} != {k: v for k, v in key.items() if k != "a_nodes"}:
            continue
        idx = np.searchsorted(table.a_nodes, want)
        idx = np.minimum(idx, len(table.a_nodes) - 1)
        if not np.array_equal(table.a_nodes[idx], want):
            continue
        return PreintegratedTable(
            kind=table.kind,
            g=table.g,
            quality=table.quality,
            seed=table.seed,
            a_nodes=table.a_nodes[idx].copy(),
            tau_nodes=table.tau_nodes,
            theta_nodes=table.theta_nodes,
            n_paths=table.n_paths,
            D=table.D[idx].copy(),
            D_err=table.D_err[idx].copy(),
            F=table.F[idx].copy(),
            F_err=table.F_err[idx].copy(),
            F_diff=table.F_diff[idx].copy(),
        )
    return None


def get_table(phase=None, albedo_range=(0.0, 1.0), *, quality="balanced", cache=True, progress_bar=False, seed=0):
    """The D/F table slice for a phase function and an albedo range: shipped, cached or computed.

    Parameters
    ----------
    phase : None, float, PhaseFunction, str or dict, default: None
        Phase function (:func:`pv_ambient.inputs.phase.as_phase`): ``None`` is isotropic, a float is
        the HG anisotropy g.
    albedo_range : (float, float), default: (0.0, 1.0)
        ``(a_min, a_max)`` of the scene, ``0 <= a_min <= a_max <= 1``; the table holds the
        :data:`ALBEDO_NODES` that bracket it (:func:`albedo_nodes_for`).
    quality : {"preview", "balanced", "accurate"}, default: "balanced"
        Node counts and paths (:data:`QUALITY_PRESETS`).
    cache : bool, default: True
        Read and write the disk cache (:func:`cache_dir`). ``False`` always computes (the
        shipped default is still used).
    progress_bar : bool, default: False
        Show a tqdm bar over τ nodes while computing.
    seed : int, default: 0
        Random seed (part of the cache key).

    Returns
    -------
    PreintegratedTable

    Examples
    --------
    >>> from pv_ambient.stages.preintegration import get_table
    >>> table = get_table(None, (0.8, 0.9))  # isotropic: served from the shipped default
    >>> table.a_nodes.tolist(), table.D.shape
    ([0.8, 0.85, 0.9], (3, 33, 1))
    >>> round(table.f(0.0, 0.85), 6)
    1.0
    """
    ph = as_phase(phase)
    a_min, a_max = _check_albedo_range(albedo_range)
    check_choice(quality, "quality", tuple(QUALITY_PRESETS))
    check_bool(cache, "cache")
    check_bool(progress_bar, "progress_bar")
    seed = check_int(seed, "seed", lo=0)
    kind, g, iso = ph.canonical()
    params = dict(QUALITY_PRESETS[quality])
    if iso:
        params["n_theta"] = 1
    a_nodes = albedo_nodes_for(a_min, a_max)
    key = _key(kind, g, quality, seed, a_nodes, params)
    table = _from_default(key)
    if table is not None:
        return table
    path = _cache_path(cache_dir(), key) if cache else None
    if path is not None:
        table = _load_cached(path, key)
        if table is not None:
            return table
    table = compute_table(
        ph,
        a_nodes,
        n_tau=params["n_tau"],
        n_theta=params["n_theta"],
        n_paths=params["n_paths"],
        seed=seed,
        progress_bar=bool(progress_bar),
        quality=quality,
    )
    if path is not None:
        try:
            _save_npz(path, _table_to_arrays(table, key))
        except OSError as exc:
            warnings.warn(f"could not write the table cache {str(path)!r}: {exc}", UserWarning, stacklevel=2)
    return table


def _check_albedo_range(albedo_range):
    try:
        a_min, a_max = albedo_range
    except (TypeError, ValueError):
        raise TypeError(f"albedo_range must be (a_min, a_max), got {albedo_range!r}") from None
    a_min = check_real(a_min, "albedo_range[0]", lo=0.0, hi=1.0)
    a_max = check_real(a_max, "albedo_range[1]", lo=0.0, hi=1.0)
    if a_min > a_max:
        raise ValueError(f"albedo_range must have a_min <= a_max, got {albedo_range!r}")
    return a_min, a_max


# --- the shipped default ----------------------------------------------------------------------


def build_default(path=DEFAULT_TABLE_PATH, *, progress_bar=True) -> Path:
    """Compute the :data:`DEFAULT_PHASES` ``"balanced"`` slices (all albedo nodes, seed 0) and
    write them to ``path`` (``pv_ambient/data/default_table.npz``). Deterministic."""
    arrays = {}
    params = QUALITY_PRESETS["balanced"]
    for i, ph in enumerate(DEFAULT_PHASES):
        kind, g, iso = ph.canonical()
        p = dict(params)
        if iso:
            p["n_theta"] = 1
        key = _key(kind, g, "balanced", 0, ALBEDO_NODES, p)
        t0 = time.perf_counter()
        table = compute_table(
            ph, ALBEDO_NODES, n_tau=p["n_tau"], n_theta=p["n_theta"], n_paths=p["n_paths"], seed=0,
            progress_bar=progress_bar, quality="balanced",
        )
        print(f"{ph!r}: {time.perf_counter() - t0:.1f} s")
        arrays.update(_table_to_arrays(table, key, prefix=f"s{i}_"))
    arrays["n_slices"] = np.array(len(DEFAULT_PHASES))
    path = Path(path)
    _save_npz(path, arrays)
    _default_slices.cache_clear()
    return path
