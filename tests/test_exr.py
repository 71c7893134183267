"""OpenEXR input and output: exact float32 round trips, the channel layouts accepted, refusals
naming the file or parameter, and atomic writes."""

from __future__ import annotations

import numpy as np
import OpenEXR
import pytest

from wgbragg.common.exr import read_exr, write_exr


def write_channels(path, channels):
    """An EXR file with exactly these channels, written by OpenEXR itself."""
    # The binding reads the buffer as if C-contiguous, whatever the strides.
    channels = {name: np.ascontiguousarray(plane) for name, plane in channels.items()}
    # A new header each time: OpenEXR.File fills in the one it is given (its data window).
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as exr:
        exr.write(str(path))


def radiance(shape=(5, 7), seed=0, decades=6.0):
    rng = np.random.default_rng(seed)
    # Decades of dynamic range, as in a sky with the sun, plus exact zeros.
    image = 10.0 ** rng.uniform(-decades, decades, (*shape, 3))
    image[0, 0] = 0.0
    return image.astype(np.float32)


def test_float32_round_trip_is_exact(tmp_path):
    image = radiance()
    image[1, 1] = [-1.5, 3.0e38, 1e-40]  # negative, near the float32 maximum, subnormal
    write_exr(tmp_path / "sky.exr", image)
    back = read_exr(tmp_path / "sky.exr")
    assert back.dtype == np.float32
    assert back.shape == image.shape
    np.testing.assert_array_equal(back, image)


def test_float64_input_is_stored_as_float32(tmp_path):
    image = radiance().astype(np.float64) * (1.0 + 1e-12)
    write_exr(tmp_path / "sky.exr", image)
    np.testing.assert_array_equal(read_exr(tmp_path / "sky.exr"), image.astype(np.float32))


def test_rows_and_channels_keep_their_order(tmp_path):
    image = np.zeros((2, 3, 3), np.float32)
    image[0, :, 0] = 1.0  # top row red
    image[:, 2, 2] = 2.0  # right column blue
    write_exr(tmp_path / "order.exr", image)
    with OpenEXR.File(str(tmp_path / "order.exr"), separate_channels=True) as exr:
        channels = exr.channels()
        np.testing.assert_array_equal(channels["R"].pixels, image[..., 0])
        np.testing.assert_array_equal(channels["B"].pixels, image[..., 2])


def test_reads_half_channels(tmp_path):
    image = radiance(decades=4.0).astype(np.float16)  # half tops out at 65504
    write_channels(tmp_path / "half.exr", {"RGB": image})
    back = read_exr(tmp_path / "half.exr")
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, image.astype(np.float32))


def test_reads_rgb_among_other_channels(tmp_path):
    image = radiance()
    alpha = np.full(image.shape[:2], 0.5, np.float32)
    write_channels(
        tmp_path / "rgba.exr",
        {"R": image[..., 0], "G": image[..., 1], "B": image[..., 2], "A": alpha, "Z": alpha},
    )
    np.testing.assert_array_equal(read_exr(tmp_path / "rgba.exr"), image)


def test_replicates_a_luminance_channel(tmp_path):
    y = radiance()[..., 0]
    write_channels(tmp_path / "grey.exr", {"Y": y})
    np.testing.assert_array_equal(read_exr(tmp_path / "grey.exr"), np.stack([y, y, y], axis=-1))


def test_accepts_path_strings(tmp_path):
    write_exr(str(tmp_path / "sky.exr"), radiance())
    np.testing.assert_array_equal(read_exr(str(tmp_path / "sky.exr")), radiance())


def test_missing_file(tmp_path):
    # A ValueError naming the file (the CLI prints it on one line): more in test_scene_paths.py.
    with pytest.raises(ValueError, match=r"absent\.exr: cannot be read: No such file"):
        read_exr(tmp_path / "absent.exr")


def test_refuses_a_file_that_is_not_exr(tmp_path):
    path = tmp_path / "text.exr"
    path.write_text("not an image")
    with pytest.raises(ValueError, match=r"text\.exr: not a readable OpenEXR file"):
        read_exr(path)


