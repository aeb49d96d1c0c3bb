"""Phase functions: validated Python objects over the kernels in ``_kernels/phase.py``.

A phase function ``p(cos θ)`` gives the angular distribution of scattered light. Convention
(docs/conventions.rst): ``p`` is normalised to 1 over the sphere (it includes the 1/4π) and θ is the
angle between the light's propagation direction before and after scattering, so ``g > 0``
is forward scattering (peak at ``cos θ = 1``).

Each object carries an integer ``kind`` and a float ``g`` — exactly what kernels take — and
offers vectorised :meth:`PhaseFunction.eval`, :meth:`PhaseFunction.pdf` and
:meth:`PhaseFunction.sample` that run the kernels; the maths exists only there. Objects are
immutable, compare and hash on ``(kind, g)`` and can therefore key caches.
:func:`as_phase` converts the forms a user or a JSON scene may give.

This module imports only numpy and the kernels (no pyvista), like the rest of the array core.
"""

from __future__ import annotations

import math
import warnings
from numbers import Real

import numpy as np

from .._kernels import phase as _k

__all__ = [
    "PhaseFunction",
    "Isotropic",
    "HenyeyGreenstein",
    "Schlick",
    "Rayleigh",
    "as_phase",
]

_COS_TOL = 1e-6  # cosines from dot products may overshoot ±1 by rounding; kernels clamp them


def _check_g(g) -> float:
    """Return ``g`` as a float with ``|g| < 1``, or raise naming ``g`` and the value received."""
    if isinstance(g, np.ndarray) and g.ndim == 0:
        g = g[()]
    if isinstance(g, (bool, np.bool_)) or not isinstance(g, (Real, np.floating, np.integer)):
        raise TypeError(f"g must be a real number, got {type(g).__name__} {g!r}")
    out = float(g)
    if not math.isfinite(out):
        raise ValueError(f"g must be finite, got {out!r}")
    if not abs(out) < 1.0:
        raise ValueError(f"g must satisfy |g| < 1, got {out!r} (|g| = 1 is a delta distribution)")
    return out + 0.0  # -0.0 -> 0.0


def _schlick_mean_cosine(k: float) -> float:
    """Mean cosine of Schlick's lobe ``(1 − k²)/(4π (1 − kμ)²)``.

    Closed form ``1/k − (1 − k²) atanh(k)/k²``; it cancels for small ``k``, where the series
    ``Σ_{n≥1} 2 k^{2n−1} / (4n² − 1) = 2k/3 + 2k³/15 + …`` is used instead.
    """
    if abs(k) < 0.05:
        return sum(2.0 * k ** (2 * n - 1) / (4 * n * n - 1) for n in range(1, 12))
    return 1.0 / k - (1.0 - k * k) * math.atanh(k) / (k * k)


