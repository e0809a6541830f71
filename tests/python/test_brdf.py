"""lamina.brdf equals `lamina brdf` bit for bit: the summary's JSON numbers exactly, the table's
values as the CSV prints them (%.9g)."""

import csv
import json

import numpy as np
import pytest

import lamina

CHANNELS = "rgb"


def cli_brdf(cli, tmp_path, stack, method, *extra):
    table, summary = tmp_path / "t.csv", tmp_path / "s.json"
    cli("brdf", stack, "--theta-i", "35", "--phi-i", "10", "--method", method, "--out", table, "--summary", summary,
        "--bins-theta", "6", "--bins-phi", "8", *extra)
    return list(csv.DictReader(table.open())), json.loads(summary.read_text())


@pytest.mark.parametrize("method,extra,kwargs", [
    ("monte-carlo", ["--samples", "4000", "--seed", "7"], {"samples": 4000, "seed": 7}),
    ("adding-doubling", ["--quadrature-points", "8"], {"quadrature_points": 8}),
    ("first-order", [], {}),
])
def test_equals_the_command_line(cli, source, tmp_path, method, extra, kwargs):
    stack = source / "docs/examples/slab_truth.json"
    rows, summary = cli_brdf(cli, tmp_path, stack, method, *extra)
    r = lamina.brdf(lamina.Stack.load(stack), 35, phi_i=10, method=method, bins_theta=6, bins_phi=8,
                    progress=False, **kwargs)
    for key in ("R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed"):
        assert r.totals[key]["value"].tolist() == summary[key], key
        assert r.totals[key]["stderr"].tolist() == summary[key + "_stderr"], key
    if method == "adding-doubling":
        for key in ("R_hemispherical", "T_hemispherical", "absorbed_hemispherical"):
            assert r.totals[key]["value"].tolist() == summary[key]
        assert r.totals["R_diffuse"]["discretisation_error"].tolist() == summary["discretisation_error"]["R_diffuse"]
    if method == "monte-carlo":
        assert r.extra["walk_ends"] == summary["walk_ends"]
    assert len(rows) == 2 * 6 * 8 * 3
    theta_index = {f"{t:.9g}": k for k, t in enumerate(r.theta_o_deg)}
    phi_index = {f"{p:.9g}": m for m, p in enumerate(r.phi_o_deg)}
    for row in rows:
        at = (0 if row["side"] == "reflect" else 1, theta_index[row["theta_o_deg"]], phi_index[row["phi_o_deg"]],
              CHANNELS.index(row["channel"]))
        for key in ("value", "stderr", "single", "multiple"):
            assert f"{getattr(r, key)[at]:.9g}" == row[key], (key, row)


def test_monte_carlo_is_deterministic_and_seeded(source):
    s = lamina.Stack.load(source / "docs/examples/slab_truth.json")
    a = lamina.brdf(s, 0, samples=2000, seed=1, progress=False)
    b = lamina.brdf(s, 0, samples=2000, seed=1, progress=False)
    c = lamina.brdf(s, 0, samples=2000, seed=2, progress=False)
    assert np.array_equal(a.value, b.value)
    assert not np.array_equal(a.value, c.value)


def test_progress_callback_reaches_the_total(source):
    calls = []
    lamina.brdf(lamina.Stack.load(source / "docs/examples/slab_truth.json"), 0, samples=200000, seed=1,
                progress=lambda done, total: calls.append((done, total)))
    assert calls, "the callback was never called"
    assert all(0 <= d <= t == 200000 for d, t in calls)
    assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:]))


def test_rough_top_with_first_order_raises_the_clis_message(cli, source, tmp_path):
    d = json.loads((source / "scenes/materials/skin.json").read_text())  # does not transmit
    d["roughness"] = 0.3
    path = tmp_path / "rough.json"
    path.write_text(json.dumps(d))
    p = cli("brdf", path, "--theta-i", "0", "--method", "first-order", check=False)
    with pytest.raises(RuntimeError) as e:
        lamina.brdf(path, 0, method="first-order")
    assert "lamina brdf: " + str(e.value) == p.stderr.strip().splitlines()[-1]


@pytest.mark.parametrize("kwargs,error", [
    ({"theta_i": float("nan")}, ValueError), ({"theta_i": 90}, ValueError), ({"theta_i": "30"}, TypeError),
    ({"theta_i": 0, "samples": 1}, ValueError), ({"theta_i": 0, "samples": 10.5}, TypeError),
    ({"theta_i": 0, "method": "exact"}, ValueError), ({"theta_i": 0, "seed": -1}, ValueError),
    ({"theta_i": 0, "bins_theta": 2000, "bins_phi": 2000}, ValueError),
])
def test_bad_arguments_raise(source, kwargs, error):
    with pytest.raises(error):
        lamina.brdf(source / "docs/examples/slab_truth.json", progress=False, **kwargs)


# The options and their ranges are declared once (renderer/batch/brdf_job.h): a value out of
# range is refused by the command line and the package in the same words, the flag's name
# written as the keyword.
@pytest.mark.parametrize("flag,value", [
    ("--theta-i", 95), ("--samples", 1), ("--quadrature-points", 3), ("--bins-phi", 0), ("--roulette-cap", 999),
])
def test_out_of_range_gives_the_clis_message(cli, source, flag, value):
    stack = source / "docs/examples/slab_truth.json"
    extra = [] if flag == "--theta-i" else ["--theta-i", "0"]
    p = cli("brdf", stack, *extra, flag, str(value), check=False)
    assert p.returncode == 2
    line = p.stderr.strip().splitlines()[-1].replace(" (try 'lamina brdf --help')", "")
    keyword = flag[2:].replace("-", "_")
    kwargs = {"theta_i": 0, keyword: value}
    with pytest.raises(ValueError) as e:
        lamina.brdf(stack, progress=False, **kwargs)
    assert line == "lamina brdf: " + str(e.value).replace(keyword + ":", flag + ":", 1)


def test_every_option_of_the_table_is_a_flag_and_a_keyword(cli):
    import inspect
    help_text = cli("brdf", "--help").stdout
    params = inspect.signature(lamina.brdf).parameters
    for name, *_ in lamina._lamina.brdf_options():
        assert "--" + name.replace("_", "-") in help_text and name in params, name


def test_unknown_option_is_a_type_error(source):
    with pytest.raises(TypeError, match="unexpected keyword argument 'smaples'"):
        lamina.brdf(source / "docs/examples/slab_truth.json", 0, smaples=10, progress=False)
