"""Scene section ``voxelize``."""

import enum

from pydantic import BaseModel, ConfigDict, Field


class VoxelizeMethod(str, enum.Enum):
    """``boundary``: interior voxel rows in bulk, only shell voxels tested (bit masks only where spheres meet); ``brute``: all
    216 points of every voxel near a sphere (the thesis's method, kept as oracle and for the benchmark). Both give
    identical grey values.
    """

    boundary = "boundary"
    brute = "brute"


class Settings(BaseModel):
    """How grey volumes are computed (the values never depend on it: both methods are bit-identical)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    method: VoxelizeMethod = Field(
        VoxelizeMethod.boundary, description="boundary (fast) or brute (216 points/voxel)"
    )
    slab_planes: int = Field(32, ge=1, description="voxel planes per slab held in memory at once")