class PhaseFunction:
    """Base class: an integer ``kind`` and anisotropy ``g`` understood by the kernels.

    Use a subclass (:class:`Isotropic`, :class:`HenyeyGreenstein`, :class:`Schlick`,
    :class:`Rayleigh`) or :func:`as_phase`.

    Attributes
    ----------
    kind : int
        Kernel kind, one of ``ISOTROPIC``, ``HENYEY_GREENSTEIN``, ``SCHLICK``, ``RAYLEIGH``
        in :mod:`pv_ambient._kernels.phase`.
    g : float
        Anisotropy parameter, ``0.0`` for kinds without one.
    """

    __slots__ = ("_kind", "_g")
    _name = "phase"

    def __init__(self, kind: int, g: float = 0.0):
        self._kind = int(kind)
        self._g = _check_g(g)

    @property
    def kind(self) -> int:
        """Kernel kind (int)."""
        return self._kind

    @property
    def g(self) -> float:
        """Anisotropy parameter (float; 0 for isotropic and Rayleigh)."""
        return self._g

    @property
    def mean_cosine(self) -> float:
        """Mean cosine ``∫ cos θ p(cos θ) dω`` of the scattering angle (analytic)."""
        return 0.0

    def canonical(self) -> tuple[int, float, bool]:
        """``(kind, g, isotropic)`` with every isotropic phase function as one.

        :class:`Isotropic`, and :class:`HenyeyGreenstein` or :class:`Schlick` with ``g = 0``,
        all give ``(ISOTROPIC, 0.0, True)``; any other phase function its own ``(kind, g,
        False)`` (:class:`Rayleigh` is symmetric but not isotropic). Stages that key results
        on the phase function (the preintegrated tables) use this form.

        Examples
        --------
        >>> from pv_ambient.inputs.phase import HenyeyGreenstein, Schlick
        >>> HenyeyGreenstein(0.0).canonical(), Schlick(0.3).canonical()
        ((0, 0.0, True), (2, 0.3, False))
        """
        kind, g = self._kind, float(self._g)
        iso = kind == _k.ISOTROPIC or (kind in (_k.HENYEY_GREENSTEIN, _k.SCHLICK) and g == 0.0)
        if iso:
            return _k.ISOTROPIC, 0.0, True
        return kind, g, False

    @staticmethod
    def from_kind(kind: int, g: float = 0.0) -> PhaseFunction:
        """The phase function for a kernel ``kind`` and ``g`` (the inverse of ``(p.kind, p.g)``).

        Raises
        ------
        ValueError
            For an unknown kind, or ``g != 0`` for a kind without anisotropy.

        Examples
        --------
        >>> from pv_ambient.inputs.phase import PhaseFunction
        >>> PhaseFunction.from_kind(1, 0.6), PhaseFunction.from_kind(0)
        (HenyeyGreenstein(g=0.6), Isotropic())
        """
        cls = _BY_KIND.get(int(kind))
        if cls is None:
            raise ValueError(f"unknown phase kind {kind!r}; expected one of {sorted(_BY_KIND)}")
        if cls in _PARAMETRISED:
            return cls(g)
        if _check_g(g) != 0.0:
            raise ValueError(f"phase kind {kind!r} takes no anisotropy, got g = {g!r}")
        return cls()

    def eval(self, cos_theta):
        """Evaluate the phase function.

        Parameters
        ----------
        cos_theta : float or array_like
            Cosine of the angle between the propagation directions before and after
            scattering. Values within 1e-6 outside [-1, 1] are clamped.

        Returns
        -------
        float or numpy.ndarray
            ``p(cos θ)`` in 1/sr, the shape of ``cos_theta`` (a float for a scalar).

        Examples
        --------
        >>> from pv_ambient.inputs.phase import HenyeyGreenstein
        >>> hg = HenyeyGreenstein(0.6)
        >>> round(hg.eval(1.0), 6)  # (1 + g) / (4π (1 − g)²)
        0.795775
        >>> hg.eval([-1.0, 0.0, 1.0]).round(4)
        array([0.0124, 0.0321, 0.7958])
        """
        mu = np.asarray(cos_theta, dtype=np.float64)
        if not np.all(np.isfinite(mu)):
            raise ValueError("cos_theta must be finite")
        if mu.size and np.max(np.abs(mu)) > 1.0 + _COS_TOL:
            raise ValueError(
                f"cos_theta must lie in [-1, 1], got values up to {np.max(np.abs(mu))!r} in magnitude"
            )
        flat = np.ascontiguousarray(mu.ravel())
        out = np.empty_like(flat)
        _k.phase_eval_array(self._kind, self._g, flat, out)
        return float(out[0]) if mu.ndim == 0 else out.reshape(mu.shape)

    def pdf(self, cos_theta):
        """Solid-angle pdf of :meth:`sample` at ``cos_theta``; sampling is exact, so equal to
        :meth:`eval`.

        Examples
        --------
        >>> from pv_ambient.inputs.phase import Rayleigh
        >>> Rayleigh().pdf(0.0) == Rayleigh().eval(0.0)
        True
        """
        return self.eval(cos_theta)

    def sample_cos(self, u):
        """Sample ``cos θ`` by inverting the CDF at uniforms ``u`` in [0, 1] (increasing in u).

        Examples
        --------
        >>> from pv_ambient.inputs.phase import Isotropic
        >>> Isotropic().sample_cos([0.0, 0.5, 1.0])
        array([-1.,  0.,  1.])
        """
        uu = _check_uniform(u, "u")
        flat = np.ascontiguousarray(uu.ravel())
        out = np.empty_like(flat)
        _k.phase_sample_cos_array(self._kind, self._g, flat, out)
        return float(out[0]) if uu.ndim == 0 else out.reshape(uu.shape)

    def sample(self, u1, u2, direction):
        """Sample scattered propagation directions.

        Parameters
        ----------
        u1, u2 : float or array_like
            Uniforms in [0, 1]: ``u1`` picks cos θ, ``u2`` the azimuth. Broadcast together
            with ``direction[..., 0]``.
        direction : array_like, shape (..., 3)
            Propagation direction of the incoming light (normalised here; must be non-zero).

        Returns
        -------
        directions : numpy.ndarray, shape (..., 3)
            Unit propagation directions after scattering.
        pdf : float or numpy.ndarray
            Their solid-angle pdf (equal to :meth:`eval` of ``directions · direction``).

        Examples
        --------
        >>> import numpy as np
        >>> from pv_ambient.inputs.phase import HenyeyGreenstein
        >>> rng = np.random.default_rng(0)
        >>> d, pdf = HenyeyGreenstein(0.8).sample(rng.random(1000), rng.random(1000), [0, 0, 1])
        >>> d.shape, pdf.shape
        ((1000, 3), (1000,))
        >>> bool(np.allclose(np.linalg.norm(d, axis=-1), 1.0))
        True
        >>> bool(abs(d[:, 2].mean() - 0.8) < 0.05)  # mean cosine ≈ g
        True
        """
        a = _check_uniform(u1, "u1")
        b = _check_uniform(u2, "u2")
        w = np.asarray(direction, dtype=np.float64)
        if w.ndim == 0 or w.shape[-1] != 3:
            raise ValueError(f"direction must have shape (..., 3), got shape {w.shape}")
        if not np.all(np.isfinite(w)):
            raise ValueError("direction must be finite")
        norm = np.linalg.norm(w, axis=-1, keepdims=True)
        if np.any(norm == 0.0):
            raise ValueError("direction must not be the zero vector")
        w = w / norm
        try:
            shape = np.broadcast_shapes(a.shape, b.shape, w.shape[:-1])
        except ValueError:
            raise ValueError(
                f"u1 {a.shape}, u2 {b.shape} and direction {w.shape} do not broadcast"
            ) from None
        n = math.prod(shape)
        a = np.ascontiguousarray(np.broadcast_to(a, shape).reshape(n))
        b = np.ascontiguousarray(np.broadcast_to(b, shape).reshape(n))
        w = np.ascontiguousarray(np.broadcast_to(w, shape + (3,)).reshape(n, 3))
        out_dir = np.empty((n, 3))
        out_pdf = np.empty(n)
        _k.phase_sample_array(self._kind, self._g, a, b, w, out_dir, out_pdf)
        pdf = float(out_pdf[0]) if shape == () else out_pdf.reshape(shape)
        return out_dir.reshape(shape + (3,)), pdf

    def to_dict(self) -> dict:
        """The JSON scene form, accepted back by :func:`as_phase`.

        Examples
        --------
        >>> from pv_ambient.inputs.phase import Schlick, as_phase
        >>> Schlick(0.3).to_dict()
        {'kind': 'schlick', 'g': 0.3}
        >>> as_phase(Schlick(0.3).to_dict()) == Schlick(0.3)
        True
        """
        return {"kind": self._name}

    def __eq__(self, other):
        if not isinstance(other, PhaseFunction):
            return NotImplemented
        return (self._kind, self._g) == (other._kind, other._g)

    def __hash__(self):
        return hash((self._kind, self._g))

    def __repr__(self):
        return f"{type(self).__name__}()"


