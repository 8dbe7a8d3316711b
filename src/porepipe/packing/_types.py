"""The data of the packing engine: the finished :class:`Packing`, the resumable :class:`State`, history columns.

Its own module so that the engine (``_api``), the placement (``_setup``) and the files (``_io``) all import it and
none of them imports another late.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from porepipe.packing._settings import Effect

#: bit of each effect in the per-step ``effects`` history column
EFFECT_BITS = {e: 1 << i for i, e in enumerate(Effect)}
HISTORY_KEYS = (
    "stage",
    "step",
    "n_spheres",
    "converged",
    "max_overlap",
    "mean_overlap",
    "kinetic_energy",
    "max_displacement_um",
    "effects",
    "rebuilt",
    "wall_s",
)
#: history columns that describe the machine, not the packing (they differ between identical runs)
HISTORY_TIMING = ("wall_s",)
#: history columns stored as integers
_HISTORY_INT = {"stage", "step", "n_spheres", "converged", "effects", "rebuilt"}


@dataclasses.dataclass
class Packing:
    """A sphere packing and how it was made.

    Attributes
    ----------
    centres_um : (N, 3) float64
    radii_um : (N,) float64
    types : (N,) int32
        Index into ``type_names``.
    max_overlap : (N,) float64
        max_j sigma_ij at the final configuration (-inf: no partner in reach).
    converged : (N,) uint8
        0 < max_overlap <= sigma_max of the sphere's type.
    """

    centres_um: np.ndarray
    radii_um: np.ndarray
    types: np.ndarray
    max_overlap: np.ndarray
    converged: np.ndarray
    type_names: list[str]
    box_um: np.ndarray
    periodic: np.ndarray
    history: dict[str, np.ndarray]
    stage_converged: list[bool]
    stage_steps: list[int]
    snapshots: list[dict]
    #: (wall s, CPU s) that earlier processes of a resumed run spent up to its checkpoint (NaN: not recorded there)
    carried: tuple[float, float] = (0.0, 0.0)

    @property
    def all_converged(self) -> bool:
        return bool(self.stage_converged) and self.stage_converged[-1]


@dataclasses.dataclass
class State:
    """Everything a run needs to continue bit-identically (what a checkpoint stores)."""

    x: np.ndarray
    v: np.ndarray
    f: np.ndarray
    r: np.ndarray
    types: np.ndarray
    frozen: np.ndarray
    x_build: np.ndarray
    r_build: np.ndarray
    # insertion number of each sphere; the arrays are kept in slab-tiled cell order for memory locality
    ids: np.ndarray
    next_id: int
    since_build: int
    stage: int  # index of the stage in progress
    step: int  # last completed stage-local step (0: stage not started, spheres not inserted)
    nconv_prev: int
    need_rebuild: bool
    history: dict[str, list]
    stage_converged: list[bool]
    stage_steps: list[int]
    snapshots: list[dict]
    #: (wall s, CPU s) spent up to the checkpoint this state was read from, earlier processes included
    carried: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def empty(cls) -> State:
        z3 = np.zeros((0, 3))
        return cls(
            x=z3,
            v=z3.copy(),
            f=z3.copy(),
            r=np.zeros(0),
            types=np.zeros(0, dtype=np.int64),
            frozen=np.zeros(0, dtype=np.uint8),
            x_build=z3.copy(),
            r_build=np.zeros(0),
            ids=np.zeros(0, dtype=np.int64),
            next_id=0,
            since_build=0,
            stage=0,
            step=0,
            nconv_prev=0,
            need_rebuild=True,
            history={k: [] for k in HISTORY_KEYS},
            stage_converged=[],
            stage_steps=[],
            snapshots=[],
        )
