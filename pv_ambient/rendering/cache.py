"""The scene cache: what a :class:`~pv_ambient.Renderer` has computed for its scene, by named key.

A key is a tuple whose first element names the stage (``"majorant"``, ``"light_grid"``, ``"tau"``,
``"ball"``, ``"table"``, ``"front"``, ``"diffusion"``, …) and whose other elements are the inputs
the entry depends on, so a camera move finds everything but the ray cast, and a relight recomputes
only the entries of the light that changed. Entries whose stage depends only on σt (see
:data:`SIGMA_ONLY`) stay valid when the colour of the transfer function changes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from ..backend import blas_before_stage

#: Stages computed from σt and the geometry alone (no albedo, emission or colour).
SIGMA_ONLY = frozenset({"majorant", "cast_majorant", "light_grid", "sigma_l", "tau"})
#: Stages that depend on nothing in the scene but their key (the preintegrated table slices).
SCENE_INDEPENDENT = frozenset({"table"})


class SceneCache:
    """A dictionary of stage results with named keys.

    Examples
    --------
    >>> from pv_ambient.rendering.cache import SceneCache
    >>> c = SceneCache()
    >>> c.get(("majorant", 8), lambda: [1, 2])
    [1, 2]
    >>> c.kinds()
    {'majorant'}
    """

    def __init__(self, entries=None):
        self._entries = dict(entries or {})

    def get(self, key: tuple, build: Callable[[], object]):
        """The entry ``key``, built by ``build()`` (and kept) when missing."""
        if key not in self._entries:
            blas_before_stage()  # a stage is computed: the CPU's kernels and BLAS may run
            self._entries[key] = build()
        return self._entries[key]

    def __getitem__(self, key: tuple):
        return self._entries[key]

    def __setitem__(self, key: tuple, value) -> None:
        if not (isinstance(key, tuple) and key and isinstance(key[0], str)):
            raise TypeError(f"a scene-cache key is a tuple starting with the stage's name, got {key!r}")
        self._entries[key] = value

    def __delitem__(self, key: tuple) -> None:
        del self._entries[key]

    def __contains__(self, key) -> bool:
        return key in self._entries

    def __iter__(self):
        return iter(list(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def keys(self, kind: str | None = None) -> list:
        """The keys, or those of stage ``kind``."""
        return [k for k in self._entries if kind is None or k[0] == kind]

    def kinds(self) -> set:
        """The stage names present."""
        return {k[0] for k in self._entries}

    def items(self, kind: str | None = None) -> list:
        return [(k, v) for k, v in self._entries.items() if kind is None or k[0] == kind]

    def share(self, other: "SceneCache", kinds: Iterable[str] = SCENE_INDEPENDENT) -> None:
        """Copy ``other``'s entries of the stages ``kinds`` into this cache (by reference).

        The default shares what does not depend on the scene (the preintegrated table slices: what
        the disk cache would give a second renderer anyway)."""
        kinds = frozenset(kinds)
        self._entries.update((k, v) for k, v in other._entries.items() if k[0] in kinds)

    def with_sigma_only(self) -> "SceneCache":
        """A new cache holding only the σt-derived entries (:data:`SIGMA_ONLY`): what stays valid for
        a transfer function with the same σt and other colours."""
        return SceneCache({k: v for k, v in self._entries.items() if k[0] in SIGMA_ONLY})

    def clear(self, kind: str | None = None) -> None:
        """Forget every entry, or those of stage ``kind``."""
        if kind is None:
            self._entries.clear()
        else:
            for k in self.keys(kind):
                del self._entries[k]

    def __repr__(self):
        return f"SceneCache({len(self)} entries: {', '.join(sorted(self.kinds())) or 'empty'})"
