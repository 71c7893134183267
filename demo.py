"""wgbragg demo: the default Bragg mirror's reflectance map, computed by the GPU kernel.

Run with ``make demo`` (which does all the set-up) or ``python demo.py [-o PATH]``. Writes a PNG
of R(wavelength, angle) for BraggMirror(n1=1.0, n2=1.5, d1=125, d2=375, N=20): band gaps are
the bright bands that move to shorter wavelengths as the angle grows. Later versions grow this
into the interactive renderer.
"""

from __future__ import annotations

import argparse
import time

from wgbragg import BraggMirror, gpu
from wgbragg.maps import reflectance_map, save_reflectance_map


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


if __name__ == "__main__":
    main()
