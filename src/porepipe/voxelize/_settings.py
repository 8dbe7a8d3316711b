"""Scene section ``voxelize``."""

from pydantic import BaseModel, ConfigDict, Field

from porepipe.voxelize._api import VoxelizeMethod


class Settings(BaseModel):
    """How grey volumes are computed (the values never depend on it: both methods are bit-identical)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    method: VoxelizeMethod = Field(VoxelizeMethod.boundary, description="boundary (fast) or brute (216 points/voxel)")
    slab_planes: int = Field(32, ge=1, description="voxel planes per slab held in memory at once")
