"""The figures: plot_brdf, plot_compare and `python -m lamina.plot` on lamina brdf's files."""

import subprocess
import sys

import numpy as np

import lamina


def png_size(path):
    import matplotlib.image
    return matplotlib.image.imread(path).shape[:2]


def test_plot_brdf_writes_a_figure(source, tmp_path):
    r = lamina.brdf(source / "docs/examples/slab_truth.json", 30, method="adding-doubling", bins_theta=9,
                    bins_phi=12, quadrature_points=8)
    fig = lamina.plot_brdf(r, tmp_path / "brdf.png")
    assert png_size(tmp_path / "brdf.png") == (900, 1100)
    legend = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
    assert any(f"R_diffuse {r.total('R_diffuse')[0]:.4f}" in t for t in legend), legend


def test_plot_from_the_command_lines_files(cli, source, tmp_path):
    cli("brdf", source / "docs/examples/slab_truth.json", "--theta-i", "30", "--method", "first-order",
        "--out", tmp_path / "t.csv", "--summary", tmp_path / "s.json")
    subprocess.run([sys.executable, "-m", "lamina.plot", "brdf", tmp_path / "t.csv", tmp_path / "s.json",
                    tmp_path / "p.png"], check=True)
    assert png_size(tmp_path / "p.png") == (900, 1100)


def test_plot_compare(tmp_path):
    a = np.ones((20, 30, 3), np.float32)
    b = a.copy()
    b[5:10] *= 1.2
    fig = lamina.plot_compare(a, b, tmp_path / "c.png")
    assert png_size(tmp_path / "c.png") == (450, 1100)
    rel = lamina.relative_difference(a, b)
    assert rel.shape == (20, 30) and np.isclose(rel.max(), 0.2, atol=1e-6) and rel.min() == 0


def test_cli_brdf_plot(cli, source, tmp_path):
    cli("brdf", source / "docs/examples/slab_truth.json", "--theta-i", "30", "--method", "adding-doubling",
        "--quadrature-points", "8", "--plot", tmp_path / "b.png", "--summary", tmp_path / "s.json")
    assert png_size(tmp_path / "b.png") == (900, 1100)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.png", "s.json"]


def test_cli_compare_plot(cli, tmp_path):
    a = lamina.Image(np.ones((20, 30, 3), np.float32))
    b = lamina.Image(np.full((20, 30, 3), 1.1, np.float32))
    a.write(tmp_path / "a.exr")
    b.write(tmp_path / "b.exr")
    cli("compare", tmp_path / "a.exr", tmp_path / "b.exr", "--plot", tmp_path / "c.png")
    assert png_size(tmp_path / "c.png") == (450, 1100)
    p = cli("compare", tmp_path / "a.exr", tmp_path / "b.exr", "--plot", tmp_path / "d.png", "--smooth", "2",
            check=False)
    assert p.returncode == 2 and "--plot: not with --crop or --smooth" in p.stderr
    assert not (tmp_path / "d.png").exists()


def test_cli_plot_without_the_package_fails_cleanly(cli, source, tmp_path, monkeypatch):
    monkeypatch.setenv("LAMINA_PYTHON", str(tmp_path / "no_python"))
    p = cli("brdf", source / "docs/examples/slab_truth.json", "--theta-i", "30", "--method", "first-order",
            "--plot", tmp_path / "b.png", check=False)
    assert p.returncode == 1 and "--plot: cannot run" in p.stderr
    assert not (tmp_path / "b.png").exists()


def test_tradeoff_figure():
    from lamina import plot
    rows = [{"scene": s, "mode": m, "spp": n, "seconds": 0.1 * n, "rmse": 0.5 / n ** 0.5, "precompute_seconds": 0.5}
            for s in ("a", "b") for m in ("random-walk", "lambert") for n in (1, 4, 16)]
    fig = plot.tradeoff(rows, [("a", "scene a", 0.01), ("b", "scene b", 0.02)], ["random-walk", "lambert"])
    assert [ax.get_title() for ax in fig.axes] == ["scene a", "scene b"]
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["random-walk", "lambert (incl. 0.50 s precompute per run)", "reference's own noise ~0.010"]
