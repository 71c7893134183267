"""wgbragg demo: edit a teapot's Bragg layers or thin film live, rasterized and path-traced.

Run with ``make demo`` (which does all the set-up) or ``python demo.py``: a window shows the
teapot preset (two rough Bragg layers over a dark diffuse base, under a sky), rasterized in
real time while you drag or edit and path-traced progressively when the view rests, and a side
panel with sliders for each layer (Lambda, delta = d1 / Lambda, N, n2, alpha), the structure
(layer count, n1, the base's albedo rho_d), the colour method, RGB or spectral transport and
the environment; the selected layer's reflectance at normal incidence with its landmarks and
its colour against the angle; and the interactive budgets as measured. The material can be
switched to a rough thin film (thickness, or a noise map's range; n_film; a dielectric or
metal base; alpha), which ``--scene thin_film`` opens on. Drag the picture to orbit, scroll to
zoom; every edit restarts the accumulation.

``python demo.py --offscreen --spp 64 -o demo.png`` renders the same window without a display,
the picture path-traced, and prints the image's path (also what happens when no display is
found); with ``--denoise`` it also writes the window with the picture denoised (the panel's
toggle, same samples) beside it, as ``demo.denoised.png``. The window denoises full-size
frames of more than 4 spp by default (``--no-denoise`` starts with the toggle off).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from PIL import Image

from wgbragg.app.viewer import DENOISE_AFTER_SPP, HANDOVER_SPP, Viewer
from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.scene import MODES, PRESETS, load_preset, load_scene


def _size(text: str) -> tuple[int, int]:
    width, _, height = text.lower().partition("x")
    try:
        return int(width), int(height)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must be WIDTHxHEIGHT, got {text!r}") from None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--offscreen", action="store_true",
                        help="render the window without a display and write it as a PNG")
    parser.add_argument("--spp", type=int, default=64,
                        help="offscreen: samples per pixel (default 64)")
    parser.add_argument("-o", "--output", default="out/demo.png",
                        help="offscreen: the PNG to write (default out/demo.png)")
    parser.add_argument("--size", type=_size, default=(256, 256),
                        help="WIDTHxHEIGHT of the render in pixels (default 256x256); the "
                             "scene's whole frame stays in view at any aspect ratio")
    parser.add_argument("--scene", default="teapot",
                        help=f"a preset ({', '.join(PRESETS)}) or a scene file with a "
                             "layered-bragg or thin-film material (default teapot)")
    parser.add_argument("--allow-outside-paths", action="store_true",
                        help="let the scene file name files outside its folder (../x.obj, "
                             "absolute paths, symlinks to elsewhere); refused by default")
    parser.add_argument("--mode", choices=MODES, default=None,
                        help="light transport (default: the scene's)")
    parser.add_argument("--denoise", action=argparse.BooleanOptionalAction, default=None,
                        help="the window: start with the denoise toggle on (default) or off; "
                             "offscreen: also write the denoised picture as NAME.denoised.png "
                             f"(needs --spp >= {DENOISE_AFTER_SPP}; default off)")
    args = parser.parse_args(argv)
    offscreen = args.offscreen
    if not offscreen and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print("demo.py: no display (DISPLAY, WAYLAND_DISPLAY): rendering offscreen",
              file=sys.stderr)
        offscreen = True
    denoised_output = None
    try:
        if args.spp < 1:
            raise ValueError(f"--spp must be >= 1, got {args.spp}")
        if offscreen:
            check_output_path(args.output, "--output", ".png")
            if args.denoise:
                if args.spp < DENOISE_AFTER_SPP:
                    raise ValueError(f"--denoise needs --spp >= {DENOISE_AFTER_SPP} (fewer "
                                     f"samples are shown raw), got {args.spp}")
                output = Path(args.output)
                denoised_output = output.with_name(f"{output.stem}.denoised{output.suffix}")
                check_output_path(denoised_output, "--output (denoised)", ".png")
        scene = (load_preset(args.scene) if args.scene in PRESETS
                 else load_scene(args.scene, allow_outside=args.allow_outside_paths))
        # Offscreen, the first picture is the raw one; the denoised one follows.
        # Offscreen, the picture is the path tracer's from its first sample.
        viewer = Viewer(scene, size=args.size, mode=args.mode,
                        denoise=not offscreen and args.denoise is not False,
                        handover_spp=1 if offscreen else HANDOVER_SPP)
    except (ValueError, OSError) as error:
        parser.error(str(error))
    # Imported here: the window needs imgui and rendercanvas, the checks above do not.
    from wgbragg.app.viewer_window import ViewerWindow

    window = ViewerWindow(viewer, offscreen=offscreen)
    if not offscreen:
        window.run()
        return 0
    start = time.perf_counter()
    if args.spp > 2:
        viewer.refine(args.spp - 2)
    if args.spp > 1:
        window.draw()  # Dear ImGui places some widgets (the layer tabs) from its second frame
    frame = window.capture()  # each frame adds a sample
    seconds = time.perf_counter() - start
    frames = [(args.output, frame)]
    if denoised_output is not None:
        viewer.denoise = True
        frames.append((denoised_output, window.capture(sample=False)))
    window.close()
    for path, pixels in frames:
        with atomic_path(path) as temporary:
            Image.fromarray(pixels, "RGB").save(temporary, format="PNG")
    width, height = viewer.size
    denoised = (f", denoised in {viewer.budgets.denoise_ms / 1e3:.2f} s"
                if denoised_output is not None else "")
    print(f"demo.py: {width}x{height}, {viewer.passes} spp {viewer.source} in {seconds:.1f} s"
          f"{denoised}",
          file=sys.stderr)
    for path, _ in frames:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
