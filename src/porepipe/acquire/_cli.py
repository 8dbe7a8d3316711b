"""``porepipe acquire`` (image -> statistics.h5) and its follow-ups ``acquire-binary``, ``acquire-calibrate``,
``acquire-model`` and ``acquire-compare``. Argparse only; the work is in ``_run``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from porepipe._shared.errors import PorepipeError
from porepipe._shared.overrides import add_threads_option, merge_settings, scene_name

#: the RAW options of ``porepipe acquire`` -> keys of acquire.raw
_RAW_OPTIONS = {
    "raw_dtype": "dtype",
    "raw_shape": "shape",
    "raw_byte_order": "byte_order",
    "raw_header": "header_bytes",
    "raw_order": "order",
}

#: settings (dotted keys below acquire) -> (option of ``porepipe acquire``, its argparse name), for the messages:
#: every option laid over the settings but --no-grains (a switch, never invalid, and on by default)
_OPTION_OF = {
    "voxel_um": ("--voxel-um", "voxel_um"),
    "section_um": ("--section-um", "section_um"),
    "format": ("--format", "format"),
    "dataset": ("--dataset", "dataset"),
    **{f"raw.{key}": ("--" + opt.replace("_", "-"), opt) for opt, key in _RAW_OPTIONS.items()},
    "crop": ("--crop", "crop"),
    "crop.size": ("--crop", "crop"),
    "denoise": ("--denoise", "denoise"),
    **{
        f"segmentation.{k}": ("--" + k.replace("_", "-"), k)
        for k in ("method", "phases", "pore_phases", "thresholds")
    },
}


def _scene_sets(section, key: str) -> bool:
    """Whether the scene's ``acquire`` section sets ``key`` (dotted) itself (not by default)."""
    for part in key.split("."):
        if section is None or part not in section.model_fields_set:
            return False
        section = getattr(section, part)
    return True


def setting_names(args, scene):
    """How messages name the settings: by the option where the command line gave it, or where it named the image
    (IMAGE) and the scene does not set the key (the user is then on the command line); else by the scene key.
    """
    from porepipe.acquire._settings import SettingNames

    section = scene.acquire if scene is not None else None
    return SettingNames(
        {
            key: flag
            for key, (flag, dest) in _OPTION_OF.items()
            if getattr(args, dest) is not None or (args.image is not None and not _scene_sets(section, key))
        }
    )


def _scene(path):
    from porepipe.scene import load_scene

    return load_scene(path) if path else None


def settings_from_args(args, scene=None):
    """The scene's ``acquire`` section (or defaults) with the command-line options laid over it."""
    from porepipe.acquire._settings import Settings

    base = (
        scene.acquire.model_dump(exclude_none=True) if scene is not None and scene.acquire is not None else {}
    )
    over: dict = {
        k: getattr(args, k)
        for k in ("voxel_um", "section_um", "format", "dataset", "denoise")
        if getattr(args, k) is not None
    }
    # only the RAW options given: the scene's acquire.raw keeps the others (--raw-shape reset them to the defaults)
    raw = {key: getattr(args, opt) for opt, key in _RAW_OPTIONS.items() if getattr(args, opt) is not None}
    if raw:
        over["raw"] = raw
    if args.crop is not None:
        over["crop"] = {"size": args.crop, "centre": True}
    over["segmentation"] = {
        k: getattr(args, k)
        for k in ("method", "phases", "pore_phases", "thresholds")
        if getattr(args, k) is not None
    }
    if not args.grains:
        over["statistics"] = {"grains": False}
    given = {key: flag for key, (flag, dest) in _OPTION_OF.items() if getattr(args, dest) is not None}
    return merge_settings(Settings, base, over, "acquire settings", options=given)


def _check_format_options(args, scene, settings, base_dir, names) -> None:
    """Refuse --dataset for an image that is not HDF5 and the --raw-* options for one that is not RAW (a .npy image
    took them without a word), and --raw-* options without a shape (the file was then read as 1 x 1 x 1 voxels).
    """
    raw = ["--" + o.replace("_", "-") for o in _RAW_OPTIONS if getattr(args, o) is not None]
    if args.dataset is None and not raw:
        return
    from porepipe.acquire._api import image_file
    from porepipe.acquire._io import detect_format
    from porepipe.acquire._settings import ImageFormat

    path = image_file(settings, base_dir, args.image)
    fmt = detect_format(path, settings.format, names)
    given = [("--dataset", ImageFormat.hdf5)] if args.dataset is not None else []
    given += [(flag, ImageFormat.raw) for flag in raw]
    for flag, applies in given:
        if fmt is not applies:
            raise PorepipeError(
                f"{flag} applies to {applies.value} images, but {path} is read as {fmt.value}; leave "
                f"{flag} out (or give --format {applies.value} if the file is one)"
            )
    scene_raw = scene.acquire.raw if scene is not None and scene.acquire is not None else None
    if raw and args.raw_shape is None and scene_raw is None:
        raise PorepipeError(f"{raw[0]} needs the RAW image's shape: give --raw-shape NX NY NZ too")


def _main(args) -> int:
    from porepipe.acquire._run import run

    scene = _scene(args.scene)
    settings = settings_from_args(args, scene)
    base_dir = Path(args.scene).parent if args.scene else Path(".")
    names = setting_names(args, scene)
    _check_format_options(args, scene, settings, base_dir, names)
    tables = run(
        settings,
        args.out,
        scene=scene,
        image_path=args.image,
        base_dir=base_dir,
        threads=args.threads,
        names=names,
    )
    root = tables[None]
    print(
        f"porosity {float(root.porosity):.6g}, thresholds {root.threshold.values.tolist()}, "
        f"voxel {root.attrs['voxel_um']:g} µm -> {args.out}"
    )
    return 0


