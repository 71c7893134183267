"""Paths in scene files stay inside the scene's folder unless allowed, and messages show them as
written; image files that cannot be read are one-line errors naming them (issue 40, item 6)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wgbragg.app.cli import main
from wgbragg.common.exr import read_exr, write_exr
from wgbragg.render.packing import exr_environment
from wgbragg.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]

_BASE = """\
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[materials.grey]
type = "lambertian"
albedo = 0.5

[materials.blue]
type = "layered-bragg"
base_albedo = 0.5
[[materials.blue.layers]]
n1 = 1.0
n2 = 1.5
d1_nm = 250.0
d2_nm = 250.0
N = 10
alpha = 0.1
"""

_SPHERE = """
[[objects]]
shape = "sphere"
material = "grey"
"""

# Each kind of path a scene names: (suffix, key in messages, TOML naming PATH).
KINDS = {
    "mesh": (".obj", "objects[0].path",
             '[[objects]]\nshape = "mesh"\npath = PATH\nmaterial = "grey"\n'),
    "environment": (".exr", "environment.path",
                    '[environment]\ntype = "exr"\npath = PATH\n' + _SPHERE),
    "texture": (".png", "materials.blue.period_map.texture",
                '[materials.blue.period_map]\ntexture = PATH\nrange = [200.0, 300.0]\n'
                + _SPHERE),
}


def scene_file(folder: Path, kind: str, written: str) -> Path:
    """A scene in ``folder`` whose ``kind`` path is ``written`` (as the TOML writes it)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.toml"
    path.write_text(_BASE + "\n" + KINDS[kind][2].replace("PATH", json.dumps(written)),
                    encoding="utf-8")
    return path


