"""Segmentation of grey volumes: Otsu on the grey histogram, or a fixed threshold; pore if g <= g_th."""

from __future__ import annotations

import dataclasses

import numpy as np

from porepipe._shared.errors import PorepipeError
from porepipe.segment._settings import SegmentationMethod

G_MAX = 216
#: threshold used when the histogram has a single populated grey value (Otsu undefined): pore if the voxel is
#: less than half matrix, g <= 107 (g < 216 / 2). This is porepipe's choice, not the thesis's.
HALF_THRESHOLD = 107
#: the thesis's trivial threshold: §4.7.2 names g_th = 128 and Fig. 7.3 calls a voxel pore if g < 128; in the
#: g <= g_th convention that is 127 (the two readings differ by one grey level; we follow Fig. 7.3, whose pictures
#: were made with it). On the 0..216 scale it is not half matrix: 128/216 = 0.59.
THESIS_TRIVIAL_THRESHOLD = 127


@dataclasses.dataclass(frozen=True)
class Threshold:
    """A segmentation decision: pore if g <= ``value``."""

    value: int
    method: SegmentationMethod
    note: str = ""


def otsu_threshold(hist: np.ndarray) -> int:
    """Otsu's threshold t of a grey histogram (pore = g <= t), maximising the between-class variance.

    Parameters
    ----------
    hist : (G,) ndarray of int
        Counts per grey value 0..G-1.

    Returns
    -------
    t : int
        The largest of the maximisers' lower class ends (ties to the lower t, as scikit-image does).

    Notes
    -----
    N. Otsu, IEEE Trans. SMC 9 (1979) 62. Computed from the histogram alone, so a volume of any size costs O(G).
    """
    hist = np.asarray(hist, dtype=np.float64)
    if hist.ndim != 1 or hist.size < 2 or not np.all(np.isfinite(hist) & (hist >= 0)) or hist.sum() <= 0:
        raise PorepipeError(
            f"otsu needs a 1-D histogram of >= 2 bins with finite counts >= 0, not all 0; got shape "
            f"{hist.shape}, smallest count {hist.min() if hist.size else None} and sum {hist.sum()}"
        )
    g = np.arange(hist.size, dtype=np.float64)
    w0 = np.cumsum(hist)[:-1]
    w1 = hist.sum() - w0
    m0 = np.cumsum(hist * g)[:-1]
    mu0 = np.divide(m0, w0, out=np.zeros_like(m0), where=w0 > 0)
    mu1 = np.divide(m0[-1] + hist[-1] * g[-1] - m0, w1, out=np.zeros_like(m0), where=w1 > 0)
    between = w0 * w1 * (mu0 - mu1) ** 2
    return int(np.argmax(between))


def choose_threshold(hist: np.ndarray, method: SegmentationMethod, fixed: int | None = None) -> Threshold:
    """Decide the threshold for a grey histogram M(g), g = 0..216."""
    hist = np.asarray(hist)
    if hist.shape != (G_MAX + 1,):
        raise PorepipeError(f"grey histogram needs 217 bins (g = 0..216), got shape {hist.shape}")
    method = SegmentationMethod(method)
    populated = np.flatnonzero(hist)
    if method is SegmentationMethod.fixed:
        if fixed is None or not 0 <= fixed <= G_MAX - 1:
            raise PorepipeError(f"fixed threshold must be an integer 0..215, got {fixed}")
        return Threshold(int(fixed), method)
    if method is SegmentationMethod.trivial:
        return Threshold(
            THESIS_TRIVIAL_THRESHOLD, method, "the thesis's trivial threshold (Fig. 7.3: pore if g < 128)"
        )
    if populated.size == 0:
        raise PorepipeError("empty grey histogram: the volume has no voxels")
    if populated.size == 1:
        g = int(populated[0])
        phase = "pore" if g <= HALF_THRESHOLD else "matrix"
        return Threshold(
            HALF_THRESHOLD,
            method,
            f"single grey value g={g}: Otsu undefined; whole volume is {phase} (pore if g <= "
            f"{HALF_THRESHOLD})",
        )
    return Threshold(otsu_threshold(hist), method)


def segment(grey: np.ndarray, threshold: int) -> np.ndarray:
    """Binary pore indicator (uint8, 1 = pore) of a grey volume: pore where g <= threshold."""
    return (grey <= threshold).astype(np.uint8)
