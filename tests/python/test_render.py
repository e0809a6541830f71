"""lamina.render, Image, compare and denoise against the command line, and Ctrl-C."""

import json
import os
import signal
import threading
import time

import numpy as np
import pytest

import lamina

SCENE = "scenes/spheres/spheres_0.gltf"
SIZE = ["--width", "40", "--height", "30", "--spp", "4", "--seed", "5"]


def exr_of_cli(cli, source, tmp_path, name, *extra):
    out = tmp_path / name
    cli("render", source / SCENE, *SIZE, "-o", out, *extra)
    return lamina.Image.read(out)


def test_render_equals_the_command_line(cli, source, tmp_path):
    ref = exr_of_cli(cli, source, tmp_path, "cli.exr", "--aovs", "albedo,normal,depth")
    im = lamina.render(source / SCENE, width=40, height=30, spp=4, seed=5, aovs=["albedo", "normal", "depth"],
                       progress=False)
    assert im.rgb.dtype == np.float32 and im.rgb.shape == (30, 40, 3)
    assert np.array_equal(im.rgb, ref.rgb)
    assert set(im.channels) == set(ref.channels) == {"albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "Z"}
    for name in im.channels:
        assert np.array_equal(im.channels[name], ref.channels[name]), name
    assert im.aovs["albedo"].shape == (30, 40, 3) and im.aovs["depth"].shape == (30, 40)
    # The header: the same keys and values but the command and the timings.
    differ = {k for k in set(im.metadata) | set(ref.metadata) if im.metadata.get(k) != ref.metadata.get(k)}
    assert differ <= {"lamina:command", "lamina:seconds"}, differ
    # Image.write writes what the CLI wrote.
    im.write(tmp_path / "py.exr")
    back = lamina.Image.read(tmp_path / "py.exr")
    assert np.array_equal(back.rgb, ref.rgb) and back.metadata == im.metadata


def test_spectral_equals_the_command_line(cli, source, tmp_path):
    # lamina.render(spectral=True) is lamina render --spectral: the same image and header.
    ref = exr_of_cli(cli, source, tmp_path, "cli.exr", "--spectral")
    im = lamina.render(source / SCENE, width=40, height=30, spp=4, seed=5, spectral=True, progress=False)
    assert np.array_equal(im.rgb, ref.rgb)
    assert not np.array_equal(im.rgb, exr_of_cli(cli, source, tmp_path, "rgb.exr").rgb)
    differ = {k for k in set(im.metadata) | set(ref.metadata) if im.metadata.get(k) != ref.metadata.get(k)}
    assert differ <= {"lamina:command", "lamina:seconds"}, differ
    assert "lamina:spectral" in im.metadata and "spectral=True" in im.metadata["lamina:command"]


def test_spectral_refusal_is_the_command_lines(cli, source, tmp_path):
    # Chromophores bound to a map are not tabulated per wavelength: the table mode refuses them in
    # the spectral mode, in the command line's words; nothing is written.
    (tmp_path / "map.json").write_text(json.dumps({"skin": {
        "stack": str(source / "scenes/spectral/skin_spectral.json"),
        "bind": [{"parameter": "layers[0].chromophores.melanin", "texture": str(source / "scenes/head_skin/melanin_fitted.png"),
                  "channel": "r", "range": [0.01, 0.3]}]}}))
    out = tmp_path / "out"
    out.mkdir()
    p = cli("render", source / SCENE, *SIZE, "-o", out / "x.exr", "--materials", tmp_path / "map.json", "--spectral",
            "--subsurface", "table", check=False)
    assert p.returncode == 1, p.stderr
    message = p.stderr.strip().splitlines()[-1]
    assert "not tabulated per wavelength" in message, message
    with pytest.raises(RuntimeError) as e:
        lamina.render(source / SCENE, width=40, height=30, spp=4, seed=5, materials=tmp_path / "map.json", spectral=True,
                      subsurface="table", out=out / "x.exr", progress=False)
    assert "lamina render: " + str(e.value) == message
    assert os.listdir(out) == []


def test_spectral_keyword_is_the_flags_declaration():
    # The keyword, its flag and its help come from the one C++ declaration (spectral_option.h).
    import inspect
    from lamina import _lamina
    keyword, flag, help = _lamina.SPECTRAL_OPTION
    assert flag == "--" + keyword
    assert inspect.signature(lamina.render).parameters[keyword].default is False
    assert help in lamina.render.__doc__


def test_out_writes_the_files_as_the_cli(cli, source, tmp_path):
    ref = exr_of_cli(cli, source, tmp_path, "cli.exr")
    lamina.render(source / SCENE, width=40, height=30, spp=4, seed=5, out=tmp_path / "py.exr",
                  png=tmp_path / "py.png", progress=False)
    assert np.array_equal(lamina.Image.read(tmp_path / "py.exr").rgb, ref.rgb)
    assert (tmp_path / "py.png").stat().st_size > 0


def test_inline_stacks_equal_the_map(cli, source, tmp_path):
    skin = lamina.Stack.load(source / "scenes/materials/skin_dark.json")
    im = lamina.render(source / SCENE, width=40, height=30, spp=4, seed=5, materials={"skin": skin}, progress=False)
    mapping = tmp_path / "map.json"
    mapping.write_text('{"skin": "%s"}' % (source / "scenes/materials/skin_dark.json"))
    ref = exr_of_cli(cli, source, tmp_path, "cli.exr", "--materials", mapping)
    assert np.array_equal(im.rgb, ref.rgb)


def test_compare_equals_the_command_line(cli, source, tmp_path):
    a = exr_of_cli(cli, source, tmp_path, "a.exr")
    b = lamina.render(source / SCENE, width=40, height=30, spp=4, seed=6, progress=False)
    b.write(tmp_path / "b.exr")
    cli("compare", tmp_path / "a.exr", tmp_path / "b.exr", "--json", tmp_path / "m.json")
    import json
    expected = json.loads((tmp_path / "m.json").read_text())
    got = lamina.compare(a, b)
    for key in ("guard_floor", "mean_relative", "rms_relative", "max_abs_relative", "mae", "mse", "rmse", "ssim"):
        assert got[key] == expected[key], key
    assert lamina.compare(tmp_path / "a.exr", tmp_path / "b.exr") == got


def test_progress_and_gil(source):
    calls, ticks, stop = [], [0], threading.Event()

    def count():  # runs only while the render has released the GIL
        while not stop.is_set():
            ticks[0] += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    lamina.render(source / SCENE, width=64, height=48, spp=64, progress=lambda d, n: calls.append((d, n)))
    stop.set()
    t.join()
    assert calls and all(0 < d <= n for d, n in calls)
    assert ticks[0] > 10


# 640x480 at 256 spp takes a minute or more on 2 cores; 4x4 at 2^20 spp is one tile of minutes,
# which Ctrl-C stops inside the tile (the render checks before each path sample).
@pytest.mark.parametrize("width,height,spp,seconds", [(640, 480, 256, 30), (4, 4, 1 << 20, 10)])
def test_ctrl_c_stops_and_writes_nothing(source, tmp_path, width, height, spp, seconds):
    out = tmp_path / "never.exr"
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        lamina.render(source / SCENE, width=width, height=height, spp=spp, out=out, png=tmp_path / "never.png",
                      progress=False)
    timer.cancel()
    assert time.monotonic() - start < seconds  # stopped, not finished
    assert os.listdir(tmp_path) == []  # no image, no temporary
    cpu = time.process_time()  # and the render does not go on in the background
    time.sleep(0.5)
    assert time.process_time() - cpu < 0.2


@pytest.mark.parametrize("kwargs,error", [
    ({"width": 0}, ValueError), ({"width": "40"}, TypeError), ({"spp": 2.5}, TypeError),
    ({"clamp": float("nan")}, ValueError), ({"subsurface": "magic"}, ValueError), ({"aovs": "colour"}, ValueError),
    ({"walk": {"no-such-option": 1}}, ValueError), ({"spectral": 1}, TypeError), ({"spectral": "yes"}, TypeError),
])
def test_bad_arguments_raise(source, kwargs, error):
    args = {"width": 8, "height": 8, "spp": 1, "progress": False, **kwargs}
    with pytest.raises(error):
        lamina.render(source / SCENE, **args)


def test_missing_scene_raises_the_clis_message(cli, tmp_path):
    p = cli("render", tmp_path / "none.gltf", "-o", tmp_path / "x.exr", check=False)
    with pytest.raises(RuntimeError) as e:
        lamina.render(tmp_path / "none.gltf", width=8, height=8, progress=False)
    assert "lamina render: " + str(e.value) == p.stderr.strip().splitlines()[-1]


def test_image_errors(tmp_path):
    with pytest.raises(lamina.ImageIoError):
        lamina.Image.read(tmp_path / "none.exr")
    with pytest.raises(ValueError):
        lamina.Image(np.zeros((4, 4)))
    with pytest.raises(ValueError):
        lamina.compare(np.zeros((4, 4, 3), np.float32), np.zeros((4, 5, 3), np.float32))
    bad = np.ones((4, 4, 3), np.float32)
    bad[1, 1, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        lamina.compare(np.ones((4, 4, 3), np.float32), bad)


def test_denoise_equals_the_command_line(cli, source, tmp_path):
    raw = exr_of_cli(cli, source, tmp_path, "raw.exr", "--aovs", "albedo,normal")
    cli("denoise", tmp_path / "raw.exr", "-o", tmp_path / "dn.exr", "--threads", "1")
    got = lamina.denoise(raw, threads=1)
    assert np.array_equal(got.rgb, lamina.Image.read(tmp_path / "dn.exr").rgb)
    assert not np.array_equal(got.rgb, raw.rgb)
    assert got.metadata["lamina:command"] == raw.metadata["lamina:command"]


def test_crop_and_png_options_equal_the_command_line(cli, source, tmp_path):
    ref = exr_of_cli(cli, source, tmp_path, "cli.exr", "--crop", "10,5,30,25", "--png", tmp_path / "cli.png",
                     "--exposure", "1.5", "--tone-curve", "clamp")
    im = lamina.render(source / SCENE, width=40, height=30, spp=4, seed=5, crop=(10, 5, 30, 25), out=tmp_path / "py.exr",
                       png=tmp_path / "py.png", exposure=1.5, tone_curve="clamp", progress=False)
    assert im.rgb.shape == (20, 20, 3) and im.window == (10, 5, 40, 30)
    assert np.array_equal(im.rgb, ref.rgb)
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    with pytest.raises(ValueError, match="crop"):
        lamina.render(source / SCENE, width=40, height=30, spp=1, crop=(10, 5, 50, 25), progress=False)


# Combinations the library refuses (renderer/render/render_request_check.h): the command line
# and the package name the same rule in the same words, before anything is loaded.
@pytest.mark.parametrize("args,kwargs", [
    (["--exposure", "1"], {"exposure": 1.0}),
    (["--tone-curve", "clamp"], {"tone_curve": "clamp"}),
    (["--subsurface", "lambert", "--guiding", "0.5"], {"subsurface": "lambert", "walk": {"guiding": 0.5}}),
    (["--pilot-spp", "2"], {"pilot_spp": 2}),
    (["--noise-threshold", "0.1", "--pilot-spp", "8"], {"noise_threshold": 0.1, "pilot_spp": 8}),
    (["--tolerance", "0.1"], {"tolerance": 0.1}),
    (["--subsurface", "auto"], {"subsurface": "auto"}),
    (["--table-method", "walk"], {"table_method": "walk"}),
    (["--crop", "10,5,50,25"], {"crop": (10, 5, 50, 25)}),
    (["--crop", "0,0,0,0"], {"crop": (0, 0, 0, 0)}),
    (["--width", "16384", "--height", "16384", "--spp", "1048576"], {"width": 16384, "height": 16384, "spp": 1 << 20}),
])
def test_bad_combinations_give_the_clis_message(cli, source, tmp_path, args, kwargs):
    size = [] if "--width" in args else ["--width", "40", "--height", "30", "--spp", "4"]
    p = cli("render", source / SCENE, *size, "-o", tmp_path / "x.exr", *args, check=False)
    assert p.returncode == 2, p.stderr
    message = p.stderr.strip().splitlines()[-1]
    assert message.startswith("lamina render: --"), message
    with pytest.raises(ValueError) as e:
        lamina.render(source / SCENE, **{"width": 40, "height": 30, "spp": 4, **kwargs}, out=tmp_path / "x.exr",
                      progress=False)
    assert "lamina render: " + str(e.value) == message
    assert os.listdir(tmp_path) == []
