"""The scene: one YAML file that says what to build and what to measure.

``load_scene(path)`` validates the whole file and raises :class:`SceneError` listing *every* problem at once, each
naming the key, the bad value and what is allowed. Lengths are in micrometres throughout (keys end in ``_um``).
"""

from __future__ import annotations

import copy
import difflib
import enum
import math
import re
import reprlib
import typing
from pathlib import Path
from typing import Annotated, Any

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)

from porepipe._registry import OPTIONAL_SECTIONS, stage_settings
from porepipe._shared.budget import Resources, machine_bytes
from porepipe._shared.errors import PorepipeError
from porepipe._shared.naming import SCENE_NAME_RE
from porepipe._shared.yaml_safe import load_yaml
from porepipe.segment._settings import Segmentation, SegmentationMethod

__all__ = [
    "Analysis",
    "Domain",
    "Scene",
    "SceneError",
    "Segmentation",
    "SegmentationMethod",
    "Spheres",
    "grey_stage",
    "load_scene",
    "parse_scene",
    "scene_part",
]

#: the validation context of a scene file: a stage's settings may then refuse what a scene sets explicitly to no
#: effect (diffusion: a key its setup does not read; see porepipe.diffusion._settings.SCENE_CONTEXT)
_CONTEXT = {"scene_file": True}
#: relative tolerance when checking that a resolution divides the box
_DIVIDES_RTOL = 1e-9
#: longest scene name (it names the results folder, and Snakemake's lock and log paths carry it too)
_NAME_MOST = 100


class Analysis(str, enum.Enum):
    """Measurements a scene can ask for; only these enter the workflow DAG."""

    segment = "segment"  # binary pore/matrix volumes at every resolution
    estimate = "estimate"  # grey-value estimators of porosity and specific surface (§7.2, §7.3)
    minkowski = "minkowski"  # φ, S_V, K_V, T_V of the segmented volume
    lpt = "lpt"  # local porosity theory
    permeability = "permeability"  # lattice-Boltzmann permeability
    diffusion = "diffusion"  # gas in the pore space: Knudsen flights, event-driven gas, wall reactions
    acquire = "acquire"  # image statistics, calibrated model scene, model-vs-experiment comparison
    report = "report"  # resolution sweep, extrapolation and the accuracy-versus-cost report
    granular = "granular"  # 2-D frictional DEM of convex polygons (gc2d, Schinner 2001)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


PositiveUm = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class Domain(_Strict):
    """The box [0, size_um) in x, y, z."""

    size_um: tuple[PositiveUm, PositiveUm, PositiveUm] = Field(description="box edge lengths x, y, z in µm")
    periodic: bool = Field(True, description="spheres wrap across opposite faces")


class Spheres(_Strict):
    """Where the spheres (the matrix) come from; exactly one of the four keys."""

    pack: bool = Field(False, description="use the packing stage's output (needs a `packing:` section)")
    hdf5: Path | None = Field(
        None, description="packing.h5 written by `porepipe pack` (path relative to the scene)"
    )
    xyzr: Path | None = Field(
        None, description="text file, one sphere per line: x y z r in µm (PackDEM format)"
    )
    inline: list[tuple[float, float, float, float]] | None = Field(
        None, description="[[x, y, z, r], ...] in µm"
    )

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [k for k in ("hdf5", "xyzr", "inline") if getattr(self, k) is not None] + (
            ["pack"] if self.pack else []
        )
        if len(given) != 1:
            raise ValueError(f"give exactly one of pack: true, hdf5, xyzr, inline (got {given or 'none'})")
        return self

    @field_validator("inline")
    @classmethod
    def _radii_positive(cls, spheres):
        spheres = spheres or []
        not_finite = [i for i, sphere in enumerate(spheres) if not all(math.isfinite(v) for v in sphere)]
        not_positive = [i for i, sphere in enumerate(spheres) if i not in not_finite and sphere[3] <= 0]
        faults = []
        if not_finite:
            faults.append(f"sphere(s) {_index_list(not_finite)} have a non-finite value")
        if not_positive:
            shown = [f"{i} (radius {spheres[i][3]:g})" for i in not_positive]
            faults.append(f"sphere(s) {_index_list(shown)} have radius <= 0 (allowed: r > 0)")
        if faults:
            raise ValueError("; ".join(faults))
        return spheres or None


