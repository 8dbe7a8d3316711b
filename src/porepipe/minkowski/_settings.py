"""Scene section ``minkowski``."""

import enum

from pydantic import BaseModel, ConfigDict, Field


class Adjacency(str, enum.Enum):
    """Complementary adjacency pair: which phase is 6- and which is 26-connected."""

    pore6_matrix26 = "pore6_matrix26"
    pore26_matrix6 = "pore26_matrix6"

    def of(self, phase: str) -> int:
        """Adjacency (6 or 26) of ``phase`` ('pore' or 'matrix')."""
        pore = 6 if self is Adjacency.pore6_matrix26 else 26
        return pore if phase == "pore" else 32 - pore


class Settings(BaseModel):
    """How the Minkowski functionals of the segmented volumes are measured (Zauner 2020, §4.5)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting

    adjacency: Adjacency = Field(
        Adjacency.pore6_matrix26,
        description="complementary adjacency pair for the Euler numbers and K_V: pore6_matrix26 or pore26_matrix6",
    )
    slab_planes: int = Field(64, ge=1, description="x planes of the volume read into memory at once")
    threshold_functions: bool = Field(
        False,
        description="also compute φ, S_V, K_V, T_V, χ of the grey volume at every threshold g_th (one pass)",
    )
