"""Scene section ``acquire``: the image a scene starts from, how to prepare and segment it, what to measure.

Its presence switches the acquisition stage on (Zauner 2020, §4.7 item 1 and ch. 8); the scene then may omit
``domain`` and ``spheres``. Paths are relative to the scene file. Axis order is (x, y, z) = array axes (0, 1, 2).
"""

from __future__ import annotations

import dataclasses
import enum
import itertools
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

PosFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
PosInt = Annotated[int, Field(ge=1)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # no NaN/inf setting


@dataclasses.dataclass(frozen=True)
class SettingNames:
    """How a message names an ``acquire`` setting: by its command-line option where ``options`` (dotted key below
    ``acquire`` -> option) holds one (``porepipe acquire`` fills it with the options given, and with those its user
    would give for keys the scene does not set), else by its scene key ``acquire.<key>``.
    """

    options: Mapping[str, str] = dataclasses.field(default_factory=dict)

    def __call__(self, key: str) -> str:
        return self.options.get(key, f"acquire.{key}")

    def by_option(self, key: str) -> bool:
        """Whether ``key`` is named by its command-line option."""
        return key in self.options


#: every setting named by its scene key (a scene run, and the Python API)
SCENE_KEYS = SettingNames()


class ImageFormat(str, enum.Enum):
    """File formats the readers understand; ``auto`` picks by suffix (a directory is a TIFF stack)."""

    auto = "auto"
    tiff = "tiff"  # one multi-page/3-D TIFF, or a directory / glob of 2-D TIFF sections
    raw = "raw"  # headerless or fixed-header binary; needs `raw`
    hdf5 = "hdf5"  # one dataset of an HDF5 file; needs `dataset`
    npy = "npy"  # NumPy .npy (memory-mapped)


class ByteOrder(str, enum.Enum):
    little = "little"
    big = "big"


class MemoryOrder(str, enum.Enum):
    """How the RAW file runs: C = last axis fastest (x, y, z with z fastest); F = x fastest (the usual CT dump)."""

    C = "C"
    F = "F"


class Raw(_Strict):
    """What the reader cannot guess about a RAW file."""

    dtype: str = Field(
        "uint8", description="NumPy element type without byte order: uint8, uint16, int16, float32 …"
    )
    shape: tuple[PosInt, PosInt, PosInt] = Field((1, 1, 1), description="voxels along x, y, z")
    byte_order: ByteOrder = Field(ByteOrder.little, description="byte order of multi-byte elements")
    header_bytes: int = Field(0, ge=0, description="bytes to skip before the data")
    order: MemoryOrder = Field(MemoryOrder.F, description="F: x runs fastest in the file; C: z runs fastest")


class Crop(_Strict):
    """A box of the image in voxels: ``start`` (x, y, z) and ``size`` (x, y, z); ``centre: true`` centres it."""

    start: tuple[int, int, int] = Field((0, 0, 0), description="first voxel (ignored with centre)")
    size: tuple[PosInt, PosInt, PosInt] = Field(description="voxels along x, y, z")
    centre: bool = Field(
        False, description="centre the box in the image (the thesis's Bentheimer crop, §8.1)"
    )


class Denoise(str, enum.Enum):
    none = "none"
    median = "median"  # scipy/scikit-image median filter of a cube of `denoise_size` voxels
    nl_means = "nl_means"  # scikit-image non-local means (slow; small images or 2-D sections)


class Method(str, enum.Enum):
    """How grey values become phases."""

    otsu = "otsu"  # two phases: pore (dark) and matrix
    multi_otsu = "multi_otsu"  # len(phases) classes by multi-level Otsu (scikit-image)
    thresholds = "thresholds"  # user thresholds, len(phases) - 1 of them, ascending


class Segmentation(_Strict):
    """Phases in order of increasing grey value; pore if g <= t for the pore class (the thesis's convention)."""

    method: Method = Field(Method.otsu, description="otsu, multi_otsu or thresholds")
    phases: list[str] = Field(
        default_factory=lambda: ["pore", "matrix"],
        description="phase names from darkest to brightest (Table 8.1: pore, clay, cement, grains)",
    )
    pore_phases: list[str] = Field(
        default_factory=lambda: ["pore"], description="phases that count as pore space"
    )
    thresholds: list[float] | None = Field(
        None, description="method thresholds: class k is t_{k-1} < g <= t_k"
    )
    bins: int = Field(256, ge=2, le=65536, description="histogram bins for float or 16-bit images")
    invert: bool = Field(
        False, description="phases are listed brightest first (pore BRIGHT, e.g. resin-filled SEM)"
    )

    @model_validator(mode="after")
    def _consistent(self):
        if len(self.phases) < 2 or len(set(self.phases)) != len(self.phases):
            raise ValueError(f"phases must name at least two distinct phases, got {self.phases}")
        unknown = sorted(set(self.pore_phases) - set(self.phases))
        if unknown or not self.pore_phases:
            raise ValueError(
                f"pore_phases {self.pore_phases} must be a non-empty subset of phases {self.phases}"
            )
        if self.method is Method.otsu and len(self.phases) != 2:
            raise ValueError(
                f"method otsu gives two phases, got {len(self.phases)}; use multi_otsu or thresholds"
            )
        if self.method is Method.thresholds:
            t = self.thresholds or []
            if len(t) != len(self.phases) - 1 or any(b <= a for a, b in itertools.pairwise(t)):
                raise ValueError(
                    f"method thresholds needs {len(self.phases) - 1} ascending thresholds, got {t}"
                )
        elif self.thresholds is not None:
            raise ValueError("`thresholds` is only used with method thresholds")
        return self


class Statistics(_Strict):
    """What ``statistics.h5`` contains beyond the always-computed fractions, Minkowski and percolation numbers."""

    max_lag_um: PosFloat | None = Field(
        None, description="largest lag of the two-point correlation (default: 1/4 box)"
    )
    grains: bool = Field(
        True, description="watershed grain segmentation: count, radii, elongation, orientation"
    )
    grain_min_distance_um: PosFloat | None = Field(
        None, description="smallest distance between two grain centres (watershed markers); default 2 voxels"
    )
    grain_max_voxels: int = Field(
        256**3,
        ge=0,
        description="grains are measured in a central sub-box of at most this many voxels (0: whole "
        "image); number density, radii and shapes are intensive, and the watershed is the costliest statistic",
    )
    grain_phase: str | None = Field(
        None, description="phase that forms the grains (default: all non-pore phases)"
    )
    lpt: bool = Field(
        False, description="run local porosity theory on the image (uses the scene's `lpt` section)"
    )
    permeability: bool = Field(
        False, description="run LBM on the image (uses the scene's `permeability` section)"
    )


class Family(str, enum.Enum):
    """Radius distribution families of the packer (packing.RadiusDist) the calibration may fit."""

    uniform = "uniform"
    exponential = "exponential"
    discrete = "discrete"


#: largest sigma_max the calibration's matching moves to unless the scene says otherwise (§5.6.2 packs at 0.35)
_DEFAULT_OVERLAP_LIMIT = 0.4


class Calibration(_Strict):
    """How statistics become a model scene (packing + decoration) that the user can edit and run."""

    families: list[Family] = Field(
        default_factory=lambda: [Family.uniform, Family.exponential, Family.discrete],
        description="candidate families; the best Kolmogorov-Smirnov fit wins",
    )
    discrete_bins: int = Field(12, ge=2, le=200, description="radius classes of the discrete family")
    max_overlap: float = Field(
        0.1,
        gt=0,
        le=1,
        description="sigma_max of the calibrated type (Table 8.3: 0.1), where matching starts and the least it "
        "uses: matching moves it up to max_overlap_limit to fit the image's S_V, and where the packing does not "
        "converge",
    )
    max_overlap_limit: float | None = Field(
        None,
        gt=0,
        le=1,
        description="largest sigma_max matching may move max_overlap to (default: 0.4, §5.6.2 packs at 0.35, or "
        "max_overlap where that is larger)",
    )
    box_um: tuple[PosFloat, PosFloat, PosFloat] | None = Field(
        None, description="model box (default: the image's)"
    )
    resolution_um: PosFloat | None = Field(None, description="model voxel size (default: the image's)")
    elongation_classes: int = Field(4, ge=1, le=32, description="elongation classes for the decoration")
    decoration: bool = Field(
        True,
        description="add a `decoration` section (random polyhedra, one family per "
        "elongation class, inscribed scaling) and decorate the model run; false: spheres",
    )
    steps: int = Field(400, ge=1, description="DEM step limit of the calibrated packing")
    porosity_iterations: int = Field(
        6,
        ge=0,
        le=10,
        description="pack-and-measure rounds (at most) that adjust the sphere count and max_overlap until the "
        "packing converges and its porosity and S_V are within the realisation scatter of the image's (0: neither "
        "is matched)",
    )

    @model_validator(mode="after")
    def _overlap_limit(self):
        if self.max_overlap_limit is not None and self.max_overlap_limit < self.max_overlap:
            raise ValueError(
                f"max_overlap_limit = {self.max_overlap_limit} is below max_overlap = {self.max_overlap}"
            )
        return self

    @property
    def overlap_limit(self) -> float:
        """The largest sigma_max matching may use: ``max_overlap_limit``, else 0.4 or ``max_overlap`` if larger."""
        if self.max_overlap_limit is not None:
            return self.max_overlap_limit
        return max(_DEFAULT_OVERLAP_LIMIT, self.max_overlap)


class Settings(_Strict):
    """The ``acquire`` section of a scene."""

    image: Path | None = Field(None, description="image file, directory of TIFF sections, or a glob of them")
    format: ImageFormat = Field(ImageFormat.auto, description="file format (auto: from the suffix)")
    raw: Raw | None = Field(None, description="dtype, shape, byte order and header of a RAW file")
    dataset: str | None = Field(None, description="dataset path inside an HDF5 file")
    voxel_um: PosFloat | None = Field(None, description="voxel edge in µm (overrides the file's metadata)")
    section_um: PosFloat | None = Field(
        None, description="spacing of serial sections (z) if it differs from voxel_um"
    )
    resample_cubic: bool = Field(
        True, description="resample anisotropic (serial-section) stacks to cubic voxels"
    )
    crop: Crop | None = Field(None, description="part of the image to use")
    denoise: Denoise = Field(Denoise.none, description="filter applied before segmentation")
    denoise_size: int = Field(3, ge=1, le=15, description="median filter width in voxels")
    segmentation: Segmentation = Field(default_factory=Segmentation, description="grey values -> phases")
    statistics: Statistics = Field(default_factory=Statistics, description="what to measure")
    calibration: Calibration = Field(default_factory=Calibration, description="statistics -> model scene")
    periodic: bool = Field(False, description="treat the image as periodic (images almost never are)")