def _index_list(indices: list, most: int = 20) -> str:
    """``0, 3, 7``: every index, or the first ``most`` and how many more (the message stays one line)."""
    text = ", ".join(str(i) for i in indices[:most])
    return text + (f" and {len(indices) - most} more" if len(indices) > most else "")


class SceneBase(_Strict):
    name: str = Field(pattern=SCENE_NAME_RE, description="scene name = results folder")
    seed: int = Field(0, ge=0, strict=True, description="root of every random stream of the scene")
    domain: Domain | None = Field(None, description="the box; required unless the scene starts from an image")
    spheres: Spheres | None = Field(
        None, description="the matrix; required unless the scene starts from an image"
    )
    resolutions_um: list[PositiveUm] = Field(
        default_factory=list,
        min_length=1,
        description="voxel sizes a in µm, coarse to fine (none: 2-D granular)",
    )
    segmentation: Segmentation = Segmentation()
    analyses: list[Analysis] = Field(
        default_factory=lambda: [Analysis.estimate],
        min_length=1,
        description="what to measure (default: estimate); none would run nothing",
    )
    resources: Resources = Field(
        Resources(), description="what one stage may use: memory_budget_mb (volumes over it go in chunks)"
    )

    @model_validator(mode="after")
    def _model_source(self):
        if Analysis.granular in self.analyses and set(self.analyses) <= {Analysis.granular, Analysis.report}:
            return self  # a 2-D granular scene has no box, spheres or voxels (its report reads granular.h5)
        if not self.resolutions_um:
            raise ValueError(
                "missing resolutions_um: give at least one voxel size in µm (only a 2-D granular scene, analyses "
                "[granular] or [granular, report], needs none)"
            )
        if getattr(getattr(self, "diffusion", None), "geometry", None) is not None:
            other = sorted(a.value for a in set(self.analyses) - {Analysis.diffusion, Analysis.report})
            if other:  # a synthetic capillary (diffusion.geometry) has a binary volume only, no grey one
                raise ValueError(
                    f"diffusion.geometry: a synthetic capillary scene runs diffusion only, not {other}"
                )
            return self
        if getattr(self, "acquire", None) is None:
            missing = [k for k in ("domain", "spheres") if getattr(self, k) is None]
            if missing:
                raise ValueError(
                    f"missing {' and '.join(missing)}: a scene needs `domain` and `spheres` unless it "
                    "starts from an image (`acquire:` section)"
                )
        return self

    @field_validator("name")
    @classmethod
    def _name_snakemake_can_run(cls, name):
        if len(name) > _NAME_MOST:  # a file name (results/<name>/, the lock's paths) has at most 255 bytes
            raise ValueError(f"{len(name)} characters; allowed: at most {_NAME_MOST}")
        # Snakemake's PeriodicWildcardError (a 20-line traceback) takes 20 repeats at the end for an endless recursion
        repeated = re.search(r"(.+?)\1{19,}$", name)
        if repeated:
            raise ValueError(
                f"ends in {repeated.group(1)!r} repeated {len(repeated.group(0)) // len(repeated.group(1))} times, "
                "which Snakemake refuses as a wildcard value; allowed: fewer than 20 repeats at the end"
            )
        return name

    @field_validator("resolutions_um")
    @classmethod
    def _distinct(cls, values):
        if len(set(values)) != len(values):
            raise ValueError(f"resolutions must be distinct, got {values}")
        return values


def _scene_model() -> type[BaseModel]:
    fields: dict[str, Any] = {
        key: ((model | None, None) if key in OPTIONAL_SECTIONS else (model, model()))
        for key, model in stage_settings().items()
    }
    return create_model("Scene", __base__=SceneBase, **fields)


Scene = _scene_model()


class SceneError(PorepipeError):
    """A scene file with one or more problems; ``problems`` lists them, one line each."""

    def __init__(self, source: str, problems: list[str]):
        self.problems = problems
        super().__init__(f"{source}: {len(problems)} problem(s)\n" + "\n".join(f"  - {p}" for p in problems))


def _loc(loc: tuple) -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def _get(raw: dict, loc: tuple):
    value = raw
    for part in loc:
        try:
            value = value[part]
        except (KeyError, IndexError, TypeError):
            return "(missing)"
    return value


