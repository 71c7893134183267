"""The wheel built by ``python -m build`` carries every shipped WGSL source and none of the test
suite's kernels or benchmarks, and runs kernels from its own sources, not from the tree."""

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
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out),
         str(ROOT)],
        check=True, capture_output=True,
    )
    (path,) = out.glob("wgbragg-*.whl")
    return path


def test_wheel_contains_every_shader(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = [s for s in SHADERS if f"wgbragg/wgsl/{s}" not in names]
    assert SHADERS and not missing


def test_wheel_leaves_out_benchmarks_tests_and_tools(wheel):
    tops = {name.split("/")[0] for name in zipfile.ZipFile(wheel).namelist()}
    assert not tops & {"benchmarks", "tests", "tools"}, tops


def test_wheel_holds_no_test_kernels_tests_or_benchmarks(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    test_kernels = {p.name for p in (ROOT / "tests" / "kernels").glob("*.wgsl")}
    assert test_kernels
    shipped = {Path(n).name for n in names if n.endswith(".wgsl")}
    assert not test_kernels & shipped
    assert not [n for n in names if n.split("/")[0] in ("tests", "benchmarks", "tools")]
    assert not [n for n in names if "test" in Path(n).name]


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
