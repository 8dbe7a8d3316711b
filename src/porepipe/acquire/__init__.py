"""Data acquisition: read µ-CT / SEM images, segment them, measure their statistics, calibrate a model, compare."""

from porepipe.acquire._settings import Settings

__all__ = ["Settings"]
