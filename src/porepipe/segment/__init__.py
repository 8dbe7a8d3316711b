"""Segmentation of grey volumes into pore and matrix (Otsu or fixed threshold, pore if g <= g_th)."""

from porepipe.segment._api import Threshold, choose_threshold, otsu_threshold, segment

__all__ = ["Threshold", "choose_threshold", "otsu_threshold", "segment"]
