"""wgbragg demo: a Bragg mirror's reflectance map and a jewel beetle's scatterogram, on the GPU.

Run with ``make demo`` (which does all the set-up) or ``python demo.py [-o PATH]``. Writes a PNG
of R(wavelength, angle) for BraggMirror(n1=1.0, n2=1.5, d1=125, d2=375, N=20): band gaps are
the bright bands that move to shorter wavelengths as the angle grows. Beside it
(``*_scatterogram.png``), the reflected hemisphere of the jewel beetle's green cuticle (Table 3
of the Bragg paper) lit from 30 degrees, and (``*_teapot.png``) the teapot preset path-traced on
the GPU: two rough Bragg layers over a diffuse base. Later versions grow this into the
interactive window.
"""

from __future__ import annotations

import argparse
import math
import time

from pathlib import Path

from wgbragg import BraggMirror, gpu
from wgbragg.maps import reflectance_map, save_reflectance_map
from wgbragg.render import Renderer, save_png
from wgbragg.scatterogram import jewel_beetle, save_scatterogram, scatterogram
from wgbragg.scene import load_preset


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="out/demo.png")
    args = parser.parse_args()
    mirror = BraggMirror(n1=1.0, n2=1.5, d1=125.0, d2=375.0, N=20)
    mirror.reflectance(550.0, 0.0, backend="gpu")  # device and pipeline creation, not timed
    start = time.perf_counter()
    result = reflectance_map(mirror, backend="gpu")
    seconds = time.perf_counter() - start
    adapter = gpu.adapter_info()["name"]
    title = (f"{mirror!r}, unpolarized\n{result.values.size:,} evaluations on {adapter} "
             f"in {seconds * 1e3:.0f} ms (upload, kernel, readback)")
    save_reflectance_map(result, args.output, title)
    print(args.output)

    output = Path(args.output)
    beetle = output.with_name(f"{output.stem}_scatterogram{output.suffix}")
    start = time.perf_counter()
    hemisphere = scatterogram(jewel_beetle("green"), math.radians(30.0), size=160,
                              backend="gpu")
    seconds = time.perf_counter() - start
    save_scatterogram(hemisphere, beetle, f"jewel beetle, green area (Table 3), light at 30 deg"
                      f"\n160 x 160 on {adapter} in {seconds:.1f} s")
    print(beetle)

    teapot = output.with_name(f"{output.stem}_teapot{output.suffix}")
    scene = load_preset("teapot")
    renderer = Renderer(scene, size=(256, 256))
    image = renderer.render(64, progress=True)
    save_png(image, teapot, scene.settings.exposure)
    print(teapot)


if __name__ == "__main__":
    main()