def test_refuses_a_truncated_file_naming_it(tmp_path):
    whole = tmp_path / "whole.exr"
    write_exr(whole, np.ones((8, 8, 3)))
    cut = tmp_path / "cut.exr"
    cut.write_bytes(whole.read_bytes()[:40])
    with pytest.raises(ValueError, match=r"cut\.exr: not a readable OpenEXR file"):
        read_exr(cut)


def test_write_refuses_other_suffixes_and_folders(tmp_path):
    with pytest.raises(ValueError, match=r"path must end in \.exr"):
        write_exr(tmp_path / "image.png", np.ones((2, 2, 3)))
    folder = tmp_path / "folder.exr"
    folder.mkdir()
    with pytest.raises(ValueError, match="path is a folder"):
        write_exr(folder, np.ones((2, 2, 3)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder.exr"]


@pytest.mark.parametrize(
    ("channels", "match"),
    [
        ({"Z": np.ones((2, 2), np.float32)}, r"depth\.exr: needs R, G and B .* found \['Z'\]"),
        (
            {"R": np.ones((2, 2), np.float32), "G": np.ones((2, 2), np.float32)},
            r"depth\.exr: .*found \['G', 'R'\]",
        ),
        (
            {
                "Y": np.ones((2, 2), np.float32),
                "RY": np.ones((2, 2), np.float32),
                "BY": np.ones((2, 2), np.float32),
            },
            r"depth\.exr: .*found \['BY', 'RY', 'Y'\]",
        ),
        (
            {
                "R": np.ones((2, 2), np.uint32),
                "G": np.ones((2, 2), np.float32),
                "B": np.ones((2, 2), np.float32),
            },
            r"depth\.exr: channel R holds uint32",
        ),
    ],
    ids=["no-colour", "no-blue", "chroma", "integer"],
)
def test_refuses_files_without_float_rgb(tmp_path, channels, match):
    write_channels(tmp_path / "depth.exr", channels)
    with pytest.raises(ValueError, match=match):
        read_exr(tmp_path / "depth.exr")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_refuses_non_finite_pixels_in_a_file(tmp_path, bad):
    image = radiance()
    image[2, 3, 1] = bad
    write_channels(tmp_path / "hot.exr", {"RGB": image})
    with pytest.raises(ValueError, match=r"hot\.exr: holds non-finite pixels"):
        read_exr(tmp_path / "hot.exr")


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.ones((4, 5)), r"image must have shape \(H, W, 3\)"),
        (np.ones((4, 5, 4)), r"image must have shape \(H, W, 3\)"),
        (np.ones((0, 5, 3)), r"image must have shape \(H, W, 3\) with H, W >= 1"),
        (np.full((2, 2, 3), np.nan), "image must be finite"),
        (np.full((2, 2, 3), np.inf), "image must be finite"),
        (np.full((2, 2, 3), 1e39), "image must be finite in float32"),
        (np.full((2, 2, 3), "1"), "image must hold real numbers"),
    ],
    ids=["2d", "rgba", "empty", "nan", "inf", "overflow", "strings"],
)
def test_write_refuses_bad_images(tmp_path, image, match):
    with pytest.raises(ValueError, match=match):
        write_exr(tmp_path / "bad.exr", image)
    assert list(tmp_path.iterdir()) == []


def test_write_replaces_atomically_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "maps" / "sky.exr"
    write_exr(path, radiance(seed=1))
    write_exr(path, radiance(seed=2))
    np.testing.assert_array_equal(read_exr(path), radiance(seed=2))
    assert [p.name for p in path.parent.iterdir()] == ["sky.exr"]


def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "sky.exr"
    write_exr(path, radiance(seed=1))
    before = path.read_bytes()

    class CrashingFile:
        """Writes half a file, then fails, as a full disk would."""

        def __init__(self, header, channels):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, filename):
            with open(filename, "wb") as handle:
                handle.write(before[: len(before) // 2])
            raise OSError("No space left on device")

    monkeypatch.setattr(OpenEXR, "File", CrashingFile)
    with pytest.raises(OSError, match="No space left"):
        write_exr(path, radiance(seed=2))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["sky.exr"]
