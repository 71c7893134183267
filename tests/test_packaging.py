"""The built wheel carries the WGSL sources and runs kernels from them, not from the tree."""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHADERS = sorted(p.relative_to(ROOT / "wgsl").as_posix() for p in (ROOT / "wgsl").rglob("*.wgsl"))


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(out), str(ROOT)],
        check=True,
    )
    (path,) = out.glob("wgbragg-*.whl")
    return path


def test_wheel_contains_every_shader(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = [s for s in SHADERS if f"wgbragg/wgsl/{s}" not in names]
    assert SHADERS and not missing


@pytest.mark.gpu
def test_installed_wheel_loads_shaders_and_runs_a_kernel(wheel, tmp_path):
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    script = (
        "import wgbragg, numpy as np\n"
        "from wgbragg import gpu\n"
        f"assert wgbragg.__file__.startswith({str(site)!r}), wgbragg.__file__\n"
        f"assert str(gpu.shader_dir()).startswith({str(site)!r}), gpu.shader_dir()\n"
        "m = wgbragg.BraggMirror(n1=1.0, n2=1.5, d1=125.0, d2=375.0, N=20)\n"
        "g = m.reflectance(np.linspace(400, 700, 64), 0.3, backend='gpu')\n"
        "r = m.reflectance(np.linspace(400, 700, 64), 0.3)\n"
        "assert np.abs(g - r).max() < 2e-3, np.abs(g - r).max()\n"
        "print('ok')\n"
    )
    # PYTHONPATH puts the extracted wheel before the editable install of the source tree.
    result = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True,
        env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path),
             "XDG_RUNTIME_DIR": str(tmp_path)},
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().endswith("ok")
