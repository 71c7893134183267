"""Atomic writes: all or nothing, no temporary left behind, ordinary permissions."""

import os

import pytest

from wgbragg.common.atomic import (
    atomic_path,
    check_output_folder,
    check_output_path,
    write_text_atomic,
)


def test_replaces_whole_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "sub" / "table.md"
    write_text_atomic(path, "one\n")
    write_text_atomic(path, "two\n")
    assert path.read_text(encoding="utf-8") == "two\n"
    assert [p.name for p in path.parent.iterdir()] == ["table.md"]


def test_failure_keeps_the_old_file(tmp_path):
    path = tmp_path / "image.png"
    path.write_bytes(b"old")
    with pytest.raises(RuntimeError), atomic_path(path) as temporary:
        temporary.write_bytes(b"half")
        raise RuntimeError("writer crashed")
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["image.png"]


def test_temporary_keeps_the_suffix_and_result_is_readable_by_others(tmp_path):
    mask = os.umask(0o022)
    try:
        with atomic_path(tmp_path / "figure.png") as temporary:
            assert temporary.suffix == ".png"
            temporary.write_bytes(b"png")
    finally:
        os.umask(mask)
    assert (tmp_path / "figure.png").stat().st_mode & 0o777 == 0o644


@pytest.mark.parametrize("check", [
    lambda path: check_output_path(path / "image.png", "output", ".png"),
    lambda path: check_output_folder(path / "frames", "folder"),
])
def test_output_under_a_dangling_link_is_refused_before_work(tmp_path, check):
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "gone")
    with pytest.raises(ValueError, match="link to nothing"):
        check(link)


def test_output_under_new_folders_is_accepted(tmp_path):
    target = check_output_path(tmp_path / "a" / "b" / "image.png", "output", ".png")
    with atomic_path(target) as temporary:
        temporary.write_bytes(b"x")
    assert target.read_bytes() == b"x"