class Isotropic(PhaseFunction):
    """Isotropic scattering, ``p = 1/(4π)``.

    Examples
    --------
    >>> from pv_ambient.inputs.phase import Isotropic
    >>> p = Isotropic()
    >>> p, p.kind, p.g, p.mean_cosine
    (Isotropic(), 0, 0.0, 0.0)
    """

    __slots__ = ()
    _name = "isotropic"

    def __init__(self):
        super().__init__(_k.ISOTROPIC, 0.0)


class Rayleigh(PhaseFunction):
    """Rayleigh scattering, ``p = 3/(16π) (1 + cos²θ)`` (symmetric, mean cosine 0).

    Examples
    --------
    >>> from pv_ambient.inputs.phase import Rayleigh
    >>> p = Rayleigh()
    >>> round(p.eval(1.0) / p.eval(0.0), 12)
    2.0
    """

    __slots__ = ()
    _name = "rayleigh"

    def __init__(self):
        super().__init__(_k.RAYLEIGH, 0.0)


class HenyeyGreenstein(PhaseFunction):
    """Henyey–Greenstein, ``p = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})``.

    Parameters
    ----------
    g : float
        Anisotropy, ``|g| < 1``; ``g > 0`` is forward scattering. It equals the mean cosine.
        Kernels clamp ``|g|`` to 0.999 (``p(1)`` stays finite); a larger ``|g|`` warns.

    Raises
    ------
    ValueError
        If ``g`` is not finite or ``|g| >= 1``.

    Examples
    --------
    >>> from pv_ambient.inputs.phase import HenyeyGreenstein
    >>> hg = HenyeyGreenstein(0.6)
    >>> hg, hg.mean_cosine
    (HenyeyGreenstein(g=0.6), 0.6)
    >>> bool(hg.eval(1.0) > hg.eval(-1.0))  # forward peak
    True
    >>> {hg: "cached"}[HenyeyGreenstein(0.6)]
    'cached'
    """

    __slots__ = ()
    _name = "hg"

    def __init__(self, g: float):
        super().__init__(_k.HENYEY_GREENSTEIN, g)
        if abs(self._g) > _k.G_MAX:
            warnings.warn(f"HenyeyGreenstein g={self._g!r} is beyond |g| = {_k.G_MAX}, the sharpest lobe the "
                          f"kernels resolve (p(1) ≈ 1.6e5/sr): the phase function is evaluated and sampled as "
                          f"g = {math.copysign(_k.G_MAX, self._g)!r}", UserWarning, stacklevel=2)

    @property
    def mean_cosine(self) -> float:
        return self._g

    def to_dict(self) -> dict:
        return {"kind": self._name, "g": self._g}

    def __repr__(self):
        return f"{type(self).__name__}(g={self._g!r})"


