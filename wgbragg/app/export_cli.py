"""``wgbragg export`` (a scene as glTF 2.0 or MaterialX), the glTF options of ``wgbragg render``
(``--camera``, ``--environment``) and the ``--export`` of ``wgbragg fit`` / ``design``.

Like the other commands, it imports what it runs when it runs, so ``wgbragg --help`` stays fast.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from wgbragg.common.atomic import check_output_path

__all__ = ["EXPORT_SUFFIXES", "add_export_command", "add_gltf_options", "environment_option",
           "export_scene", "load_scene_argument", "write_structure"]

EXPORT_SUFFIXES = (".glb", ".gltf", ".mtlx")
"""What ``wgbragg export`` and ``--export`` write: glTF 2.0 (binary or JSON) or MaterialX."""

ENVIRONMENTS = ("uniform", "sky", "studio", "softbox-studio")


def environment_option(text: str | None):
    """``--environment``: ``uniform[:RADIANCE]``, ``sky[:INTENSITY]``, ``studio[:INTENSITY]`` or
    an ``.exr`` or ``.hdr`` file, as an :class:`~wgbragg.scene.model.Environment` (None for
    None)."""
    from wgbragg.scene.model import Environment

    if text is None:
        return None
    kind, _, amount = text.partition(":")
    if kind in ENVIRONMENTS:
        try:
            value = float(amount) if amount else 1.0
        except ValueError:
            value = -1.0
        if not (0.0 <= value <= 1e9):
            raise ValueError(f"--environment {text!r}: the amount after ':' must be a number in "
                             f"[0, 1e9]")
        if kind == "uniform":
            return Environment("uniform", radiance=(value,) * 3)
        return Environment(kind, intensity=value)
    path = Path(text)
    if path.suffix.lower() not in (".exr", ".hdr") or not path.is_file():
        raise ValueError(f"--environment must be one of {', '.join(ENVIRONMENTS)} (with "
                         f"':AMOUNT' optionally) or an existing .exr or .hdr file, got "
                         f"{text!r}")
    return Environment("exr", path=path.absolute())


def add_gltf_options(parser) -> None:
    """``--camera`` and ``--environment``, for glTF scene files."""
    parser.add_argument("--camera", default=None, metavar="NAME",
                        help="glTF files: the camera (or its node) of this name (default: the "
                             "first perspective camera)")
    parser.add_argument("--environment", default=None, metavar="ENV",
                        help="glTF files: uniform[:RADIANCE], sky[:INTENSITY], "
                             "studio[:INTENSITY], softbox-studio[:INTENSITY] or an .exr or .hdr "
                             "file (default: the file's "
                             "extras.wgbragg, else uniform:1)")


def load_scene_argument(args):
    """The scene of ``args.scene_file`` (TOML, ``.gltf`` or ``.glb``), with the glTF options;
    what a glTF file holds that is not rendered is printed as one warning line."""
    from wgbragg.scene import GltfWarning, load_scene
    from wgbragg.scene.gltf_io import GLTF_SUFFIXES

    options = {}
    if getattr(args, "camera", None) is not None:
        options["camera"] = args.camera
    environment = environment_option(getattr(args, "environment", None))
    if environment is not None:
        options["environment"] = environment
    if options and Path(args.scene_file).suffix.lower() not in GLTF_SUFFIXES:
        raise ValueError(f"{', '.join('--' + k for k in options)}: options of glTF scene "
                         f"files (.gltf, .glb), not of {args.scene_file}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GltfWarning)
        scene = load_scene(args.scene_file, allow_outside=args.allow_outside_paths, **options)
    for warning in caught:
        if issubclass(warning.category, GltfWarning):
            print(f"wgbragg: warning: {warning.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(warning.message, warning.category, warning.filename,
                                   warning.lineno)
    return scene


def export_scene(scene, path) -> list[str]:
    """Write ``scene`` to ``path`` by its suffix (:data:`EXPORT_SUFFIXES`); lines to print."""
    from wgbragg.scene import save_gltf, save_materialx

    path = Path(path)
    if path.suffix.lower() == ".mtlx":
        save_materialx(scene, path)
        return [str(path)]
    info = save_gltf(scene, path)
    lines = [str(path)]
    lines += [f"wgbragg: note: {note}" for note in info["notes"]]
    for name, fallback in info["fallbacks"].items():
        lines.append(f"{name}: Bragg material as WGBRAGG_materials_bragg; its fallback "
                     f"(KHR_materials_iridescence, {fallback.thickness_nm:.0f} nm, ior "
                     f"{fallback.ior:.3f}, over a metal) is off by dE2000 "
                     f"{fallback.delta_e_mean:.1f} on average ({fallback.delta_e_max:.1f} at "
                     f"most) over 0-80 degrees")
    return lines


def _check_suffix(flag: str, path) -> Path:
    suffix = Path(path).suffix.lower()
    if suffix not in EXPORT_SUFFIXES:
        raise ValueError(f"{flag} must end in {', '.join(EXPORT_SUFFIXES)}, got {str(path)!r}")
    return check_output_path(path, flag, suffix)


def run_export(args) -> int:
    """``wgbragg export``."""
    from wgbragg.scene import load_preset

    if (args.scene_file is None) == (args.scene is None):
        raise ValueError("give either a scene file or --scene NAME, not both or neither")
    _check_suffix("--output", args.output)
    scene = load_preset(args.scene) if args.scene else load_scene_argument(args)
    for line in export_scene(scene, args.output):
        print(line, file=sys.stderr if line.startswith("wgbragg:") else sys.stdout)
    return 0


def write_structure(structure, path, alpha: float) -> None:
    """``--export`` of ``fit`` and ``design``: the structure's scene (a sphere under a sky, as
    in the TOML they write) as glTF or MaterialX."""
    from wgbragg.design.files import scene_toml
    from wgbragg.scene import parse_scene

    scene = parse_scene(scene_toml(structure, alpha=alpha), Path.cwd(), origin="design")
    for line in export_scene(scene, path):
        print(line, file=sys.stderr if line.startswith("wgbragg:") else sys.stdout)


def check_export(path) -> None:
    """Check ``--export PATH`` before the search it follows."""
    if path is not None:
        _check_suffix("--export", path)


def add_export_command(commands, command) -> None:
    """Add ``export`` to the CLI's sub-commands; ``command`` is the CLI's parser maker."""
    export = command(commands, "export", "write a scene (TOML, glTF or a preset) as glTF 2.0 "
                                         "(.glb, .gltf: films as KHR_materials_iridescence, "
                                         "Bragg materials as WGBRAGG_materials_bragg with a "
                                         "fallback) or MaterialX (.mtlx, OpenPBR)")
    export.add_argument("scene_file", nargs="?", default=None,
                        help="a scene file: TOML, .gltf or .glb")
    export.add_argument("--scene", default=None, metavar="NAME", help="a built-in preset")
    export.add_argument("-o", "--output", required=True,
                        help="the file to write: .glb, .gltf or .mtlx")
    export.add_argument("--allow-outside-paths", action="store_true",
                        help="let the scene file name files outside its folder")
    add_gltf_options(export)
    export.set_defaults(run=run_export)
