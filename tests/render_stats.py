"""z-scores for comparing two independent renders (RenderResult) of the same expectation,
from the renders' own per-pixel variance estimates. Channels stay separate: in a grey
medium, or under one white light, the three carry the same samples up to a factor, so
pooling them would count one z-score three times."""

from __future__ import annotations

import numpy as np


def mean_z(a, b) -> np.ndarray:
    """Per channel, the z-score of the difference of the two images' means (variance: the
    sum of per-pixel variances of the mean / pixels^2)."""
    npix = a.image.shape[0] * a.image.shape[1]
    diff = a.image.reshape(-1, 3).astype(np.float64).mean(axis=0) - \
        b.image.reshape(-1, 3).astype(np.float64).mean(axis=0)
    var = (a.variance.reshape(-1, 3).astype(np.float64).sum(axis=0)
           + b.variance.reshape(-1, 3).astype(np.float64).sum(axis=0)) / npix ** 2
    return diff / np.sqrt(var)


def block_z(a, b, block: int = 4) -> list[np.ndarray]:
    """z-scores of block x block means of the two images, one array per channel (rows and
    columns beyond whole blocks, and blocks where both renders are exact, left out)."""
    h, w = a.image.shape[:2]
    h, w = h - h % block, w - w % block

    def blocks(x):
        x = np.asarray(x[:h, :w], np.float64)
        return x.reshape(h // block, block, w // block, block, -1).sum(axis=(1, 3))

    diff = blocks(a.image) - blocks(b.image)
    var = blocks(a.variance) + blocks(b.variance)
    return [diff[..., c][var[..., c] > 0] / np.sqrt(var[..., c][var[..., c] > 0])
            for c in range(3)]
