"""Grain decoration: polyhedral grain types on a sphere packing and their grey-value voxelisation (Zauner 2020, §4.7)."""
