"""``porepipe acquire`` (image -> statistics.h5) and its follow-ups ``acquire-binary``, ``acquire-calibrate``,
``acquire-model`` and ``acquire-compare``."""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError

from porepipe._shared.errors import PorepipeError
from porepipe._shared.numba_config import set_threads
from porepipe._shared.store import hash_of
from porepipe.acquire._settings import Settings


def _scene(path):
    from porepipe.scene import load_scene

    return load_scene(path) if path else None


def settings_from_args(args, scene=None) -> Settings:
    """The scene's ``acquire`` section (or defaults) with the command-line options laid over it."""
    base = scene.acquire.model_dump(exclude_none=True) if scene is not None and scene.acquire is not None else {}
    over: dict = {}
    if args.voxel_um is not None:
        over["voxel_um"] = args.voxel_um
    if args.section_um is not None:
        over["section_um"] = args.section_um
    if args.format is not None:
        over["format"] = args.format
    if args.dataset is not None:
        over["dataset"] = args.dataset
    if args.raw_shape is not None:
        over["raw"] = {"dtype": args.raw_dtype, "shape": args.raw_shape, "byte_order": args.raw_byte_order,
                       "header_bytes": args.raw_header, "order": args.raw_order}
    if args.crop is not None:
        over["crop"] = {"size": args.crop, "centre": True}
    if args.denoise is not None:
        over["denoise"] = args.denoise
    seg = dict(base.get("segmentation", {}))
    for key in ("method", "phases", "pore_phases", "thresholds"):
        if getattr(args, key) is not None:
            seg[key] = getattr(args, key)
    stats = dict(base.get("statistics", {}))
    if args.no_grains:
        stats["grains"] = False
    try:
        return Settings.model_validate({**base, **over, "segmentation": seg, "statistics": stats})
    except ValidationError as err:
        raise PorepipeError(f"acquire settings: {err}") from None


def _main(args) -> int:
    from porepipe.acquire._api import acquire

    set_threads(args.threads)
    scene = _scene(args.scene)
    settings = settings_from_args(args, scene)
    base_dir = Path(args.scene).parent if args.scene else Path(".")
    tables = acquire(settings, args.out, base_dir=base_dir, image_path=args.image,
                     scene_name=scene.name if scene else "",
                     scene_hash=hash_of(settings.model_dump(mode="json")),
                     lpt_settings=getattr(scene, "lpt", None), permeability_settings=getattr(scene, "permeability", None))
    root = tables[None]
    print(f"porosity {float(root.porosity):.6g}, thresholds {root.threshold.values.tolist()}, "
          f"voxel {root.attrs['voxel_um']:g} µm -> {args.out}")
    return 0


def _binary(args) -> int:
    from porepipe.acquire._api import write_binary

    phi = write_binary(args.statistics, args.out, args.a)
    print(f"porosity {phi:.6g} -> {args.out}")
    return 0


def _calibrate(args) -> int:
    from porepipe._shared.store import read_table
    from porepipe.acquire._calibrate import calibrated_scene, write_scene_yaml
    from porepipe.acquire._model import match_porosity

    scene = _scene(args.scene)
    settings = scene.acquire if scene is not None and scene.acquire is not None else Settings()
    name = args.name or (f"{scene.name}-model" if scene else "calibrated-model")
    model = calibrated_scene(read_table(args.statistics), settings.calibration, name=name,
                             seed=scene.seed if scene else 0)
    history = match_porosity(model, model["_calibration"]["target_porosity"],
                             settings.calibration.porosity_iterations, Path(args.out).parent)
    model["_calibration"]["porosity_matching"] = [{"count": n, "porosity": phi} for n, phi in history]
    write_scene_yaml(model, args.out)
    print(f"calibrated scene {name!r} -> {args.out}")
    return 0


