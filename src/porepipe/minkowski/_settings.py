"""Scene section ``minkowski``."""

from pydantic import BaseModel, ConfigDict, Field

from porepipe.minkowski._weights import Adjacency


class Settings(BaseModel):
    """How the Minkowski functionals of the segmented volumes are measured (Zauner 2020, §4.5)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    adjacency: Adjacency = Field(
        Adjacency.pore6_matrix26,
        description="complementary adjacency pair for the Euler numbers and K_V: pore6_matrix26 or pore26_matrix6")
    slab_planes: int = Field(64, ge=1, description="x planes of the volume read into memory at once")
    threshold_functions: bool = Field(
        False, description="also compute φ, S_V, K_V, T_V, χ of the grey volume at every threshold g_th (one pass)")