class Schlick(PhaseFunction):
    """Schlick's approximation of HG, ``p = (1 − k²) / (4π (1 − k cos θ)²)``.

    ``k = 1.55 g − 0.55 g³`` (Blasi, Le Saëc, Schlick 1993); ``k > 0`` is forward scattering.
    The cubic fit exceeds 1 for ``|g| > 0.938``; kernels clamp ``|k|`` to 0.999 there, so all
    ``g`` in that range give the same lobe (mean cosine ≈ 0.993). :attr:`k` and
    :attr:`mean_cosine` report the clamped value the kernels use. The mean cosine is close to,
    but not equal to, ``g`` (0.532 at g = 0.5).

    Parameters
    ----------
    g : float
        HG-like anisotropy, ``|g| < 1``.

    Raises
    ------
    ValueError
        If ``g`` is not finite or ``|g| >= 1``.

    Examples
    --------
    >>> from pv_ambient.inputs.phase import Schlick
    >>> s = Schlick(0.5)
    >>> round(s.k, 6), round(s.mean_cosine, 4)
    (0.70625, 0.532)
    """

    __slots__ = ()
    _name = "schlick"

    def __init__(self, g: float):
        super().__init__(_k.SCHLICK, g)

    @property
    def k(self) -> float:
        """Schlick's parameter as the kernels use it (clamped to ``|k| <= 0.999``)."""
        return float(_k.schlick_k(self._g))

    @property
    def mean_cosine(self) -> float:
        return _schlick_mean_cosine(self.k)

    def to_dict(self) -> dict:
        return {"kind": self._name, "g": self._g}

    def __repr__(self):
        return f"{type(self).__name__}(g={self._g!r})"