def _binary(args) -> int:
    from porepipe.acquire._run import run_binary

    phi = run_binary(args.statistics, args.out, args.a)
    print(f"porosity {phi:.6g} -> {args.out}")
    return 0


def _calibrate(args) -> int:
    from porepipe.acquire._run import run_calibrate

    out = run_calibrate(args.statistics, args.out, scene=_scene(args.scene), name=args.name)
    print(f"calibrated scene -> {out}")
    return 0


def _model(args) -> int:
    from porepipe.acquire._run import run_calibrated_model

    tables = run_calibrated_model(
        _scene(args.model_scene), args.model_scene, args.out, scene=_scene(args.scene), threads=args.threads
    )
    print(f"model porosity {float(tables[None].porosity):.6g} -> {args.out}")
    return 0


def _compare(args) -> int:
    from porepipe.acquire._compare import comparison_markdown
    from porepipe.acquire._run import run_compare

    print(comparison_markdown(run_compare(args.experiment, args.model, args.out)))
    return 0


def register(subparsers) -> None:
    """Add ``acquire`` and its follow-ups to the ``porepipe`` command."""
    p = subparsers.add_parser("acquire", help="statistics of a µ-CT/SEM image (statistics.h5)")
    p.add_argument(
        "image", nargs="?", default=None, help="image file, TIFF directory or glob (default: the scene's)"
    )
    p.add_argument("-o", "--out", required=True, help="output statistics.h5")
    p.add_argument("--scene", default=None, help="scene YAML whose `acquire` section holds the settings")
    p.add_argument(
        "--voxel-um", type=float, default=None, help="voxel edge in µm (required if not in the file)"
    )
    p.add_argument("--section-um", type=float, default=None, help="serial-section spacing along z in µm")
    p.add_argument("--format", choices=["auto", "tiff", "raw", "hdf5", "npy"], default=None)
    p.add_argument("--dataset", default=None, help="dataset inside an HDF5 file")
    p.add_argument(
        "--raw-dtype", default=None, help="RAW element type (uint8, uint16, float32, ...; default uint8)"
    )
    p.add_argument(
        "--raw-shape",
        type=int,
        nargs=3,
        default=None,
        metavar=("NX", "NY", "NZ"),
        help="RAW image: voxels along x, y, z",
    )
    p.add_argument(
        "--raw-byte-order",
        choices=["little", "big"],
        default=None,
        help="RAW image byte order (default little)",
    )
    p.add_argument("--raw-header", type=int, default=None, help="RAW header bytes to skip (default 0)")
    p.add_argument(
        "--raw-order",
        choices=["F", "C"],
        default=None,
        help="F (default): x fastest in the file; C: z fastest",
    )
    p.add_argument("--crop", type=int, nargs=3, default=None, metavar=("NX", "NY", "NZ"), help="central crop")
    p.add_argument("--denoise", choices=["none", "median", "nl_means"], default=None)
    p.add_argument(
        "--method",
        choices=["otsu", "multi_otsu", "thresholds"],
        default=None,
        help="how phases are separated",
    )
    p.add_argument("--phases", nargs="+", default=None, help="phase names, darkest first")
    p.add_argument("--pore-phases", nargs="+", default=None, help="the phases counted as pore space")
    p.add_argument(
        "--thresholds", type=float, nargs="+", default=None, help="grey thresholds (with --method thresholds)"
    )
    p.add_argument(
        "--grains",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="run the watershed grain analysis (--no-grains skips it)",
    )
    add_threads_option(p)
    p.set_defaults(func=_main)

    p = subparsers.add_parser(
        "acquire-binary", help="binary_a{a}.h5 of an acquired image (for minkowski/lpt/lbm)"
    )
    p.add_argument("statistics", help="statistics.h5 from `porepipe acquire`")
    p.add_argument(
        "--a",
        type=float,
        default=None,
        help="voxel size in µm: the image's (default) or a whole multiple of it (blocks of voxels, pore where "
        "less than half is matrix)",
    )
    p.add_argument("-o", "--out", required=True, help="output binary_a{a}.h5")
    p.set_defaults(func=_binary)

    p = subparsers.add_parser("acquire-calibrate", help="model scene YAML calibrated to image statistics")
    p.add_argument("statistics", help="statistics.h5 from `porepipe acquire`")
    p.add_argument("--scene", default=None, help="the image scene (its acquire.calibration settings)")
    p.add_argument(
        "--name", type=scene_name, default=None, help="name of the model scene (default: <scene>-model)"
    )
    p.add_argument("-o", "--out", required=True, help="output YAML")
    p.set_defaults(func=_calibrate)

    p = subparsers.add_parser("acquire-model", help="pack, voxelise and measure a calibrated model scene")
    p.add_argument("model_scene", help="calibrated scene YAML")
    p.add_argument("--scene", default=None, help="the image scene (which statistics to measure)")
    p.add_argument("-o", "--out", required=True, help="output model_statistics.h5")
    add_threads_option(p)
    p.set_defaults(func=_model)

    p = subparsers.add_parser("acquire-compare", help="model vs experiment (Tables 8.4/8.5, LPT overlays)")
    p.add_argument("experiment", help="statistics.h5 of the image")
    p.add_argument("model", help="model_statistics.h5")
    p.add_argument("-o", "--out", required=True, help="comparison.h5 (+ .png, .md beside it)")
    p.set_defaults(func=_compare)
