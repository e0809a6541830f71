"""Figures of lamina's results with matplotlib (imported here only: never in the render path).

``python -m lamina.plot brdf TABLE.csv TOTALS.json OUT.png`` draws a ``lamina brdf`` result from
its files; ``lamina brdf --plot`` and ``lamina compare --plot`` run this module, and
scripts/tradeoff.py draws the speed-accuracy report with ``tradeoff``.
"""

from __future__ import annotations

import csv
import json
import math
import os
import sys
from typing import Any, Optional

import numpy as np

_CHANNELS = ("r", "g", "b")
_COLOURS = ("tab:red", "tab:green", "tab:blue")


def _pyplot():
    import matplotlib

    if "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _sorted(result: Any):
    """theta_o ascending (lamina numbers the rings by cos theta_o) with the bins in that order."""
    order = np.argsort(result.theta_o_deg)
    return np.asarray(result.theta_o_deg)[order], np.asarray(result.phi_o_deg), np.asarray(result.value)[:, order]


def _plane_of_incidence(result: Any, side: int, channel: int):
    """The bins nearest the plane of incidence: theta_o signed (negative: the light's side,
    phi_o near 180 degrees for reflection's back-scatter half) and the BRDF there."""
    theta, phi, values = _sorted(result)
    m_fwd = int(np.argmin(np.abs(((phi - 180.0) + 180.0) % 360.0 - 180.0)))  # phi_o = 180: forward (mirror) side
    m_back = int(np.argmin(np.minimum(phi, 360.0 - phi)))                     # phi_o = 0: towards the light
    values = values[side, :, :, channel]
    angles = np.concatenate([-theta[::-1], theta])
    f = np.concatenate([values[::-1, m_back], values[:, m_fwd]])
    return angles, f


def brdf(result: Any, path: Optional[os.PathLike] = None, *, title: Optional[str] = None):
    """Four panels: the BRDF and BTDF in the plane of incidence as polar plots (per channel, the
    Lambert lobe of the same diffuse albedo dashed, the totals in the legend), and the
    hemispherical maps of the green channel (projected: radius sin theta_o). Returns the figure;
    writes it to ``path`` if given."""
    if result.value is None:
        raise ValueError("plot_brdf: the result has no table (adding-doubling with table=False)")
    plt = _pyplot()
    from matplotlib.ticker import MaxNLocator

    fig = plt.figure(figsize=(11, 9))
    sides = ((0, "BRDF (reflection)", "R_diffuse", "R_specular"), (1, "BTDF (transmission)", "T_diffuse", "T_ballistic"))
    for row, (side, name, diffuse_key, delta_key) in enumerate(sides):
        ax = fig.add_subplot(2, 2, 2 * row + 1, projection="polar")
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)  # the light's side on the left, the mirror / forward side on the right
        ax.set_thetamin(-90)
        ax.set_thetamax(90)
        ax.yaxis.set_major_locator(MaxNLocator(4))
        ax.tick_params(axis="y", labelsize=7)
        ax.axvline(np.radians(-result.theta_i if side == 0 else result.theta_i + 180), color="orange", lw=1)
        for c in range(3):
            angles, f = _plane_of_incidence(result, side, c)
            albedo = float(result.totals[diffuse_key]["value"][c])
            err = float(result.totals[diffuse_key]["stderr"][c])
            label = f"{_CHANNELS[c]}: {diffuse_key} {albedo:.4f}" + (f" \u00b1 {err:.1g}" if err > 0 else "")
            ax.plot(np.radians(angles), f, color=_COLOURS[c], label=label)
            ax.plot(np.radians(angles), np.full_like(angles, albedo / math.pi), color=_COLOURS[c], ls="--", lw=0.8)
        delta = result.totals[delta_key]["value"]
        ax.set_title(f"{name} in the plane of incidence, theta_i {result.theta_i:g}\u00b0 (orange)\n"
                     f"dashed: Lambert of the same albedo; {delta_key} {np.round(delta, 4).tolist()}", fontsize=9)
        ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.1, -0.25))
        # The hemisphere seen from above: radius sin(theta_o), angle phi_o.
        ax2 = fig.add_subplot(2, 2, 2 * row + 2, projection="polar")
        theta_edges = np.degrees(np.arccos(np.linspace(1.0, 0.0, result.value.shape[1] + 1)))
        phi_edges = np.linspace(0.0, 2 * math.pi, result.value.shape[2] + 1)
        mesh = ax2.pcolormesh(phi_edges, np.sin(np.radians(theta_edges)), _sorted(result)[2][side, :, :, 1], shading="flat")
        ax2.set_yticklabels([])
        ax2.set_title(f"{name}, hemisphere (green, 1/sr; radius sin theta_o)", fontsize=9)
        fig.colorbar(mesh, ax=ax2, shrink=0.8)
    fig.suptitle(title or f"lamina brdf, {result.method}")
    fig.tight_layout()
    if path is not None:
        fig.savefig(os.fspath(path), dpi=100)
    return fig