def _short_repr() -> reprlib.Repr:
    short = reprlib.Repr()  # keyword arguments to Repr() need Python 3.12
    short.maxstring = short.maxother = 60
    short.maxlist = short.maxtuple = 6
    short.maxdict, short.maxlevel = 4, 3
    return short


_SHORT = _short_repr()


def _short(value) -> str:
    """A repr of a scene value short enough for one error line, whatever the value holds."""
    return _SHORT.repr(value)


def _model_in(annotation) -> type[BaseModel] | None:
    """The pydantic model inside an annotation (``X``, ``X | None``, ``list[X]``, ``tuple[X, ...]``), if any."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _model_in(arg)
        if found is not None:
            return found
    return None


def _did_you_mean(loc: tuple) -> str:
    """``"; did you mean 'x'?"`` for an unknown key at ``loc`` close to a key the section allows, else ``""``."""
    model: type[BaseModel] | None = Scene
    for part in loc[:-1]:
        if isinstance(part, int):
            continue  # an item of a list: the same model
        field = model.model_fields.get(part) if model is not None else None
        model = _model_in(field.annotation) if field is not None else None
    if model is None or not isinstance(loc[-1], str):
        return ""
    close = difflib.get_close_matches(loc[-1], list(model.model_fields), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _pydantic_problems(raw: dict, err: ValidationError) -> list[str]:
    problems = []
    for e in err.errors():
        loc = tuple(p for p in e["loc"] if not (isinstance(p, str) and p.startswith("function-")))
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            msg = "unknown key (misspelt?)" + _did_you_mean(loc)
        elif e["type"] == "finite_number":
            msg = "NaN or inf; every setting must be a finite number"
        elif e["type"] in _SHAPE_WANTED:
            msg = f"{_SHAPE_WANTED[e['type']]}, not {_yaml_kind(_get(raw, loc))}"
        if not loc:  # a check across keys: the whole scene is no value to show
            problems.append(f"(top level): {msg[:300]}")
            continue
        problems.append(f"{_loc(loc)} = {_short(_get(raw, loc))}: {msg[:300]}")
    return problems


#: pydantic's error types for a value of the wrong YAML shape, in YAML's words ("instance of Box" named a class)
_SHAPE_WANTED = {
    "model_type": "should be a mapping of keys to values ({key: value, ...} or indented `key: value` lines)",
    "dict_type": "should be a mapping of keys to values ({key: value, ...} or indented `key: value` lines)",
    "list_type": "should be a list ([a, b, ...] or lines starting with `- `)",
    "tuple_type": "should be a list ([a, b, ...] or lines starting with `- `)",
}


def _yaml_kind(value) -> str:
    """What a YAML value is, in YAML's words."""
    if value is None:
        return "empty (null)"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "a list"
    return "a mapping" if isinstance(value, dict) else type(value).__name__


def _is_length(value) -> bool:
    return (
        isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0
    )


#: bytes per sphere the packing engine holds (positions, velocities, forces, radii, ids, cell and neighbour lists)
_PACK_BYTES_PER_SPHERE = 256


def _size_problems(raw: dict, size, res) -> list[str]:
    """Resolutions that do not divide the box, and volumes or packings that cannot fit in this machine's memory."""
    problems, memory = [], machine_bytes()
    for i, a in enumerate(res):
        if not _is_length(a):
            continue
        edges = [edge for edge in size if _is_length(edge)]
        bad = [
            f"{edge!r} ({edge / a:.6g} voxels)"
            for edge in edges
            if abs(edge / a - round(edge / a)) > _DIVIDES_RTOL * max(1.0, edge / a)
        ]
        if bad:
            problems.append(
                f"resolutions_um[{i}] = {a!r}: does not divide the box edge(s) {', '.join(bad)} of "
                "domain.size_um; allowed: a voxel size giving a whole number of voxels per edge"
            )
        voxels = math.prod(edge / a for edge in edges) if len(edges) == 3 else 0.0
        if voxels > memory and _get(raw, ("resources", "memory_budget_mb")) in (None, "(missing)"):
            problems.append(
                f"resolutions_um[{i}] = {a!r}: the volume would have {voxels:.3g} voxels "
                f"({voxels / 2**30:.3g} GiB at 1 byte each), more than this machine's "
                f"{memory / 2**30:.0f} GiB of memory; set resources.memory_budget_mb to process it in chunks"
            )
    types = _get(raw, ("packing", "types"))
    counts = [t.get("count") for t in types if isinstance(t, dict)] if isinstance(types, list) else []
    spheres = sum(c for c in counts if isinstance(c, (int, float)) and not isinstance(c, bool) and c > 0)
    if math.isfinite(spheres) and spheres * _PACK_BYTES_PER_SPHERE > memory:
        problems.append(
            f"packing.types[*].count = {spheres:.3g} spheres in all: the packing engine would need about "
            f"{spheres * _PACK_BYTES_PER_SPHERE / 2**30:.3g} GiB, more than this machine's "
            f"{memory / 2**30:.0f} GiB of memory"
        )
    return problems


