"""Stacks: loading, attribute access, and bad input raising the command line's messages."""

import json
import math

import pytest

import lamina


def cli_error(cli, stack_path):
    """The one-line message `lamina brdf` prints for a stack file, without its prefix."""
    p = cli("brdf", stack_path, "--theta-i", "0", "--method", "first-order", check=False)
    assert p.returncode == 1
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("lamina brdf: ")
    return line[len("lamina brdf: "):]


def test_version_is_the_projects(source):
    text = (source / "CMakeLists.txt").read_text()
    assert f"project(lamina VERSION {lamina.__version__} " in text


def test_load_gives_the_files_values(source):
    s = lamina.Stack.load(source / "docs/examples/slab_truth.json")
    d = json.loads((source / "docs/examples/slab_truth.json").read_text())
    assert len(s.layers) == len(d["layers"]) == 1
    assert s.layers[0].thickness == 0.5
    assert s.layers[0].ior == 1.4
    assert s.layers[0].sigma_a == (0.5, 0.5, 0.5)
    assert s.layers[0].sigma_s == (10.0, 10.0, 10.0)
    assert s.to_dict() == d


def test_from_dict_equals_load(source):
    path = source / "scenes/materials/skin.json"
    a = lamina.Stack.load(path)
    b = lamina.Stack.from_dict(json.loads(path.read_text()))
    assert [(l.sigma_a, l.sigma_s, l.thickness, l.ior) for l in a.layers] == \
           [(l.sigma_a, l.sigma_s, l.thickness, l.ior) for l in b.layers]


def test_missing_file_raises_the_clis_message(cli, tmp_path):
    missing = tmp_path / "no_such.json"
    with pytest.raises(lamina.StackFileError) as e:
        lamina.Stack.load(missing)
    assert str(e.value) == cli_error(cli, missing)
    assert isinstance(e.value, ValueError)


def test_invalid_value_raises_the_clis_message(cli, source, tmp_path):
    d = json.loads((source / "docs/examples/slab_truth.json").read_text())
    d["layers"][0]["thickness"] = -1
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(lamina.StackFileError) as e:
        lamina.Stack.load(path)
    assert str(e.value) == cli_error(cli, path)
    assert "layers[0].thickness" in str(e.value)
    with pytest.raises(lamina.StackFileError) as e2:  # the same from a dict, named by its source
        lamina.Stack.from_dict(d, source=str(path))
    assert str(e2.value) == str(e.value)


def test_nan_and_wrong_types_raise(source):
    d = json.loads((source / "docs/examples/slab_truth.json").read_text())
    d["layers"][0]["sigma_a"] = math.nan
    with pytest.raises(lamina.StackFileError, match="<dict>"):
        lamina.Stack.from_dict(d)
    with pytest.raises(TypeError):
        lamina.Stack.from_dict([1, 2])
    with pytest.raises(TypeError):
        lamina.Stack.load(42)
    d["layers"][0]["sigma_a"] = "red"
    with pytest.raises(lamina.StackFileError, match=r"layers\[0\]\.sigma_a"):
        lamina.Stack.from_dict(d)
