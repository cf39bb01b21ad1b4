"""EXR and PNG input/output (io.py)."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest

from softshadows import io


def test_exr_round_trips_gray_rgb_and_rgba(tmp_path):
    rng = np.random.default_rng(0)
    for shape in [(5, 7), (5, 7, 3), (5, 7, 4)]:
        img = (rng.uniform(-2, 50, shape)).astype(np.float32)
        path = tmp_path / f"img{len(shape)}.exr"
        io.write_exr(path, img)
        back = io.read_exr(path)
        assert back.dtype == np.float32 and back.shape == shape
        np.testing.assert_array_equal(back, img)


def test_gray_exr_is_one_y_channel(tmp_path):
    import OpenEXR

    io.write_exr(tmp_path / "v.exr", np.ones((3, 4), np.float64))
    with OpenEXR.File(str(tmp_path / "v.exr"), separate_channels=True) as f:
        assert list(f.channels()) == ["Y"]


def test_half_float_files_are_read_as_float32(tmp_path):
    import OpenEXR

    h = np.arange(12, dtype=np.float16).reshape(3, 4)
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"R": h, "G": h + 1, "B": h + 2}) as f:
        f.write(str(tmp_path / "h.exr"))
    back = io.read_exr(tmp_path / "h.exr")
    assert back.dtype == np.float32 and back.shape == (3, 4, 3)
    np.testing.assert_array_equal(back[..., 2], h.astype(np.float32) + 2)


def test_read_environment_latlong(tmp_path):
    env = np.random.default_rng(1).uniform(0, 10, (8, 16, 4)).astype(np.float32)
    env[0, 0, 0] = -1e-3  # tools sometimes write tiny negatives
    io.write_exr(tmp_path / "env.exr", env)
    out = io.read_environment(tmp_path / "env.exr")
    assert out.shape == (8, 16, 3) and out.dtype == np.float32
    assert out[0, 0, 0] == 0
    np.testing.assert_array_equal(out[1:], env[1:, :, :3])
    io.write_exr(tmp_path / "gray.exr", env[..., 1])
    np.testing.assert_array_equal(io.read_environment(tmp_path / "gray.exr"), np.repeat(env[..., 1:2], 3, -1))
    with pytest.raises(ValueError, match="6 square faces"):
        io.read_environment(tmp_path / "env.exr", layout="cube")
    with pytest.raises(ValueError, match="layout"):
        io.read_environment(tmp_path / "env.exr", layout="mirrorball")


def test_write_png_maps_the_value_range(tmp_path):
    import matplotlib.image

    gray = np.array([[0.0, 0.5], [1.0, 2.0]])
    io.write_png(tmp_path / "g.png", gray, vmin=0, vmax=2)
    back = matplotlib.image.imread(tmp_path / "g.png")
    assert back.shape[:2] == (2, 2)
    np.testing.assert_allclose(back[..., 0], [[0, 0.25], [0.5, 1.0]], atol=1 / 255)
    rgb = np.zeros((2, 3, 3))
    rgb[0, 0] = [1, 0, 0.5]
    io.write_png(tmp_path / "c.png", rgb)
    back = matplotlib.image.imread(tmp_path / "c.png")
    np.testing.assert_allclose(back[0, 0, :3], [1, 0, 0.5], atol=1 / 255)
    io.write_png(tmp_path / "m.png", gray, cmap="magma", vmax=2)
    back = matplotlib.image.imread(tmp_path / "m.png")
    assert not np.allclose(back[..., 0], back[..., 2])  # a colour map, not gray


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda p: io.write_exr(p / "a.exr", np.zeros((2, 2, 2))), "image"),
        (lambda p: io.write_exr(p / "a.exr", np.full((2, 2), np.inf)), "image"),
        (lambda p: io.write_png(p / "a.png", np.zeros((2, 2, 3)), cmap="magma"), "cmap"),
        (lambda p: io.write_png(p / "a.png", np.zeros((2, 2)), vmin=1, vmax=1), "vmax"),
    ],
)
def test_bad_arguments_name_themselves(tmp_path, call, name):
    with pytest.raises(ValueError, match=name):
        call(tmp_path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        io.read_exr(tmp_path / "nope.exr")


def test_read_environment_cube_strip(tmp_path):
    faces = np.random.default_rng(2).uniform(0, 5, (6, 4, 4, 3)).astype(np.float32)
    io.write_exr(tmp_path / "cube.exr", faces.reshape(24, 4, 3))
    out = io.read_environment(tmp_path / "cube.exr", layout="cube")
    assert out.shape == (6, 4, 4, 3)
    np.testing.assert_array_equal(out, faces)  # face k is rows 4k..4k+3 of the strip


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="/dev/full, the device that fails every write like a full disk, exists on Linux only")
def test_a_failed_write_raises_oserror_naming_the_path():
    # /dev/full fails every write with ENOSPC, like a full disk; OpenEXR alone returned normally.
    with pytest.raises(OSError, match="/dev/full") as info:
        io.write_exr("/dev/full", np.ones((8, 8), np.float32))
    assert info.value.errno == errno.ENOSPC


def test_a_nul_in_the_path_is_refused_not_cut_short(tmp_path):
    with pytest.raises(ValueError, match="NUL"):
        io.write_exr(str(tmp_path / "a\0b.exr"), np.ones((8, 8), np.float32))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes (os.mkfifo) do not exist on Windows")
def test_reading_a_pipe_is_refused_instead_of_blocking(tmp_path):
    fifo = tmp_path / "pipe.exr"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match="not a regular file"):
        io.read_exr(fifo)


def _srgb(x):
    """The IEC 61966-2-1 encoding, written out independently of io.tonemap."""
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def test_write_png_exposure_auto_shows_dim_radiance_bright(tmp_path):
    import matplotlib.image

    # A shaded image as shading.direct returns it: radiance peaking at 0.06, a black background.
    radiance = np.zeros((10, 10), np.float32)
    radiance[1:9, 1:9] = np.linspace(0.01, 0.06, 64).reshape(8, 8)
    io.write_png(tmp_path / "shaded.png", radiance, exposure="auto")
    back = matplotlib.image.imread(tmp_path / "shaded.png")[..., 0]
    lit = radiance[radiance > 0]
    scale = 1 / np.percentile(lit, io.AUTO_PERCENTILE)
    np.testing.assert_allclose(back, _srgb(np.clip(radiance * scale, 0, 1)), atol=2 / 255)  # 8 bits, 256-entry gray LUT
    assert back.max() == 1 and back[0, 0] == 0  # the bright end is white, the background black


def test_write_png_explicit_exposure_scales_then_encodes(tmp_path):
    import matplotlib.image

    rgb = np.zeros((2, 2, 3))
    rgb[0, 0] = [0.05, 0.01, 0.2]  # exposure 10: 0.5, 0.1 and 2 (clipped to 1)
    io.write_png(tmp_path / "rgb.png", rgb, exposure=10)
    back = matplotlib.image.imread(tmp_path / "rgb.png")
    np.testing.assert_allclose(back[0, 0, :3], _srgb([0.5, 0.1, 1.0]), atol=1 / 255)


def test_auto_exposure_ignores_the_black_background():
    shaded = np.zeros((20, 20, 3))
    shaded[5:7, 5:7] = [0.02, 0.04, 0.01]  # 4 lit pixels out of 400: a percentile of all pixels would be 0
    assert io.auto_exposure(shaded) == pytest.approx(25.0)
    assert io.auto_exposure(np.zeros((3, 3))) == 1.0


def test_tonemap_keeps_alpha_and_clips_negative_radiance():
    rgba = np.array([[[-0.5, 0.5, 4.0, 0.25]]])
    out = io.tonemap(rgba, exposure=1.0)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out[0, 0], [0, _srgb(0.5), 1, 0.25], atol=1e-6)


@pytest.mark.parametrize("writer, name, ext", [(io.write_exr, "x.jpg", ".exr"), (io.write_exr, "x.png", ".exr"),
                                               (io.write_png, "x.exr", ".png"), (io.write_png, "x.jpg", ".png")])
def test_writers_refuse_another_formats_extension(tmp_path, writer, name, ext):
    with pytest.raises(ValueError, match=rf"path: .*{name}.*name it .*x\{ext}"):
        writer(tmp_path / name, np.zeros((2, 2)))
    assert list(tmp_path.iterdir()) == []
    # The format's own extension in any case, or none (a device such as /dev/full), is written.
    writer(tmp_path / ("y" + ext.upper()), np.zeros((2, 2)))
    writer(tmp_path / "y", np.zeros((2, 2)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["y", "y" + ext.upper()]


def test_read_exr_names_a_png_it_is_given(tmp_path):
    io.write_png(tmp_path / "view.png", np.zeros((2, 2)))
    with pytest.raises(ValueError, match="is a PNG image, not an OpenEXR file; read it with matplotlib.image.imread"):
        io.read_exr(tmp_path / "view.png")
    (tmp_path / "notes.exr").write_text("not an image")
    with pytest.raises(ValueError, match="not an OpenEXR file"):
        io.read_exr(tmp_path / "notes.exr")


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"exposure": "bright"}, "exposure"),
        ({"exposure": 0}, "exposure"),
        ({"exposure": "auto", "vmax": 2}, "vmax"),
        ({"exposure": 2.0, "cmap": "magma"}, "cmap"),
    ],
)
def test_exposure_arguments_name_themselves(tmp_path, kw, name):
    with pytest.raises(ValueError, match=name):
        io.write_png(tmp_path / "a.png", np.zeros((2, 2)), **kw)


def test_exposure_refuses_display_encoded_uint8(tmp_path):
    with pytest.raises(ValueError, match="exposure: a uint8 image is already encoded"):
        io.write_png(tmp_path / "a.png", np.zeros((2, 2), np.uint8), exposure="auto")