def _cross_problems(raw: dict, base_dir: Path) -> list[str]:
    """Checks across keys, done on the raw dict so they are reported together with the field errors."""
    problems = []
    size = _get(raw, ("domain", "size_um"))
    res = raw.get("resolutions_um")
    if isinstance(size, (list, tuple)) and isinstance(res, list):
        problems += _size_problems(raw, size, res)
    spheres = raw.get("spheres")
    if isinstance(spheres, dict):
        for key in ("hdf5", "xyzr"):
            if isinstance(spheres.get(key), str) and not (base_dir / spheres[key]).is_file():
                problems.append(
                    f"spheres.{key} = {_short(spheres[key])}: file not found (looked in {base_dir})"
                )
        if spheres.get("pack") is True and "packing" not in raw:
            problems.append("spheres.pack = True: needs a `packing:` section that says how to pack")
    perm, sweep = raw.get("permeability"), raw.get("sweep")
    sub_samples = isinstance(sweep, dict) and sweep.get("sample_um")
    if isinstance(perm, dict) and perm.get("whole_volume") is False and not sub_samples:
        problems.append("permeability.whole_volume = false: needs sub-samples to run on (sweep.sample_um)")
    return problems + _analysis_problems(raw)


def _analysis_problems(raw: dict) -> list[str]:
    """What a listed analysis needs from the rest of the scene, which before only its workflow rule or job found out
    (a Snakemake traceback, or a failed job after the others had run), while ``porepipe validate`` said ok.
    """
    analyses = raw.get("analyses")
    listed = {a for a in analyses if isinstance(a, str)} if isinstance(analyses, list) else set()
    problems = []
    section = raw.get("granular")
    if "granular" in listed and (
        section is None
        or (
            isinstance(section, dict)
            and not any(section.get(k) for k in ("particles", "blocks", "drop_sources"))
        )
    ):
        problems.append(
            f"analyses = {_short(analyses)}: lists granular, but the `granular:` section has no particles, blocks "
            "or drop_sources (nothing to simulate)"
        )
    if "acquire" in listed and raw.get("acquire") is None and "domain" in raw and "spheres" in raw:
        problems.append(
            f"analyses = {_short(analyses)}: lists acquire, but the scene has no `acquire:` section (the image)"
        )
    res = raw.get("resolutions_um")
    for key in ("permeability", "diffusion"):
        chosen = _get(raw, (key, "resolutions_um"))
        if key not in listed or not (isinstance(chosen, list) and isinstance(res, list)):
            continue
        try:
            unknown = [a for a in chosen if a not in res]
        except TypeError:  # an unhashable or odd entry: the field check names it
            continue
        if unknown:
            problems.append(
                f"{key}.resolutions_um = {_short(chosen)}: {_short(unknown)} not among resolutions_um = "
                f"{_short(res)}; allowed: some of the scene's resolutions (empty: all)"
            )
    return problems


def _raw_path(raw, loc: tuple) -> tuple:
    """The part of an error location that names keys and indices of the raw scene (pydantic adds type tags)."""
    path, value = [], raw
    for part in loc:
        if (isinstance(value, dict) and part in value) or (
            isinstance(value, list) and isinstance(part, int) and 0 <= part < len(value)
        ):
            value = value[part]
        else:
            break
        path.append(part)
    return tuple(path)


