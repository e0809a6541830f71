#!/usr/bin/env python3
"""Regenerates the figures of Hanrahan and Krueger (1993) from `lamina brdf` output.

Run it through scripts/figures.sh (which picks a python3 with numpy and matplotlib):

    scripts/figures.sh [--quick] [--lamina build/renderer/lamina] [--out out/figures]

Python only draws: every BRDF/BTDF value and energy total comes from `lamina brdf` (the CSV table
and the totals JSON of docs/contracts.md), run on stack files written into a temporary directory.
The one formula evaluated here is the Lommel-Seeliger law, as an independent check of the first
order (it must agree with `--method first-order` to rounding; the script fails otherwise).

Writes fig1_semi_infinite.png, fig2_first_order.png, fig3_incidence.png, fig4_single_multiple.png
and numbers.json (the numbers quoted in docs/validation.md) into the output directory.

Conventions (docs/contracts.md): phi_o = 0 is the light's side (back scattering), 180 the mirror
side. In the plane-of-incidence plots the signed angle is -theta_o on the light's side and
+theta_o on the mirror side (for transmission: + is the side the light travels to).
"""
import argparse
import concurrent.futures
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def fail(message):
    print(f"figures.py: {message}", file=sys.stderr)
    sys.exit(1)


# ----------------------------------------------------------------------------------------------
# Stacks (docs/contracts.md material format). Coefficients per mm, thicknesses in mm; with
# sigma_t = 1/mm the thickness in mm is the optical depth tau = sigma_t d.

def slab(albedo, tau, g, ior=1.0, below_ior=1.0, sigma_t=1.0):
    thickness = "inf" if tau == math.inf else tau / sigma_t
    return {"lamina_material": 1, "above_ior": 1.0,
            "layers": [{"ior": ior, "thickness": thickness, "sigma_a": sigma_t * (1.0 - albedo),
                        "sigma_s": sigma_t * albedo, "g": g}],
            "below": {"ior": below_ior}}