_KINDS = {
    "isotropic": Isotropic,
    "hg": HenyeyGreenstein,
    "henyey_greenstein": HenyeyGreenstein,
    "henyeygreenstein": HenyeyGreenstein,
    "schlick": Schlick,
    "rayleigh": Rayleigh,
}
_KIND_NAMES = "'isotropic', 'hg' (or 'henyey_greenstein'), 'schlick', 'rayleigh'"
_PARAMETRISED = (HenyeyGreenstein, Schlick)
_BY_KIND = {_k.ISOTROPIC: Isotropic, _k.HENYEY_GREENSTEIN: HenyeyGreenstein, _k.SCHLICK: Schlick,
            _k.RAYLEIGH: Rayleigh}


def as_phase(spec=None) -> PhaseFunction:
    """Convert a phase-function specification into a :class:`PhaseFunction`.

    Parameters
    ----------
    spec : None, PhaseFunction, float, str or dict, default: None
        ``None`` → :class:`Isotropic`; a :class:`PhaseFunction` is returned as is; a real
        number is the HG anisotropy ``g``; a kind name (``"isotropic"``, ``"rayleigh"``);
        a dict in the JSON scene form ``{"kind": "hg", "g": 0.6}``, ``{"kind": "schlick",
        "g": 0.3}``, ``{"kind": "isotropic"}``, ``{"kind": "rayleigh"}``. Kind names are
        case-insensitive; ``"g"`` is required for ``hg``/``schlick`` and may only be 0 for
        the others.

    Returns
    -------
    PhaseFunction

    Raises
    ------
    TypeError
        For a spec of another type, or a non-string ``kind``.
    ValueError
        For an unknown kind, an unknown or missing key, or an invalid ``g``; the message
        names the key and the value received.

    Examples
    --------
    >>> from pv_ambient.inputs.phase import as_phase
    >>> as_phase(None)
    Isotropic()
    >>> as_phase(0.6)
    HenyeyGreenstein(g=0.6)
    >>> as_phase({"kind": "schlick", "g": 0.3})
    Schlick(g=0.3)
    >>> as_phase("rayleigh")
    Rayleigh()
    """
    if spec is None:
        return Isotropic()
    if isinstance(spec, PhaseFunction):
        return spec
    if isinstance(spec, (bool, np.bool_)):
        raise TypeError(f"phase spec must be None, a PhaseFunction, a float g, a kind name or a dict, got {spec!r}")
    if isinstance(spec, (Real, np.floating, np.integer)):
        return HenyeyGreenstein(spec)
    if isinstance(spec, str):
        spec = {"kind": spec}
    if not isinstance(spec, dict):
        raise TypeError(
            "phase spec must be None, a PhaseFunction, a float g, a kind name or a dict, "
            f"got {type(spec).__name__} {spec!r}"
        )
    unknown = [key for key in spec if key not in ("kind", "g")]
    if unknown:
        raise ValueError(f"unknown key {unknown[0]!r} in phase spec {spec!r}; allowed keys: 'kind', 'g'")
    if "kind" not in spec:
        raise ValueError(f"phase spec {spec!r} needs a 'kind' key (one of {_KIND_NAMES})")
    kind = spec["kind"]
    if not isinstance(kind, str):
        raise TypeError(f"phase 'kind' must be a string, got {type(kind).__name__} {kind!r}")
    cls = _KINDS.get(kind.strip().lower().replace("-", "_").replace(" ", "_"))
    if cls is None:
        raise ValueError(f"unknown phase 'kind' {kind!r}; expected one of {_KIND_NAMES}")
    if cls in _PARAMETRISED:
        if "g" not in spec:
            raise ValueError(f"phase spec {spec!r} of kind {kind!r} needs a 'g' key")
        return cls(spec["g"])
    if "g" in spec and _check_g(spec["g"]) != 0.0:
        raise ValueError(f"phase kind {kind!r} takes no anisotropy, got 'g' = {spec['g']!r}")
    return cls()


def _check_uniform(u, name: str) -> np.ndarray:
    arr = np.asarray(u, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0) or np.any(arr > 1.0):
        raise ValueError(f"{name} must hold uniforms in [0, 1], got values outside it")
    return arr