def _without(raw, paths: list[tuple]):
    """A copy of ``raw`` with the mapping keys at ``paths`` (from :func:`_key_path`) removed."""
    pruned = copy.deepcopy(raw)
    for path in paths:
        parent = pruned
        for part in path[:-1]:
            try:
                parent = parent[part]
            except (KeyError, IndexError, TypeError):
                parent = None  # an enclosing key went already
                break
        if isinstance(parent, dict):
            parent.pop(path[-1], None)
    return pruned


def _key_path(raw, loc: tuple) -> tuple:
    """The mapping key a faulty value sits under (a bad list item or tuple entry: the list's own key)."""
    path = _raw_path(raw, loc)
    while path and not isinstance(path[-1], str):
        path = path[:-1]
    return path


def _checks_hidden_by(raw: dict, err: ValidationError) -> list[str]:
    """Problems pydantic skipped because of ``err``.

    The checks across keys of a model run only once all its fields are valid, so validate once more with every
    faulty key removed (its default in its place) and keep the new problems, except those at or below a removed key
    and those of a check that names a removed key (it would judge the default, not what the file says).
    """
    removed = {_key_path(raw, e["loc"]) for e in err.errors() if e["type"] != "missing"} - {()}
    if not removed:
        return []
    try:
        Scene.model_validate(_without(raw, sorted(removed, key=len)), context=_CONTEXT)
    except ValidationError as again:
        hidden = [e for e in again.errors() if not any(_about_removed(raw, e, p) for p in removed)]
        seen = set(_pydantic_problems(raw, err))
        return [problem for problem in _pydantic_problems(raw, _Errors(hidden)) if problem not in seen]
    return []


def _about_removed(raw, error: dict, path: tuple) -> bool:
    """Whether a second-pass error concerns the removed key ``path``: it lies below it, or names it from above or
    from a key beside it (``diffusion.gas``, set for another setup than a misspelt ``diffusion.setup``'s default).
    """
    loc = _raw_path(raw, error["loc"])
    if loc[: len(path)] == path:
        return True
    if path[: len(loc)] == loc and str(path[-1]) in error["msg"]:
        return True
    beside = len(path) > 1 and loc[: len(path) - 1] == path[:-1]  # inside one section, not the top level
    return beside and re.search(rf"\b{re.escape(str(path[-1]))}\b", error["msg"]) is not None


class _Errors:
    """A filtered list of pydantic errors with the ``errors()`` method :func:`_pydantic_problems` reads."""

    def __init__(self, errors: list):
        self._errors = errors

    def errors(self) -> list:
        return self._errors


def parse_scene(raw: Any, base_dir: Path | str = ".", source: str = "scene") -> BaseModel:
    """Validate a scene given as a dict; raise :class:`SceneError` with every problem found."""
    base_dir = Path(base_dir)
    if not isinstance(raw, dict):
        raise SceneError(source, [f"the scene must be a mapping of keys to values, got {type(raw).__name__}"])
    problems = _cross_problems(raw, base_dir)
    scene = None
    try:
        scene = Scene.model_validate(raw, context=_CONTEXT)
    except ValidationError as err:
        problems = _pydantic_problems(raw, err) + _checks_hidden_by(raw, err) + problems
    if problems:
        raise SceneError(source, problems)
    return _resolve_paths(scene, base_dir)


def _resolve_paths(scene, base_dir: Path):
    sph = scene.spheres
    if sph is None:
        return scene
    update = {
        k: (base_dir / getattr(sph, k)).resolve() for k in ("hdf5", "xyzr") if getattr(sph, k) is not None
    }
    return scene.model_copy(update={"spheres": sph.model_copy(update=update)}) if update else scene


def load_scene(path) -> BaseModel:
    """Read and validate a scene YAML file."""
    path = Path(path)
    if not path.is_file():
        raise SceneError(str(path), [f"scene file {path} does not exist"])
    try:
        raw = load_yaml(path)
    except PorepipeError as err:
        raise SceneError(str(path), [str(err)]) from None
    return parse_scene(raw, path.parent, str(path))


def grey_stage(scene) -> str:
    """The rule whose results folder holds the scene's grey volumes: decorated grains, or the spheres themselves."""
    return "voxelize_grains" if getattr(scene, "decoration", None) is not None else "voxelize"


def scene_part(scene, *keys: str) -> dict:
    """The JSON-able parts of the scene a result depends on (for its hash)."""
    dumped = scene.model_dump(mode="json")
    return {k: dumped.get(k) for k in keys}