def compare(reference: Any, test: Any, path: Optional[os.PathLike] = None, *, epsilon: Optional[float] = None,
            range_: float = 0.5):
    """A histogram of the per-pixel relative difference of luminance beside its false-colour
    image (red: TEST brighter, blue: darker, full at +-range_). Returns the figure."""
    import lamina

    kwargs = {} if epsilon is None else {"epsilon": epsilon}
    rel = lamina.relative_difference(reference, test, **kwargs)
    metrics = lamina.compare(reference, test, **kwargs)
    plt = _pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.5))
    im = a.imshow(rel, cmap="RdBu_r", vmin=-range_, vmax=range_)
    a.set_title("relative difference of luminance")
    a.axis("off")
    fig.colorbar(im, ax=a, shrink=0.8)
    b.hist(np.clip(rel.ravel(), -range_, range_), bins=101, color="grey")
    b.set_yscale("log")
    b.set_xlabel("(TEST - REF) / max(REF, guard)")
    b.set_title(f"mean {metrics['mean_relative']:+.4f}, RMS {metrics['rms_relative']:.4f}, SSIM {metrics['ssim']:.4f}")
    fig.tight_layout()
    if path is not None:
        fig.savefig(os.fspath(path), dpi=100)
    return fig


MODE_COLOURS = {"random-walk": "tab:blue", "first-order": "tab:orange", "table": "tab:green", "lambert": "tab:red"}


def tradeoff(rows: list, panels: list, modes: list):
    """The speed-accuracy report's figure (scripts/tradeoff.py): per panel (scene, title, the
    reference's own noise) RMSE against seconds, log-log, one curve per --subsurface mode, each
    point labelled with its spp. rows: dicts with scene, mode, spp, seconds, rmse and
    precompute_seconds. Returns the figure."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6), squeeze=False)
    for ax, (scene, title, ref_noise) in zip(axes[0], panels):
        for mode in modes:
            mr = sorted([r for r in rows if r["scene"] == scene and r["mode"] == mode],
                        key=lambda r: r["spp"])
            label = mode
            if mode in ("table", "lambert"):
                # Every run does its own precompute; on a shared machine its time varies.
                lo = min(r["precompute_seconds"] for r in mr)
                hi = max(r["precompute_seconds"] for r in mr)
                fmt = (lambda x: f"{x:.0f}") if lo >= 1 else (lambda x: f"{x:.2f}")
                span = fmt(lo) if fmt(lo) == fmt(hi) else f"{fmt(lo)}-{fmt(hi)}"
                label += f" (incl. {span} s precompute per run)"
            xs = [max(r["seconds"], 1e-3) for r in mr]
            ax.loglog(xs, [r["rmse"] for r in mr], "o-", color=MODE_COLOURS[mode], label=label, ms=4)
            for r, x in zip(mr, xs):
                ax.annotate(str(r["spp"]), (x, r["rmse"]), fontsize=6, xytext=(2, 2),
                            textcoords="offset points")
        ax.axhline(ref_noise, color="grey", ls="--", lw=0.8,
                   label=f"reference's own noise ~{ref_noise:.3f}")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("seconds (render + precompute; 0 s drawn at 1 ms)", fontsize=8)
        ax.set_ylabel("RMSE vs reference", fontsize=8)
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=6.5)
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    return fig


class _FileResult:
    """A BrdfResult read back from ``lamina brdf --out TABLE.csv --summary TOTALS.json``."""

    def __init__(self, table_csv: str, totals_json: str) -> None:
        with open(totals_json, encoding="utf-8") as f:
            j = json.load(f)
        self.method, self.theta_i = j["method"], j["theta_i_deg"]
        self.totals = {k: {"value": np.asarray(j[k]), "stderr": np.asarray(j.get(k + "_stderr", [0, 0, 0]))}
                       for k in ("R_specular", "R_diffuse", "T_ballistic", "T_diffuse", "absorbed")}
        rows = list(csv.DictReader(open(table_csv, encoding="utf-8")))
        theta = sorted({float(r["theta_o_deg"]) for r in rows})
        phi = sorted({float(r["phi_o_deg"]) for r in rows})
        self.theta_o_deg, self.phi_o_deg = np.asarray(theta), np.asarray(phi)
        self.value = np.zeros((2, len(theta), len(phi), 3))
        ti, pi = {t: i for i, t in enumerate(theta)}, {p: i for i, p in enumerate(phi)}
        for r in rows:
            self.value[0 if r["side"] == "reflect" else 1, ti[float(r["theta_o_deg"])], pi[float(r["phi_o_deg"])],
                       _CHANNELS.index(r["channel"])] = float(r["value"])


def _save_atomically(fig, path: str) -> None:
    """Written beside the path, then renamed: a failed plot leaves no partial file."""
    tmp = os.path.join(os.path.dirname(os.path.abspath(path)), f".{os.path.basename(path)}.{os.getpid()}.tmp.png")
    try:
        fig.savefig(tmp, dpi=100)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def main(argv: list) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python3 -m lamina.plot", description="lamina's figures from its files")
    sub = ap.add_subparsers(dest="what", required=True)
    b = sub.add_parser("brdf", help="lamina brdf --out TABLE.csv --summary TOTALS.json, drawn")
    b.add_argument("table")
    b.add_argument("totals")
    b.add_argument("out")
    c = sub.add_parser("compare", help="two images: relative difference and its histogram")
    c.add_argument("reference")
    c.add_argument("test")
    c.add_argument("out")
    c.add_argument("--epsilon", type=float, default=None)
    c.add_argument("--range", type=float, default=0.5)
    args = ap.parse_args(argv)
    try:
        if args.what == "brdf":
            fig = brdf(_FileResult(args.table, args.totals))
        else:
            fig = compare(args.reference, args.test, epsilon=args.epsilon, range_=args.range)
        _save_atomically(fig, args.out)
    except (OSError, ValueError) as e:
        sys.stderr.write(f"lamina.plot: {e}\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