def touch(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    # Existence is all loading checks: reading the files is the renderer's job.
    path.write_bytes(b"")
    return path


def refusal(path: Path, **kwargs) -> str:
    with pytest.raises(ValueError) as info:
        load_scene(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


def outside_cases(tmp_path: Path, kind: str):
    """(scene folder, path as written, the file it leads to) for each way out of the folder."""
    suffix = KINDS[kind][0]
    folder, elsewhere = tmp_path / "scene", tmp_path / "elsewhere"
    target = touch(elsewhere / f"target{suffix}")
    folder.mkdir()
    (folder / f"link{suffix}").symlink_to(target)
    (folder / "out").symlink_to(elsewhere, target_is_directory=True)
    return folder, target, [
        f"../elsewhere/target{suffix}",           # up and out
        str(target),                              # absolute, elsewhere
        f"link{suffix}",                          # a link inside, to a file outside
        f"out/target{suffix}",                    # through a linked folder
        f"sub/../../elsewhere/target{suffix}",    # down, then further up
    ]


# ----------------------------------------------------------------------------- refused, allowed


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_paths_outside_the_scene_folder_are_refused_naming_them_as_written(tmp_path, kind):
    folder, target, cases = outside_cases(tmp_path, kind)
    (folder / "sub").mkdir()
    key = KINDS[kind][1]
    for written in cases:
        message = refusal(scene_file(folder, kind, written))
        assert message.startswith(f"scene.toml: {key}: {json.dumps(written)} lies outside "
                                  f"the scene file's folder"), message
        assert "pass allow_outside=True (CLI: --allow-outside-paths) to allow it" in message
        if written != str(target):  # the absolute path is the target itself
            assert str(target) not in message, message
        assert "no such file" not in message


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_allow_outside_accepts_them_keeping_the_path_as_written(tmp_path, kind):
    folder, target, cases = outside_cases(tmp_path, kind)
    (folder / "sub").mkdir()
    for written in cases:
        scene = load_scene(scene_file(folder, kind, written), allow_outside=True)
        loaded = {
            "mesh": lambda s: s.objects[0].path,
            "environment": lambda s: s.environment.path,
            "texture": lambda s: s.materials["blue"].period_map.texture,
        }[kind](scene)
        # Absolute, anchored at the scene's folder, links not followed: later messages (the
        # renderer's) name the path as written.
        assert loaded == folder.resolve() / written
        assert loaded.resolve() == target.resolve()


def test_a_missing_file_outside_is_refused_as_outside_revealing_nothing(tmp_path):
    folder = tmp_path / "scene"
    touch(tmp_path / "there.obj")
    for written in ("../there.obj", "../absent.obj"):
        message = refusal(scene_file(folder, "mesh", written))
        assert f'objects[0].path: "{written}" lies outside' in message
    message = refusal(scene_file(folder, "mesh", "../absent.obj"), allow_outside=True)
    assert 'objects[0].path: no such file: "../absent.obj"' in message


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_paths_inside_are_accepted(tmp_path, kind):
    suffix = KINDS[kind][0]
    folder = tmp_path / "scene"
    inner = touch(folder / "sub" / "deeper" / f"file{suffix}")
    (folder / f"link{suffix}").symlink_to(inner)  # a link that stays inside
    for written in (f"sub/deeper/file{suffix}", f"./sub/deeper/../deeper/file{suffix}",
                    f"link{suffix}", str(inner)):
        load_scene(scene_file(folder, kind, written))


def test_a_scene_reached_through_a_linked_folder_reads_its_own_files(tmp_path):
    real = tmp_path / "real"
    touch(real / "meshes" / "m.obj")
    path = scene_file(real, "mesh", "meshes/m.obj")
    (tmp_path / "alias").symlink_to(real, target_is_directory=True)
    loaded = load_scene(tmp_path / "alias" / path.name)
    assert loaded.objects[0].path == real.resolve() / "meshes" / "m.obj"


def test_missing_files_are_named_as_written_not_where_a_link_leads(tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "dangling.obj").symlink_to(folder / "gone-target.obj")
    message = refusal(scene_file(folder, "mesh", "dangling.obj"))
    assert 'objects[0].path: no such file: "dangling.obj" (paths resolve against the scene ' \
           "file's folder" in message
    assert "gone-target" not in message
    message = refusal(scene_file(folder, "mesh", "sub/missing.obj"))
    assert 'no such file: "sub/missing.obj"' in message


def test_a_symlink_loop_is_refused_naming_the_path(tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "a.obj").symlink_to(folder / "b.obj")
    (folder / "b.obj").symlink_to(folder / "a.obj")
    message = refusal(scene_file(folder, "mesh", "a.obj"))
    assert message.startswith('scene.toml: objects[0].path: cannot be resolved: "a.obj"')


def test_renderer_messages_name_the_environment_as_written(tmp_path):
    """A link allowed outside, to a broken EXR: the renderer's error names the link."""
    folder = tmp_path / "scene"
    broken = tmp_path / "elsewhere" / "secret-target.exr"
    broken.parent.mkdir()
    broken.write_bytes(b"not an image")
    folder.mkdir()
    (folder / "sky.exr").symlink_to(broken)
    scene = load_scene(scene_file(folder, "environment", "sky.exr"), allow_outside=True)
    with pytest.raises(ValueError) as info:
        exr_environment(scene.environment)
    message = str(info.value)
    assert f"{folder.resolve() / 'sky.exr'}: not a readable OpenEXR file" in message
    assert "secret-target" not in message and "\n" not in message


# -------------------------------------------------------------------------------- read_exr


@pytest.mark.parametrize(
    ("make", "reason"),
    [
        (lambda p: None, "cannot be read: No such file or directory"),
        (lambda p: p.mkdir(), "is a folder, not an OpenEXR file"),
        (lambda p: p.write_bytes(bytes(range(256)) * 4), "not a readable OpenEXR file"),
        (lambda p: p.write_bytes(b""), "not a readable OpenEXR file"),
    ],
    ids=["missing", "folder", "garbage", "empty"],
)
def test_read_exr_failures_are_one_line_value_errors_naming_the_file(tmp_path, make, reason):
    path = tmp_path / "dir" / "sky.exr"
    path.parent.mkdir()
    make(path)
    for given in (path, str(path)):
        with pytest.raises(ValueError) as info:
            read_exr(given)
        message = str(info.value)
        assert message.startswith(f"{path}: {reason}"), message
        assert "\n" not in message


def test_read_exr_refuses_a_pipe_without_waiting_for_a_writer(tmp_path):
    path = tmp_path / "sky.exr"
    os.mkfifo(path)
    # Opening a pipe to read waits for a writer: without the check, this one comes (from
    # another process, as the OpenEXR binding may hold the GIL), so the test fails, not hangs.
    writer = subprocess.Popen([sys.executable, "-c", (
        "import os, sys, time\n"
        "while True:\n"
        "    time.sleep(0.5)\n"
        "    try: os.close(os.open(sys.argv[1], os.O_WRONLY | os.O_NONBLOCK))\n"
        "    except OSError: pass\n"), str(path)])
    try:
        with pytest.raises(ValueError) as info:
            read_exr(path)
    finally:
        writer.kill()
        writer.wait()
    assert str(info.value) == f"{path}: is a device, pipe or socket, not an OpenEXR file"


def test_read_exr_of_a_missing_parent_names_the_file(tmp_path):
    path = tmp_path / "no" / "such" / "sky.exr"
    with pytest.raises(ValueError, match=r"sky\.exr: cannot be read: No such file"):
        read_exr(path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files without read permission")
def test_read_exr_of_an_unreadable_file_names_it(tmp_path):
    path = tmp_path / "sky.exr"
    write_exr(path, np.ones((2, 4, 3)))
    path.chmod(0)
    with pytest.raises(ValueError, match=r"sky\.exr: cannot be read: Permission denied"):
        read_exr(path)


# -------------------------------------------------------------------------------- front ends


def _render_argv(scene: Path, tmp_path: Path, *extra: str) -> list[str]:
    return ["render", str(scene), "--size", "8x8", "--spp", "1", "--no-progress",
            "-o", str(tmp_path / "out" / "render.png"), *extra]


def _outside_environment_scene(tmp_path: Path) -> Path:
    sky = tmp_path / "maps" / "sky.exr"
    sky.parent.mkdir()
    write_exr(sky, np.full((4, 8, 3), 0.5))
    return scene_file(tmp_path / "scene", "environment", "../maps/sky.exr")


def test_cli_refuses_a_path_outside_in_one_line(tmp_path, capsys, monkeypatch):
    from wgbragg.render import renderer as render

    def forbidden(*args, **kwargs):
        raise AssertionError("the render started for a refused scene")

    monkeypatch.setattr(render.Renderer, "__init__", forbidden)
    scene = _outside_environment_scene(tmp_path)
    assert main(_render_argv(scene, tmp_path)) == 2
    error = capsys.readouterr().err
    assert error == ('wgbragg: error: scene.toml: environment.path: "../maps/sky.exr" lies '
                     "outside the scene file's folder (symlinks resolved); pass "
                     "allow_outside=True (CLI: --allow-outside-paths) to allow it\n"), error
    assert not (tmp_path / "out").exists()


@pytest.mark.gpu
def test_cli_renders_a_path_outside_with_the_flag(tmp_path, capsys):
    scene = _outside_environment_scene(tmp_path)
    assert main(_render_argv(scene, tmp_path, "--allow-outside-paths")) == 0, \
        capsys.readouterr().err
    assert (tmp_path / "out" / "render.png").is_file()


@pytest.mark.gpu
def test_cli_reports_a_broken_environment_in_one_line_naming_it(tmp_path, capsys):
    scene = scene_file(tmp_path / "scene", "environment", "sky.exr")
    (tmp_path / "scene" / "sky.exr").write_bytes(b"not an image")
    assert main(_render_argv(scene, tmp_path)) == 2
    error = capsys.readouterr().err
    assert error.startswith("wgbragg: error: ") and error.count("\n") == 1, error
    assert f"{(tmp_path / 'scene').resolve() / 'sky.exr'}: not a readable OpenEXR file" in error


def test_demo_refuses_a_path_outside_unless_allowed(tmp_path):
    scene = _outside_environment_scene(tmp_path)
    result = subprocess.run(
        [sys.executable, str(ROOT / "demo.py"), "--offscreen", "--scene", str(scene)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )
    assert result.returncode == 2, result.stderr
    assert ('"../maps/sky.exr" lies outside the scene file\'s folder' in result.stderr
            and "--allow-outside-paths" in result.stderr), result.stderr
    assert "--allow-outside-paths" in subprocess.run(
        [sys.executable, str(ROOT / "demo.py"), "--help"],
        capture_output=True, text=True, timeout=300, check=True,
    ).stdout
