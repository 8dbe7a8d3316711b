"""Scene section ``segmentation`` (the scene's top-level key; segment has no section of its own in the registry)."""

import enum

from pydantic import BaseModel, ConfigDict, Field, model_validator


class SegmentationMethod(str, enum.Enum):
    """How the grey threshold g_th is chosen: Otsu's method, the thesis's trivial threshold, or a fixed value."""

    otsu = "otsu"
    trivial = "trivial"
    fixed = "fixed"


class Segmentation(BaseModel):
    """Pore if grey value g <= threshold (the thesis's convention, §4.7.2)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    method: SegmentationMethod = SegmentationMethod.otsu
    threshold: int | None = Field(None, ge=0, le=215, description="g_th for method fixed (0..215)")

    @model_validator(mode="after")
    def _threshold_for_fixed(self):
        if self.method is SegmentationMethod.fixed and self.threshold is None:
            raise ValueError("method fixed needs `threshold` (an integer 0..215)")
        if self.method is not SegmentationMethod.fixed and self.threshold is not None:
            raise ValueError("`threshold` is only used with method fixed; remove it or set method: fixed")
        return self
