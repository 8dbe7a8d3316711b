"""Pieces every stage shares: errors, the HDF5 store, progress lines, numba settings."""
