"""lamina.fit equals `lamina fit` (the summary's numbers and the fitted material file)."""

import json
import math

import pytest

import lamina

PARAMS = ["--param", "layers[0].sigma_a=0:20", "--param", "layers[0].sigma_s=0:100", "--quadrature-points", "8"]


def test_equals_the_command_line(cli, source, tmp_path):
    start, data = source / "docs/examples/slab.json", source / "docs/examples/slab_rt.csv"
    cli("fit", start, "--data", data, *PARAMS, "--out", tmp_path / "fitted.json", "--summary", tmp_path / "fit.json")
    summary = json.loads((tmp_path / "fit.json").read_text())
    r = lamina.fit(start, data, {"layers[0].sigma_a": (0, 20), "layers[0].sigma_s": (0, 100)}, quadrature_points=8)
    assert r.chi2 == summary["chi2"] and r.dof == summary["dof"]
    for p in summary["parameters"]:
        assert r.values[p["name"]] == p["value"]
        assert r.sigmas[p["name"]] == p["sigma"]
    assert r.stack.to_dict() == json.loads((tmp_path / "fitted.json").read_text())
    assert abs(r.values["layers[0].sigma_a[r]"] - 0.5) < 5 * r.sigmas["layers[0].sigma_a[r]"]


def test_measurements_as_dicts_equal_the_file(source):
    rows = [{"quantity": "R", "channel": "r", "theta_i_deg": 0, "value": 0.2129, "sigma": 0.001},
            {"quantity": "T", "channel": "r", "theta_i_deg": 0, "value": 0.2756, "sigma": 0.001}]
    params = {"layers[0].sigma_a": (0, 20), "layers[0].sigma_s": (0, 100)}
    a = lamina.fit(source / "docs/examples/slab.json", rows, params, quadrature_points=8)
    b = lamina.fit(source / "docs/examples/slab.json", source / "docs/examples/slab_rt.csv", params, quadrature_points=8)
    assert a.values == b.values


def test_bad_input_raises(source, tmp_path):
    stack = source / "docs/examples/slab.json"
    data = source / "docs/examples/slab_rt.csv"
    with pytest.raises(lamina.FitError, match="no_such.csv"):
        lamina.fit(stack, tmp_path / "no_such.csv", {"layers[0].sigma_a": (0, 20)})
    with pytest.raises(lamina.FitError, match="layers\\[7\\]"):
        lamina.fit(stack, data, {"layers[7].sigma_a": (0, 20)})
    with pytest.raises(ValueError):
        lamina.fit(stack, data, {"layers[0].sigma_a": (0, math.nan)})
    with pytest.raises(ValueError):
        lamina.fit(stack, [{"quantity": "R"}], {"layers[0].sigma_a": (0, 20)})
    with pytest.raises(TypeError):
        lamina.fit(stack, 3.5, {"layers[0].sigma_a": (0, 20)})
