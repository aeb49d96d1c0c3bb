"""The progressive model's correction, kept where it is measurable (docs/progressive.rst).

The ``progressive`` model's unbiased picture is ``P = N + Δ̂``: the base model's noise-free
picture ``N`` and a Monte Carlo estimate ``Δ̂`` of the correction ``Δ = L − N`` (the residual
mean plus the deterministic control-minus-base difference), with per-pixel variance ``v``
(``std_error²``). Early on ``Δ̂``'s noise is far larger than ``Δ`` itself, and ``P`` is a worse
picture than ``N``; a bias that is smooth over the image, though, is measured long before a
single pixel's is. So the correction is split into the levels of a Haar (block-mean) pyramid —
the whole image's mean, then each 2×2 split of it, down to single pixels — and each level's
detail is added where it stands out of its own noise:

* level ``K`` (one block, the whole image): its mean ``M`` is kept when ``M² ≥ t²·Var(M)``;
* every other block ``c`` of level ``k``, child of block ``p`` of level ``k + 1``: its detail
  ``d = M_c − M_p`` (block means of ``Δ̂``) has variance ``Var(M_c) − 2·Cov(M_c, M_p) +
  Var(M_p)``, from ``v`` with the pixels independent (they are: each pixel's samples are its
  own); the details of a parent's (up to four) children are kept *together*, when any of them
  has ``d² ≥ t²·Var(d)`` — so a kept level never moves its parent's mean, and the picture's mean
  is the whole image's level (kept or not), over the pixels not known exactly (below);
* ``t = √(2 ln n)``, ``n`` the number of coefficients (pixels × channels): the universal
  threshold of wavelet shrinkage (Donoho & Johnstone 1994), under which pure noise crosses with
  probability → 0 as the image grows — 4.3 for a 64×64 RGB picture. A detail kept by mistake
  adds the same squared error at every level (a block's noise falls as its pixels grow), so one
  threshold serves all of them, the whole image's mean included (a lower threshold there, tried
  first, let heavy-tailed noise shift whole pictures at a few samples per pixel).
* A pixel whose variance is 0 — there and in its 3×3 neighbourhood, e.g. background that every
  sample left at once — holds a correction known exactly: it keeps exactly its own, and the
  block means are those of the other pixels (a correction measured on the medium does not leak
  into the empty space around it).
* The variances are estimated from the samples themselves: with ``samples`` per pixel given,
  ``t`` becomes Student's t quantile of the same tail probability, with the degrees of freedom
  of the block's pooled estimate, ``(samples − 1)·(2^k + 2)²`` at level ``k`` (its pixels and
  their 3×3 neighbours) — a pixel whose two samples agree has not shown a small variance.

The result is *consistent*, not unbiased at every sample count: as the samples grow every
variance falls to zero, every non-zero detail is kept and the picture tends to ``P``'s limit,
the transfer equation's answer; at a finite count a detail is dropped only while it is below
``t`` of its noise, and the image mean is dropped only while it is below ``t`` of its standard
error. A pixel whose variance is infinite (fewer than two samples) or NaN keeps nothing of its
own level. Each pixel's variance is first replaced by the larger of it and its 3×3
neighbourhood's mean, so that a pixel whose few samples happen to agree (an underestimated
variance: a heavy-tailed estimator's usual case) does not pass for a measured one.

This module is pure NumPy (the array core: no pyvista).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["universal_threshold", "threshold_correction", "held_out_z", "refined_picture", "progressive_picture",
           "denoise_guide", "HeldOutPasses"]


def universal_threshold(n: int) -> float:
    """``√(2 ln n)``: the threshold (in standard errors) above which one of ``n`` pure-noise
    Gaussian coefficients is unlikely to rise (probability ≤ 1/√(π ln n) for the largest).

    >>> round(universal_threshold(64 * 64 * 3), 3)
    4.34
    """
    return math.sqrt(2.0 * math.log(max(int(n), 2)))


def _pool(a, how):
    """2×2 blocks of an ``(H, W, C)`` array (odd sizes: the last row/column alone): sum or max."""
    h, w = a.shape[:2]
    ph, pw = -(-h // 2), -(-w // 2)
    fill = 0.0 if how == "sum" else -np.inf
    out = np.full((2 * ph, 2 * pw) + a.shape[2:], fill, dtype=a.dtype)
    out[:h, :w] = a
    out = out.reshape(ph, 2, pw, 2, *a.shape[2:])
    return out.sum(axis=(1, 3)) if how == "sum" else out.max(axis=(1, 3))


def _up(a, shape):
    """Each block's value on its (up to four) children: the inverse of :func:`_pool`'s layout."""
    return np.repeat(np.repeat(a, 2, axis=0), 2, axis=1)[: shape[0], : shape[1]]


def _neighbourhood_max(v):
    """``max(v, mean of v over the 3×3 neighbourhood)`` (edge pixels: their in-image neighbours)."""
    h, w = v.shape[:2]
    pad = np.pad(v, ((1, 1), (1, 1)) + ((0, 0),) * (v.ndim - 2))
    one = np.pad(np.ones((h, w)), 1)
    s = sum(pad[i:i + h, j:j + w] for i in range(3) for j in range(3))
    cnt = sum(one[i:i + h, j:j + w] for i in range(3) for j in range(3))
    if v.ndim == 3:
        cnt = cnt[..., None]
    return np.maximum(v, s / cnt)


def threshold_correction(delta, variance, *, threshold=None, samples=None):
    """The correction ``delta`` (an ``(H, W, C)`` estimate whose per-entry variance is
    ``variance``) with every Haar detail that does not stand out of its noise removed (module
    docstring). Returns ``(kept, share)``: the float64 correction to add to the base picture and
    the share of pixel-level detail groups kept (0 to 1; 1 once every pixel's own level is in),
    counted over the groups with a non-zero detail or variance.

    ``threshold``: in standard errors, one for every level; default: :func:`universal_threshold`
    of ``delta.size``.
    ``samples``: the samples per pixel ``variance`` was estimated from (None: known exactly); a
    variance estimated from few samples is itself uncertain, and the threshold becomes Student's
    t quantile of the same tail probability (module docstring) — no detail is kept from one
    sample.
    A zero variance keeps every non-zero detail (an exact correction is added in full); an
    infinite one keeps none.

    >>> import numpy as np
    >>> d = np.full((4, 4, 1), 0.5)
    >>> float(threshold_correction(d, np.zeros_like(d))[0].mean())     # exact: all of it
    0.5
    >>> float(np.abs(threshold_correction(d, np.full_like(d, 1e3))[0]).max())  # lost in its noise
    0.0
    """
    d = np.asarray(delta, dtype=np.float64)
    v = np.asarray(variance, dtype=np.float64)
    if d.ndim == 2:
        out, share = threshold_correction(d[..., None], v[..., None], threshold=threshold, samples=samples)
        return out[..., 0], share
    if d.shape != v.shape or d.ndim != 3:
        raise ValueError(f"delta and variance must be (H, W, C) arrays of one shape, got {d.shape} and {v.shape}")

    t = universal_threshold(d.size) if threshold is None else float(threshold)

    def t2(k):
        """The squared threshold for a variance estimated from ``samples`` per pixel over a
        level-``k`` block (pooled over its pixels and their 3×3 neighbours): Student's t quantile
        with the Gaussian ``t``'s tail probability (Welch–Satterthwaite degrees of freedom)."""
        if samples is None:
            return t * t
        dof = (int(samples) - 1) * (2 ** k + 2) ** 2
        if dof <= 0:
            return np.inf
        from scipy import stats

        return float(stats.t.isf(stats.norm.sf(t), dof)) ** 2

    v = np.where(np.isnan(v), np.inf, v)
    v = _neighbourhood_max(v)
    exact = v == 0.0  # a correction known exactly (no spread here nor next to it): kept as it is
    w = np.where(exact, 0.0, 1.0)
    # the pyramid of sums over the other pixels: S (of Δ̂), Q (of the variances), n (pixels)
    sums, qs, ns = [d * w], [np.where(exact, 0.0, v)], [w]
    while sums[-1].shape[0] > 1 or sums[-1].shape[1] > 1:
        sums.append(_pool(sums[-1], "sum"))
        qs.append(_pool(qs[-1], "sum"))
        ns.append(_pool(ns[-1], "sum"))

    def moments(k):  # block means and their variances (a block with no such pixel: nothing to keep)
        n = ns[k]
        some = n > 0.0
        safe = np.where(some, n, 1.0)
        return np.where(some, sums[k] / safe, 0.0), np.where(some, qs[k] / safe ** 2, np.inf), safe

    with np.errstate(invalid="ignore", over="ignore"):
        mean_top, var_top, _ = moments(len(sums) - 1)
        r = np.where(mean_top ** 2 >= t2(len(sums) - 1) * var_top, mean_top, 0.0)
        share = 1.0
        for k in range(len(sums) - 2, -1, -1):
            shape = sums[k].shape
            mk, vk, nk = moments(k)
            mp, vp, np_ = (_up(a, shape) for a in moments(k + 1))
            var_d = vk - 2.0 * qs[k] / (nk * np_) + vp  # Var(M_c) − 2 Cov(M_c, M_p) + Var(M_p)
            det = mk - mp
            stands = (det != 0.0) & (det ** 2 >= t2(k) * var_d)
            z_max = _pool(np.where(stands, 1.0, 0.0), "max")  # any child of the parent
            group = _up(z_max, shape) > 0.0
            r = _up(r, shape) + np.where(group, det, 0.0)
            if k == 0:  # over the groups with something to keep (not where every pixel is exact)
                active = _pool(np.where(exact, 0.0, 1.0), "max") > 0.0
                share = float(np.mean(z_max[active] > 0.0)) if active.any() else 1.0
        r = np.where(exact, d, r)
    return r, share


def _block_means(a, block):
    """Means of ``block``×``block`` tiles (``block`` a power of two) of an ``(H, W, C)`` array —
    :func:`_pool`'s 2×2 blocks, repeated (edge tiles: their own pixels) — and the tiles' pixel
    counts ``(h, w, 1)``."""
    if block < 1 or block & (block - 1):
        raise ValueError(f"block must be a power of two, got {block}")
    s = np.asarray(a, dtype=np.float64)
    n = np.ones(s.shape[:2] + (1,))
    while block > 1:
        s, n, block = _pool(s, "sum"), _pool(n, "sum"), block // 2
    return s / n, n


def held_out_z(first, second, estimates, variances, *, block=4) -> float:
    """Which of two ways of making a picture from Monte Carlo samples is closer to the limit, by
    held-out samples; returns a z statistic, negative when ``first`` is the closer.

    The samples are split into two independent halves, ``estimates = (P_a, P_b)`` their unbiased
    pictures (``(H, W, C)``, of the same limit ``L``) and ``variances`` their per-pixel variances
    (``std_error²``; pixels independent). ``first = (X_a, X_b)``: the first way's picture made
    from half ``a`` alone and from half ``b`` alone; ``second`` likewise. ``X_a`` is independent
    of ``P_b``, so for every ``block``×``block`` mean ``M``,
    ``E[(M(X_a) − M(P_b))²] = (M(X_a) − M(L))² + Var(M(P_b))``: the difference between the two
    ways of ``Σ (M(X_a) − M(P_b))² + (M(X_b) − M(P_a))²`` over blocks and channels has
    expectation the difference of their squared block errors (the variance terms cancel), and
    its noise ``−2 (M(X_a) − M(Y_a)) (M(P_b) − M(L))`` (and the same for ``b``) has variance
    ``4 (M(X_a) − M(Y_a))² Var(M(P_b))`` summed. The result is the difference over its standard
    error; 0 where it cannot be told (a variance not finite: fewer than two samples per pixel,
    or the two ways alike). Nothing of the reference is used (docs/progressive.rst, "Denoising").

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> truth = np.linspace(1.0, 2.0, 32 * 32 * 3).reshape(32, 32, 3)
    >>> a, b = (truth + rng.normal(0.0, 0.5, truth.shape) for _ in range(2))
    >>> var = np.full(truth.shape, 0.25)
    >>> held_out_z((truth, truth), (truth + 0.1, truth + 0.1), (a, b), (var, var)) < -3
    True
    """
    (xa, xb), (ya, yb), (pa, pb), (va, vb) = first, second, estimates, variances
    shapes = {np.shape(x) for x in (xa, xb, ya, yb, pa, pb, va, vb)}
    if len(shapes) != 1 or len(next(iter(shapes))) != 3:
        raise ValueError(f"the pictures, estimates and variances must be (H, W, C) arrays of one shape, got {sorted(shapes)}")
    (mxa, n), (mxb, _), (mya, _), (myb, _), (mpa, _), (mpb, _) = (_block_means(x, block) for x in (xa, xb, ya, yb, pa, pb))
    var_a, var_b = (_block_means(v, block)[0] / n for v in (va, vb))  # Var of a block mean: Σv / n²
    diff = (mxa - mpb) ** 2 - (mya - mpb) ** 2 + (mxb - mpa) ** 2 - (myb - mpa) ** 2
    with np.errstate(invalid="ignore"):
        var = 4.0 * ((mxa - mya) ** 2 * var_b + (mxb - myb) ** 2 * var_a)
        total = float(np.sum(var))
    if not np.isfinite(total) or total <= 0.0:
        return 0.0
    return float(np.sum(diff)) / math.sqrt(total)


def refined_picture(base, estimate, std_error, samples=None):
    """The ``progressive`` model's picture: ``base`` (the noise-free model's) plus the part of the
    correction ``estimate − base`` that stands out of its noise (``std_error``, the estimate's,
    from ``samples`` per pixel), by :func:`threshold_correction`
    (docs/progressive.rst). Returns the float64 picture and the share of pixel-level details kept.
    With fewer than ``REFINE_MIN_SAMPLES`` samples only the corrections known exactly (no
    variance there nor around) are added.

    >>> import numpy as np
    >>> base = np.zeros((2, 2, 3))
    >>> pic, kept = refined_picture(base, base + 0.25, np.zeros((2, 2, 3)))   # exact: kept in full
    >>> float(pic.mean()), kept
    (0.25, 1.0)
    """
    b = np.asarray(base, dtype=np.float64)
    # fewer than REFINE_MIN_SAMPLES: no detail stands out yet — only the exactly known corrections
    few = samples is not None and int(samples) < REFINE_MIN_SAMPLES
    corr, kept = threshold_correction(np.asarray(estimate, dtype=np.float64) - b,
                                      np.asarray(std_error, dtype=np.float64) ** 2, samples=samples,
                                      threshold=math.inf if few else None)
    return b + corr, kept


#: Samples per pixel before the ``progressive`` model's picture keeps any detail of its correction
#: that is not known exactly (fewer: the base picture, plus the exact corrections). The threshold
#: takes the variances from the samples themselves, and a heavy-tailed residual's few samples
#: underestimate them: below this count the details kept make the picture worse than its base
#: more often than better (docs/progressive.rst, "The picture shown").
REFINE_MIN_SAMPLES = 16


#: The held-out z statistic (:func:`held_out_z`) below which the
#: ``progressive`` model's denoised picture replaces its thresholded one: 1 standard error (a
#: one-sided false alarm of 16 % for Gaussian noise where the two are equally good, where the
#: choice costs nothing; a margin against heavy-tailed noise elsewhere; docs/progressive.rst).
HELD_OUT_Z = 1.0
#: Samples per pixel each held-out half needs before the choice is made (fewer: the thresholded
#: picture). With 2–8 samples per pixel a heavy-tailed residual's variances are underestimated
#: and the statistic misleads (docs/progressive.rst, "Denoising": the measured wrong choices).
HELD_OUT_MIN_SAMPLES = 16


def denoise_guide(base) -> np.ndarray:
    """The guide OIDN gets beside a ``progressive`` picture: the base model's noise-free picture
    scaled by its 99th percentile and clipped to [0, 1] (float32) — its edges and shading are the
    picture's, so the denoiser keeps them (docs/progressive.rst, "Denoising").

    >>> import numpy as np
    >>> float(denoise_guide(np.linspace(0.0, 2.0, 300).reshape(10, 10, 3)).max())
    1.0
    """
    b = np.nan_to_num(np.asarray(base, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    scale = float(np.percentile(b, 99))
    if scale <= 0.0:
        scale = float(b.max())
    return np.clip(b / scale if scale > 0.0 else np.zeros_like(b), 0.0, 1.0).astype(np.float32)


def progressive_picture(base, halves, *, denoise=False, denoiser=None):
    """The ``progressive`` model's picture from its samples given as up to two independent halves
    ``[(estimate, std_error, samples), ...]`` (``estimate``: the unbiased picture ``P`` of that
    half). Returns ``(picture, metadata)``: the float64 picture and ``kept`` (the share of
    pixel-level details kept), ``residual`` (``"thresholded"`` or ``"denoised"``) and, with
    ``denoise`` and two halves, ``held_out_z`` (the statistic of the choice).

    Without ``denoise`` it is :func:`refined_picture` of all the samples. With it, a second
    candidate is the unbiased ``P`` denoised — ``denoiser(P, guide)``, by default OIDN
    (``pyoidn``) guided by the base picture (:func:`denoise_guide`) — rescaled per channel to
    ``P``'s mean. Both are made again from each half alone, and the denoised one is taken (made
    from all the samples) only when the held-out halves find it closer by more than
    ``HELD_OUT_Z`` standard errors (:func:`held_out_z`) and each half
    has at least ``HELD_OUT_MIN_SAMPLES`` samples per pixel. Both tend to
    ``P``'s limit as samples grow, so the choice does not change what the picture converges to
    (docs/progressive.rst, "Denoising").

    >>> import numpy as np
    >>> truth = np.linspace(1.0, 2.0, 16 * 16 * 3).reshape(16, 16, 3)
    >>> rng = np.random.default_rng(1)
    >>> halves = [(truth + rng.normal(0, 0.3, truth.shape), np.full(truth.shape, 0.3), 16) for _ in range(2)]
    >>> pic, meta = progressive_picture(0.5 * truth, halves, denoise=True,   # a denoiser that knows the shape
    ...                                 denoiser=lambda p, guide: guide * p.mean() / guide.mean())
    >>> meta["residual"], bool(np.abs(pic - truth).max() < 0.1)
    ('denoised', True)
    """
    from .reference import Accumulator

    b = np.asarray(base, dtype=np.float64)
    if len(halves) == 1:  # one estimate: as it is
        mean, se, samples = halves[0]
    else:
        acc = Accumulator()
        for est, err, n in halves:
            acc.add(est, err, np.zeros(b.shape[:2]), samples=n)
        mean, se, samples = acc.mean, acc.std_error, acc.samples
    picture, kept = refined_picture(b, mean, se, samples=samples)
    meta = dict(kept=kept, residual="thresholded")
    if not denoise or len(halves) != 2 or min(int(h[2]) for h in halves) < HELD_OUT_MIN_SAMPLES:
        return picture, meta
    if denoiser is None:
        from .denoise import denoise_radiance

        def denoiser(p, guide):
            return denoise_radiance(p, albedo=guide, mean_preserving=False)
    from .denoise import preserve_mean

    guide = denoise_guide(b)

    def denoised(p):
        d = np.asarray(denoiser(p, guide), np.float64)
        return np.asarray(preserve_mean(d, p), np.float64) if np.all(np.sum(p, axis=(0, 1)) > 0) else d

    (ea, sa, na), (eb, sb, nb) = ((np.asarray(e, np.float64), np.asarray(v, np.float64), int(n)) for e, v, n in halves)
    z = held_out_z((denoised(ea), denoised(eb)),
                   (refined_picture(b, ea, sa, samples=na)[0], refined_picture(b, eb, sb, samples=nb)[0]),
                   (ea, eb), (sa * sa, sb * sb))
    meta["held_out_z"] = z
    if z < -HELD_OUT_Z:
        picture = denoised(mean)
        meta["residual"] = "denoised"
    return picture, meta


class HeldOutPasses:
    """Passes of residual samples, kept whole and as two held-out halves (even and odd passes):
    what :func:`progressive_picture` chooses its denoised picture with (docs/progressive.rst,
    "Denoising").

    ``all`` is the :class:`~pv_ambient.stages.reference.Accumulator` of every pass; a half of one
    pass hands that pass on as it is (no round trip through sums).

    >>> import numpy as np
    >>> p = HeldOutPasses()
    >>> for v in (1.0, 3.0, 5.0):
    ...     p.add(np.full((1, 1, 3), v), np.zeros((1, 1, 3)), np.ones((1, 1)), samples=2)
    >>> p.all.samples, [float(h[0].mean()) for h in p.halves()], [h[2] for h in p.halves()]
    (6, [3.0, 3.0], [4, 2])
    """

    def __init__(self):
        from .reference import Accumulator

        self.all = Accumulator()
        self._halves = [[Accumulator(), None], [Accumulator(), None]]

    def add(self, radiance, std_error, alpha, samples):
        """Add one pass (its mean ``radiance``, ``std_error`` and ``alpha`` over ``samples``)."""
        half = self._halves[self.all.passes % 2]
        half[0].add(radiance, std_error, alpha, samples=samples)
        half[1] = ((np.asarray(radiance, np.float64), np.asarray(std_error, np.float64), int(samples))
                   if half[0].passes == 1 else None)
        self.all.add(radiance, std_error, alpha, samples=samples)

    def halves(self, offset=0.0) -> list:
        """``[(estimate + offset, std_error, samples), ...]`` of the halves that hold samples."""
        out = []
        for acc, first in self._halves:
            if acc.samples == 0:
                continue
            est, se, n = first if first is not None else (acc.mean, acc.std_error, acc.samples)
            out.append((offset + est, se, n))
        return out

    def picture(self, base, *, offset=0.0, denoise=False, denoiser=None):
        """:func:`progressive_picture` of these passes (each estimate plus ``offset``)."""
        return progressive_picture(base, self.halves(offset), denoise=denoise, denoiser=denoiser)
