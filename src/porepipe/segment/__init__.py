"""Segmentation of grey volumes into pore and matrix (Otsu or fixed threshold, pore if g <= g_th)."""

from porepipe._shared.lazy import lazy_exports

_EXPORTS = {
    "Threshold": "_api",
    "choose_threshold": "_api",
    "otsu_threshold": "_api",
    "segment": "_api",
}
__all__ = [*_EXPORTS]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