def _model(args) -> int:
    from porepipe.acquire._model import run_model

    set_threads(args.threads)
    model = _scene(args.model_scene)
    scene = _scene(args.scene)
    settings = scene.acquire if scene is not None and scene.acquire is not None else Settings()
    tables = run_model(model, settings, args.out, base_dir=Path(args.model_scene).parent,
                       lpt_settings=getattr(scene, "lpt", None),
                       permeability_settings=getattr(scene, "permeability", None))
    print(f"model porosity {float(tables[None].porosity):.6g} -> {args.out}")
    return 0


def _compare(args) -> int:
    from porepipe.acquire._compare import comparison_markdown, write_comparison

    ds = write_comparison(args.experiment, args.model, args.out)
    print(comparison_markdown(ds))
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("acquire", help="statistics of a µ-CT/SEM image (statistics.h5)")
    p.add_argument("image", nargs="?", default=None, help="image file, TIFF directory or glob (default: the scene's)")
    p.add_argument("-o", "--out", required=True, help="output statistics.h5")
    p.add_argument("--scene", default=None, help="scene YAML whose `acquire` section holds the settings")
    p.add_argument("--voxel-um", type=float, default=None, help="voxel edge in µm (required if not in the file)")
    p.add_argument("--section-um", type=float, default=None, help="serial-section spacing along z in µm")
    p.add_argument("--format", choices=["auto", "tiff", "raw", "hdf5", "npy"], default=None)
    p.add_argument("--dataset", default=None, help="dataset inside an HDF5 file")
    p.add_argument("--raw-dtype", default="uint8", help="RAW element type (uint8, uint16, float32, ...)")
    p.add_argument("--raw-shape", type=int, nargs=3, default=None, metavar=("NX", "NY", "NZ"))
    p.add_argument("--raw-byte-order", choices=["little", "big"], default="little")
    p.add_argument("--raw-header", type=int, default=0, help="RAW header bytes to skip")
    p.add_argument("--raw-order", choices=["F", "C"], default="F", help="F: x fastest in the file")
    p.add_argument("--crop", type=int, nargs=3, default=None, metavar=("NX", "NY", "NZ"), help="central crop")
    p.add_argument("--denoise", choices=["none", "median", "nl_means"], default=None)
    p.add_argument("--method", choices=["otsu", "multi_otsu", "thresholds"], default=None)
    p.add_argument("--phases", nargs="+", default=None, help="phase names, darkest first")
    p.add_argument("--pore-phases", nargs="+", default=None)
    p.add_argument("--thresholds", type=float, nargs="+", default=None)
    p.add_argument("--no-grains", action="store_true", help="skip the watershed grain analysis")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=_main)

    p = subparsers.add_parser("acquire-binary", help="binary_a{a}.h5 of an acquired image (for minkowski/lpt/lbm)")
    p.add_argument("statistics", help="statistics.h5 from `porepipe acquire`")
    p.add_argument("--a", type=float, default=None, help="resolution asked for (must be the image's voxel size)")
    p.add_argument("-o", "--out", required=True)
    p.set_defaults(func=_binary)

    p = subparsers.add_parser("acquire-calibrate", help="model scene YAML calibrated to image statistics")
    p.add_argument("statistics")
    p.add_argument("--scene", default=None, help="the image scene (its acquire.calibration settings)")
    p.add_argument("--name", default=None, help="name of the model scene (default: <scene>-model)")
    p.add_argument("-o", "--out", required=True, help="output YAML")
    p.set_defaults(func=_calibrate)

    p = subparsers.add_parser("acquire-model", help="pack, voxelise and measure a calibrated model scene")
    p.add_argument("model_scene", help="calibrated scene YAML")
    p.add_argument("--scene", default=None, help="the image scene (which statistics to measure)")
    p.add_argument("-o", "--out", required=True, help="output model_statistics.h5")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=_model)

    p = subparsers.add_parser("acquire-compare", help="model vs experiment (Tables 8.4/8.5, LPT overlays)")
    p.add_argument("experiment", help="statistics.h5 of the image")
    p.add_argument("model", help="model_statistics.h5")
    p.add_argument("-o", "--out", required=True, help="comparison.h5 (+ .png, .md beside it)")
    p.set_defaults(func=_compare)
