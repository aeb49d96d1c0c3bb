"""Tests the first contact with real data end to end: the MNI152 template rendered with no light,
exposure or transfer-function tuning is well exposed (the README's first picture)."""
import numpy as np

import pv_ambient as pa


def luminance_shares(img, alpha):
    """(share of covered pixels above 10 % luminance, share with a saturated channel, count):
    the figures of the issue's acceptance 1, on the 8-bit image."""
    covered = alpha > 0.5
    x = img[..., :3].astype(np.float64) / 255.0
    lum = x @ np.array([0.2126, 0.7152, 0.0722])
    return (float(np.mean(lum[covered] > 0.1)), float(np.mean((img[..., :3] == 255).any(axis=-1)[covered])),
            int(covered.sum()))


def test_mni152_no_tuning_is_well_exposed(mni152):
    """The README's first picture: ≥ 50 % of the brain's pixels above 10 % luminance, ≤ 5 % saturated,
    with the default rig and with one default point light 300 mm above the brain."""
    mni152, _ = mni152
    tf = pa.TransferFunction(cmap="bone")
    size = (160, 160)
    res = pa.render(mni152, transfer_function=tf, model="ambient_scattering", window_size=size)
    bright, saturated, n = luminance_shares(res.to_uint8(), res.alpha)
    assert n > 1500 and bright >= 0.5 and saturated <= 0.05, (bright, saturated, n)
    top = np.reshape(mni152.bounds, (3, 2)).mean(axis=1) + (0.0, 0.0, 300.0)
    res = pa.render(mni152, transfer_function=tf, model="ambient_scattering", window_size=size,
                    lights=[pa.PointLight(tuple(top))])
    bright, saturated, n = luminance_shares(res.to_uint8(), res.alpha)
    assert n > 1500 and bright >= 0.5 and saturated <= 0.05, (bright, saturated, n)