class Table:
    """One `lamina brdf` run: the G channel of the CSV (the stacks here are grey) as arrays
    [side][k][m] (side 0 reflect, 1 transmit; k the cos-bin, m the phi-bin) and the totals."""

    def __init__(self, csv_path, json_path, K, M):
        self.K, self.M = K, M
        shape = (2, K, M)
        self.value, self.stderr = np.zeros(shape), np.zeros(shape)
        self.single, self.multiple = np.zeros(shape), np.zeros(shape)
        seen = np.zeros(shape, dtype=bool)
        with open(csv_path, newline="") as f:
            rows = csv.DictReader(f)
            for row in rows:
                if row["channel"] != "g":
                    continue
                side = 0 if row["side"] == "reflect" else 1
                # Bin k spans |cos| in [k/K, (k+1)/K], bin m phi in [m, m+1) 360/M (brdf_table.h).
                k = int(round(math.cos(math.radians(float(row["theta_o_deg"]))) * K - 0.5))
                m = int(round(float(row["phi_o_deg"]) * M / 360.0 - 0.5))
                self.value[side, k, m] = float(row["value"])
                self.stderr[side, k, m] = float(row["stderr"])
                self.single[side, k, m] = float(row["single"])
                self.multiple[side, k, m] = float(row["multiple"])
                seen[side, k, m] = True
        if not seen.all():
            fail(f"{csv_path}: table incomplete ({seen.sum()} of {seen.size} bins)")
        with open(json_path) as f:
            self.totals = json.load(f)
        self.cos_lo = np.arange(K) / K
        self.cos_hi = (np.arange(K) + 1) / K
        self.theta_deg = np.degrees(np.arccos((np.arange(K) + 0.5) / K))  # lamina's bin centres
        # Projected solid angle of one bin (brdf_table.h): (hi^2 - lo^2)/2 * 2 pi / M.
        self.proj = 0.5 * (self.cos_hi**2 - self.cos_lo**2) * 2.0 * math.pi / M

    def total(self, key):
        return self.totals[key][1], self.totals[key + "_stderr"][1]

    def integral(self, array, side):
        """sum over bins of array * projected solid angle: the power in that part."""
        return float((array[side] * self.proj[:, None]).sum())

    def plane(self, array, side, errors=False):
        """The plane of incidence: with M even, bins M-1 and 0 straddle phi = 0 and bins M/2-1 and
        M/2 straddle 180; the media here are symmetric under phi -> -phi, so the mean of each pair
        is the average over a wedge of +-360/M degrees centred on the plane. Returns (signed
        angle, values) over both halves, light's side negative."""
        M = self.M
        if errors:
            back = np.sqrt(array[side][:, M - 1]**2 + array[side][:, 0]**2) / 2
            fwd = np.sqrt(array[side][:, M // 2 - 1]**2 + array[side][:, M // 2]**2) / 2
        else:
            back = (array[side][:, M - 1] + array[side][:, 0]) / 2
            fwd = (array[side][:, M // 2 - 1] + array[side][:, M // 2]) / 2
        x = np.concatenate([-self.theta_deg, self.theta_deg[::-1]])
        return x, np.concatenate([back, fwd[::-1]])


class Lamina:
    """Runs `lamina brdf`. Each run costs about a second of program start-up (the dynamic loader
    resolving the image libraries) whatever its size, so independent runs go `jobs` at a time."""

    def __init__(self, exe, workdir, jobs):
        self.exe, self.workdir, self.jobs = exe, workdir, jobs
        self.runs, self.seconds = 0, 0.0

    def _run(self, index, stack, theta_i, method, K, M, samples=0, seed=1):
        base = os.path.join(self.workdir, f"run{index}")
        with open(base + ".json", "w") as f:
            json.dump(stack, f, indent=1)
        cmd = [self.exe, "brdf", base + ".json", "--theta-i", repr(theta_i), "--method", method,
               "--bins-theta", str(K), "--bins-phi", str(M), "--seed", str(seed),
               "--out", base + ".csv", "--summary", base + "_totals.json"]
        if method == "monte-carlo":
            cmd += ["--samples", str(samples)]
        start = time.time()
        done = subprocess.run(cmd, capture_output=True, text=True)
        seconds = time.time() - start
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
        return Table(base + ".csv", base + "_totals.json", K, M), seconds

    def brdf_many(self, specs):
        """specs: tuples of _run's arguments after index. Returns the tables in the same order."""
        first = self.runs
        self.runs += len(specs)
        with concurrent.futures.ThreadPoolExecutor(max_workers=self.jobs) as pool:
            futures = [pool.submit(self._run, first + i, *spec) for i, spec in enumerate(specs)]
            try:
                results = [f.result() for f in futures]
            except RuntimeError as e:
                fail(str(e))
        self.seconds += sum(r[1] for r in results)
        return [r[0] for r in results]

    def brdf(self, *spec):
        return self.brdf_many([spec])[0]


# ----------------------------------------------------------------------------------------------
# Lommel-Seeliger: an index-matched isotropic half-space of albedo W scatters once with
# f = W p / (mu_i + mu_o), p = 1/(4 pi) (docs/analytic_model.md; Hanrahan-Krueger eq. for the
# semi-infinite first order with the Fresnel factors equal to 1).

def lommel_seeliger(W, mu_i, mu_o):
    return W / (4.0 * math.pi) / (mu_i + mu_o)


def lommel_seeliger_bins(W, mu_i, K, n=6):
    """The bin averages lamina's first-order table computes (brdf_table.cpp): weighted by
    projected solid angle, i.e. uniform in x = mu^2; n-point Gauss-Legendre in x on [lo^2, hi^2]
    (the law does not depend on phi, so the phi rule drops out)."""
    nodes, weights = np.polynomial.legendre.leggauss(n)
    out = np.zeros(K)
    for k in range(K):
        lo, hi = (k / K)**2, ((k + 1) / K)**2
        x = 0.5 * (hi - lo) * nodes + 0.5 * (hi + lo)
        out[k] = np.sum(0.5 * weights * lommel_seeliger(W, mu_i, np.sqrt(x)))
    return out


def ratio(a, b):
    return a / b if b != 0 else math.nan  # an empty bin (possible with --quick's few photons)


def single_vs_first_order(mc, fo, side):
    """z-scores of the Monte Carlo `single` column against the analytic first order, bin by bin.
    The CSV has the standard error of `value` only; a photon adds to one bin once, either as a
    single or a multiple exit, so per bin var(single) = var(value) * E[X_s^2] / E[X^2] up to the
    O(1/N) squared means; with exit weights of similar size E[X_s^2]/E[X^2] = single/value.
    Single exits carry larger weights (W against W^n), so this sigma is somewhat too small and
    chi2/bin comes out a little above 1 (1.2-1.8 here); an independent check with the standard
    error from 8 seeds gave chi2/bin 1.42 and 1.47, as expected for Student's t with 7 degrees
    of freedom (7/5 = 1.4), for the g = -0.3, tau = 2 slab (docs/validation.md)."""
    s, v, e, f = mc.single[side], mc.value[side], mc.stderr[side], fo.value[side]
    ok = (e > 0) & (s > 0)
    sigma = e[ok] * np.sqrt(s[ok] / v[ok])
    z = (s[ok] - f[ok]) / sigma
    return {"bins": int(ok.sum()), "chi2_per_bin": float(np.mean(z**2)),
            "max_abs_z": float(np.max(np.abs(z))) if z.size else 0.0,
            "mean_z": float(np.mean(z)) if z.size else 0.0}


# ----------------------------------------------------------------------------------------------

def figure1(lamina, args, numbers):
    """BRDF in the plane of incidence of an index-matched isotropic half-space, 45 deg incidence."""
    K, M, theta_i = 30, 72, 45.0
    mu_i = math.cos(math.radians(theta_i))
    samples = args.samples(4_000_000)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=False)
    albedos = (0.4, 0.8)
    tables = lamina.brdf_many([(slab(W, math.inf, 0.0), theta_i, method, K, M, samples)
                               for W in albedos for method in ("first-order", "monte-carlo")])
    for i, (ax, W) in enumerate(zip(axes, albedos)):
        fo, mc = tables[2 * i], tables[2 * i + 1]
        # The check: lamina's analytic first order IS Lommel-Seeliger here, bin by bin, every phi.
        ls = lommel_seeliger_bins(W, mu_i, K)
        rel = np.abs(fo.value[0] - ls[:, None]) / ls[:, None]
        if rel.max() > 1e-7 or np.abs(fo.value[1]).max() != 0.0:
            fail(f"first order != Lommel-Seeliger for W={W}: max relative difference {rel.max():.3g}")
        R_diff, R_diff_err = mc.total("R_diffuse")
        lambert = R_diff / math.pi  # a Lambert surface with the same directional-hemispherical albedo
        x, total = mc.plane(mc.value, 0)
        _, err = mc.plane(mc.stderr, 0, errors=True)
        _, single = mc.plane(mc.single, 0)
        _, multiple = mc.plane(mc.multiple, 0)
        _, first = fo.plane(fo.value, 0)
        grid = np.linspace(-89.5, 89.5, 359)
        ax.errorbar(x, total, yerr=err, fmt="o", ms=3, color="k", label="total (Monte Carlo)")
        ax.plot(x, first, "-", color="tab:blue", label="first order (analytic)")
        ax.plot(x, single, ".", ms=4, color="tab:cyan", label="single (Monte Carlo)")
        ax.plot(x, multiple, "s", ms=3, color="tab:red", label="multiple (Monte Carlo)")
        ax.plot(grid, [lommel_seeliger(W, mu_i, math.cos(math.radians(a))) for a in grid], "--",
                color="tab:green", lw=1, label="Lommel-Seeliger $W/4\\pi(\\mu_i+\\mu_o)$")
        ax.axhline(lambert, color="tab:orange", label=f"Lambert, same albedo ($R_d/\\pi$, $R_d$={R_diff:.3f})")
        ax.set_title(f"W = {W}")
        ax.set_xlabel("angle of reflection (deg); - light's side, + mirror side")
        ax.set_ylabel("BRDF (1/sr)")
        ax.set_xlim(-90, 90)
        ax.set_ylim(0, None)
        ax.grid(alpha=0.3)
        # Numbers: the ring nearest the normal (all phi; |cos| in [(K-1)/K, 1]) and the most
        # grazing bins of the plane of incidence.
        ring_total = mc.value[0, K - 1].mean()
        ring_multiple = mc.multiple[0, K - 1].mean()
        check = single_vs_first_order(mc, fo, 0)
        numbers[f"fig1_W{W}"] = {
            "samples": samples, "R_diffuse": R_diff, "R_diffuse_stderr": R_diff_err,
            "R_diffuse_first_order": fo.total("R_diffuse")[0],
            "lambert_brdf": lambert,
            "near_normal_theta_max_deg": math.degrees(math.acos((K - 1) / K)),
            "near_normal_total": ring_total, "near_normal_multiple_fraction": ring_multiple / ring_total,
            "grazing_theta_deg": float(mc.theta_deg[0]),
            "grazing_back_total": float(total[0]), "grazing_mirror_total": float(total[-1]),
            "lambert_over_grazing_back": ratio(lambert, total[0]) - 1.0,
            "lambert_over_grazing_mirror": ratio(lambert, total[-1]) - 1.0,
            "theta60_back_total": float(np.interp(-60, x, total)),
            "lambert_over_theta60_back": lambert / float(np.interp(-60, x, total)) - 1.0,
            "single_vs_first_order": check,
            "lommel_seeliger_max_rel_diff": float(rel.max()),
        }
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Index-matched isotropic half-space, {theta_i:.0f}$^\\circ$ incidence, plane of incidence "
                 f"(wedges of $\\pm${360 / M:.0f}$^\\circ$ in $\\phi_o$, {K} bins in $\\cos\\theta_o$, "
                 f"{samples:.0e} photons)", fontsize=9)
    fig.tight_layout()
    return fig


def figure2(lamina, args, numbers):
    """First-order BRDF and BTDF of index-matched slabs for g x tau."""
    K, M, theta_i, W = (20, 8, 45.0, 0.9) if args.quick else (60, 72, 45.0, 0.9)
    gs, taus = (-0.3, 0.0, 0.6), (0.5, 1.0, 2.0)
    fig, axes = plt.subplots(3, 3, figsize=(11, 9), sharex=True)
    checks = () if args.quick else ((0.6, 1.0), (-0.3, 2.0))
    Kc, Mc = 10, 12
    tables = lamina.brdf_many([(slab(W, tau, g), theta_i, "first-order", K, M) for g in gs for tau in taus] +
                              [(slab(W, tau, g), theta_i, method, Kc, Mc, args.samples(400_000))
                               for g, tau in checks for method in ("first-order", "monte-carlo")])
    for i, g in enumerate(gs):
        for j, tau in enumerate(taus):
            ax = axes[i, j]
            fo = tables[3 * i + j]
            x, fr = fo.plane(fo.value, 0)
            _, ft = fo.plane(fo.value, 1)
            ax.plot(x, fr, "-", color="tab:blue", label="reflection (BRDF)")
            ax.plot(x, ft, "-", color="tab:red", label="transmission (BTDF)")
            ax.set_yscale("log")
            ax.set_ylim(1e-3, 3)
            ax.grid(alpha=0.3)
            R1, T1 = fo.total("R_diffuse")[0], fo.total("T_diffuse")[0]
            ax.text(0.03, 0.05, f"$R_1$={R1:.3f}  $T_1$={T1:.3f}", transform=ax.transAxes, fontsize=8)
            ax.set_title(f"g = {g:+.1f}, $\\tau$ = {tau}", fontsize=9)
            if j == 0:
                ax.set_ylabel("first-order f (1/sr)")
            numbers[f"fig2_g{g}_tau{tau}"] = {"R1": R1, "T1": T1}
    axes[0, 0].legend(fontsize=7, loc="upper right")
    fig.supxlabel("exit angle in the plane of incidence (deg): - light's side, + mirror side (BRDF) "
                  "or forward side (BTDF)", fontsize=9)
    # Sanity check: the Monte Carlo single-scattering part against the analytic first order for
    # two anisotropic slabs (a bug in either would show as |z| >> 1).
    for c, (g, tau) in enumerate(checks):
        fo, mc = tables[9 + 2 * c], tables[10 + 2 * c]
        numbers[f"fig2_check_g{g}_tau{tau}"] = {
            "reflect": single_vs_first_order(mc, fo, 0), "transmit": single_vs_first_order(mc, fo, 1),
            "R1_first_order": fo.total("R_diffuse")[0], "R1_monte_carlo": mc.integral(mc.single, 0),
            "T1_first_order": fo.total("T_diffuse")[0], "T1_monte_carlo": mc.integral(mc.single, 1)}
    fig.suptitle(f"First order, index-matched slabs (n = 1), albedo W = {W}, {theta_i:.0f}$^\\circ$ incidence, "
                 f"plane of incidence; rows g, columns optical depth $\\tau = \\sigma_t d$", fontsize=10)
    fig.tight_layout()
    return fig


def polar_curve(ax, table, side, scale=1.0, **kw):
    """Plane-of-incidence values on a polar axis (0 = the normal, clockwise): reflection in the
    upper half (light's side left), transmission in the lower half (forward side right)."""
    x, v = table.plane(table.value, side)
    a = np.radians(x) if side == 0 else np.radians(180.0 - x)
    order = np.argsort(a)
    ax.plot(a[order], v[order] * scale, **kw)


def figure3(lamina, args, numbers):
    """A leaf-like slab with index mismatch at 10, 40 and 65 deg incidence."""
    K, M = 20, 36
    ior, tau, W, g = 1.5, 2.0, 0.97, 0.3
    stack = slab(W, tau, g, ior=ior, below_ior=1.0, sigma_t=20.0)  # 0.1 mm at sigma_t = 20/mm
    samples = args.samples(1_000_000)
    fig, axes = plt.subplots(3, 3, figsize=(11, 11), subplot_kw={"projection": "polar"})
    angles = (10.0, 40.0, 65.0)
    tables = lamina.brdf_many([(stack, theta_i, "monte-carlo", K, M, samples) for theta_i in angles])
    for row, (theta_i, mc) in enumerate(zip(angles, tables)):
        Rs, Tb = mc.total("R_specular")[0], mc.total("T_ballistic")[0]
        Rd, Td = mc.total("R_diffuse")[0], mc.total("T_diffuse")[0]
        # T_ballistic leaves along the incident direction (same media above and below).
        # Radial scale from the bins below 80 deg (the grazing bins have tiny projected solid
        # angles, hence the largest noise).
        keep = np.abs(mc.plane(mc.value, 0)[0]) < 80
        rmax = 1.15 * max(mc.plane(mc.value, 0)[1][keep].max(), mc.plane(mc.value, 1)[1][keep].max(), 1e-6)
        for ax in axes[row]:
            ax.set_theta_zero_location("N")
            ax.set_theta_direction(-1)
            ax.plot([-math.radians(theta_i)] * 2, [0, rmax], ":", color="gold", lw=2)  # the light
            ax.set_rlim(0, rmax)
            ax.tick_params(labelsize=6)
            # Angles from the normal of the hemisphere they are in.
            ax.set_xticks(np.radians(np.arange(0, 360, 45)))
            ax.set_xticklabels(["0", "45", "90", "45", "0", "45", "90", "45"])
        # Left: the delta parts (length = fraction of the incident power, own radial scale).
        ax = axes[row, 0]
        dmax = 1.2 * max(Rs, Tb)
        ax.set_rlim(0, dmax)
        ax.plot([-math.radians(theta_i)] * 2, [0, dmax], ":", color="gold", lw=2)
        ax.plot([math.radians(theta_i)] * 2, [0, Rs], "-", color="tab:purple", lw=3)
        ax.plot([math.radians(180 - theta_i)] * 2, [0, Tb], "-", color="tab:gray", lw=3)
        ax.set_title(f"$\\theta_i$={theta_i:.0f}$^\\circ$: delta parts (fraction of the incident power)\n"
                     f"$R_s$={Rs:.3f} (purple), $T_{{ball}}$={Tb:.3f} (grey)", fontsize=8)
        # Middle: subsurface reflection and transmission.
        ax = axes[row, 1]
        polar_curve(ax, mc, 0, color="tab:blue")
        polar_curve(ax, mc, 1, color="tab:red")
        ax.set_title(f"subsurface (1/sr): $R_d$={Rd:.3f}, $T_d$={Td:.3f}", fontsize=8)
        # Right: the sum, the delta parts as spikes to the rim (they are not finite values).
        ax = axes[row, 2]
        polar_curve(ax, mc, 0, color="k")
        polar_curve(ax, mc, 1, color="k")
        ax.plot([math.radians(theta_i)] * 2, [0, rmax], "-", color="tab:purple", lw=2)
        ax.plot([math.radians(180 - theta_i)] * 2, [0, rmax], "-", color="tab:gray", lw=2)
        ax.set_title(f"sum: R = {Rs + Rd:.3f}, T = {Tb + Td:.3f}\n(spikes: delta parts)", fontsize=8)
        ax_r = mc.plane(mc.value, 0)
        numbers[f"fig3_theta{theta_i:.0f}"] = {
            "samples": samples, "R_specular": Rs, "T_ballistic": Tb, "R_diffuse": Rd, "T_diffuse": Td,
            "absorbed": mc.total("absorbed")[0],
            "brdf_max": float(ax_r[1].max()), "brdf_max_at_deg": float(ax_r[0][np.argmax(ax_r[1])]),
            "btdf_max": float(mc.plane(mc.value, 1)[1].max())}
    fig.suptitle(f"Slab n = {ior} in air, optical depth {tau}, albedo {W}, g = {g} ({samples:.0e} photons per "
                 f"angle); plane of incidence, light (dotted) from the upper left", fontsize=10)
    fig.tight_layout()
    return fig


def figure4(lamina, args, numbers):
    """Fraction of the diffuse reflection and transmission due to single scattering."""
    K, M, theta_i = 10, 1, 45.0
    albedos = (0.8,) if args.quick else (0.2, 0.5, 0.8, 0.95, 0.99)
    # (label, medium, side): the slab's run gives both its R and T.
    cases = [("half-space, R", "inf", 0), ("slab $\\tau$=1, R", "slab", 0), ("slab $\\tau$=1, T", "slab", 1)]
    samples = args.samples(200_000)
    media = (("inf", math.inf), ("slab", 1.0))
    tables = lamina.brdf_many([(slab(W, tau, 0.0), theta_i, method, K, M, samples)
                               for _, tau in media for W in albedos for method in ("monte-carlo", "first-order")])
    runs = {}
    for i, ((medium, _), W) in enumerate((m, W) for m in media for W in albedos):
        runs[medium, W] = (tables[2 * i], tables[2 * i + 1])
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for (label, medium, side), colour in zip(cases, ("tab:blue", "tab:green", "tab:red")):
        fractions, analytic = [], []
        for W in albedos:
            mc, fo = runs[medium, W]
            key = "R_diffuse" if side == 0 else "T_diffuse"
            total = mc.total(key)[0]
            fractions.append(mc.integral(mc.single, side) / total)
            analytic.append(fo.total(key)[0] / total)
            numbers[f"fig4_{medium}_{key}_W{W}"] = {
                "total": total, "total_stderr": mc.total(key)[1], "single_mc": mc.integral(mc.single, side),
                "first_order": fo.total(key)[0],
                "single_fraction_mc": fractions[-1], "first_order_over_total": analytic[-1]}
        ax.plot(albedos, fractions, "o", color=colour, label=label + " (Monte Carlo single)")
        ax.plot(albedos, analytic, "-", color=colour, lw=1, label=label + " (first order / total)")
    ax.set_xlabel("single-scattering albedo W")
    ax.set_ylabel("fraction of the diffuse part from single scattering")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"Isotropic, index-matched, {theta_i:.0f}$^\\circ$ incidence ({samples:.0e} photons)", fontsize=9)
    fig.tight_layout()
    return fig


def shrink_png(path):
    """Re-saves a PNG with a 256-colour palette (plots have few colours): a third of the size."""
    try:
        from PIL import Image
    except ImportError:
        return
    with Image.open(path) as image:
        small = image.convert("RGB").quantize(colors=256)
    small.save(path, optimize=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lamina", default=os.path.join(ROOT, "build", "renderer", "lamina"),
                        help="the lamina program (default build/renderer/lamina)")
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "figures"), help="output directory")
    parser.add_argument("--quick", action="store_true",
                        help="few photons: checks the pipeline end to end (noisy figures)")
    parser.add_argument("--jobs", type=int, default=2, help="lamina runs at a time (default 2)")
    args = parser.parse_args()
    args.samples = (lambda n: max(2000, n // 100)) if args.quick else (lambda n: n)
    if not os.access(args.lamina, os.X_OK):
        fail(f"{args.lamina}: not an executable (build it, or pass --lamina)")
    os.makedirs(args.out, exist_ok=True)
    numbers = {}
    start = time.time()
    with tempfile.TemporaryDirectory(prefix="lamina_figures_") as work:
        lamina = Lamina(args.lamina, work, args.jobs)
        for name, make in (("fig1_semi_infinite", figure1), ("fig2_first_order", figure2),
                           ("fig3_incidence", figure3), ("fig4_single_multiple", figure4)):
            t0 = time.time()
            fig = make(lamina, args, numbers)
            path = os.path.join(args.out, name + ".png")
            fig.savefig(path, dpi=80 if args.quick else 90)
            plt.close(fig)
            shrink_png(path)
            if not os.path.getsize(path) > 0:
                fail(f"{path}: empty")
            print(f"{path} ({time.time() - t0:.1f} s)")
        numbers["lamina_runs"] = lamina.runs
        numbers["lamina_seconds"] = lamina.seconds
    numbers["seconds"] = time.time() - start
    with open(os.path.join(args.out, "numbers.json"), "w") as f:
        json.dump(numbers, f, indent=1)
    print(f"{os.path.join(args.out, 'numbers.json')}: {lamina.runs} lamina runs, {numbers['seconds']:.1f} s")


if __name__ == "__main__":
    main()
