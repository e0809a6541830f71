#!/usr/bin/env python3
"""The speed-accuracy report: error against seconds for every --subsurface mode.

    scripts/tradeoff.sh [--quick] [--lamina build/renderer/lamina] [--out out/tradeoff]

For each scene (the skin sphere, the head with skin, the back-lit leaf) and each mode
(random-walk, first-order, table, lambert) it runs `lamina render` at increasing spp at a tiny
resolution, and `lamina compare REF TEST --json` against a high-sample random-walk reference of
the same scene (rendered once and kept in OUT/ref-*.exr; its file name carries its settings, so a
change of resolution or spp makes a new one). Python does no image maths: RMSE and the RMS
relative difference are read from compare's JSON, seconds from the EXR header (lamina:seconds,
the render only) plus, for table and lambert, the precompute printed by that very run (each run
builds its own tables/albedos; nothing is cached between runs, so every row is the honest cost of
producing that image from nothing but the scene).

Writes OUT/tradeoff.csv (scene,mode,spp,seconds,rmse,rel_rms,render_seconds,precompute_seconds),
OUT/tradeoff.png (one log-log panel per scene, one curve per mode) and OUT/tradeoff.log.
Exits non-zero if a render fails, a scene x mode x spp row is missing or a value is not finite.
"""

import argparse
import json
import math
import os
import re
import struct
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODES = ["random-walk", "first-order", "table", "lambert"]

# name -> (glTF, extra render arguments, width, height)
SCENES = {
    "spheres": ("scenes/spheres/spheres_45.gltf", ["--camera", "front"], 32, 32),
    "head": ("scenes/lee_perry_smith_head/head_lit.gltf",
             ["--materials", "scenes/lee_perry_smith_head/skin_map.json", "--camera", "portrait",
              "--env", "0.1"], 24, 30),
    "leaf": ("scenes/leaf/leaf_quad.gltf",
             ["--materials", "scenes/leaf/leaf_map.json", "--camera", "back", "--env", "0.02"],
             32, 32),
}


def package_plot():
    """The Python package's figures (python/lamina/plot.py), loaded from the source tree: they
    need numpy and matplotlib, not the package's compiled module."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("lamina_plot", os.path.join(ROOT, "python/lamina/plot.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def fail(message):
    print(f"tradeoff.py: {message}", file=sys.stderr)
    sys.exit(1)


def exr_attributes(path):
    """The scalar and string attributes of an OpenEXR header (OpenEXR file layout: magic 20000630,
    version int, then name\\0 type\\0 int32 size, value; an empty name ends the header)."""
    with open(path, "rb") as f:
        data = f.read(1 << 16)
    if struct.unpack_from("<i", data, 0)[0] != 20000630:
        fail(f"{path}: not an OpenEXR file")
    pos, attrs = 8, {}
    while True:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        if not name:
            return attrs
        tend = data.index(b"\0", end + 1)
        kind = data[end + 1:tend].decode()
        size = struct.unpack_from("<i", data, tend + 1)[0]
        raw = data[tend + 5:tend + 5 + size]
        if kind == "float":
            attrs[name] = struct.unpack("<f", raw)[0]
        elif kind == "double":
            attrs[name] = struct.unpack("<d", raw)[0]
        elif kind == "int":
            attrs[name] = struct.unpack("<i", raw)[0]
        elif kind == "string":
            attrs[name] = raw.decode(errors="replace")
        pos = tend + 5 + size


def render(args, scene, mode, spp, seed, out_exr):
    gltf, extra, w, h = SCENES[scene]
    cmd = [args.lamina, "render", gltf, *extra, "--width", str(w), "--height", str(h),
           "--spp", str(spp), "--seed", str(seed), "--subsurface", mode,
           "--threads", str(args.threads), "-o", out_exr]
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"{' '.join(cmd)} failed: {p.stderr.strip() or p.stdout.strip()}")
    precompute = 0.0
    found = False  # the precompute line (its time may print as 0.00 s: adding-doubling is fast)
    m = re.search(r"table mode: .* built in ([0-9.]+) s", p.stdout)
    if m:
        precompute += float(m.group(1))
        found = True
    m = re.search(r"lambert mode: albedos by .* in ([0-9.]+) s", p.stdout)
    if m:
        precompute += float(m.group(1))
        found = True
    if mode in ("table", "lambert") and not found:
        fail(f"{scene} {mode}: no precompute time in the output of lamina render:\n{p.stdout}")
    attrs = exr_attributes(out_exr)
    if "lamina:seconds" not in attrs:
        fail(f"{out_exr}: no lamina:seconds in the header")
    return float(attrs["lamina:seconds"]), precompute, p.stdout


def compare(args, ref, test, json_path):
    cmd = [args.lamina, "compare", ref, test, "--json", json_path]
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"{' '.join(cmd)} failed: {p.stderr.strip()}")
    with open(json_path) as f:
        j = json.load(f)
    return j["rmse"], j["rms_relative"]


def time_to(rows, target):
    """Seconds at which the measured curve first reaches RMSE <= target, interpolated linearly in
    log-log between the two measured points around it; None if it never does."""
    for a, b in zip([None] + rows[:-1], rows):
        if b["rmse"] <= target:
            if a is None:
                return b["seconds"], "<="
            la, lb = math.log(a["rmse"]), math.log(b["rmse"])
            t = (math.log(target) - la) / (lb - la) if lb != la else 1.0
            return math.exp(math.log(a["seconds"]) + t * (math.log(b["seconds"]) - math.log(a["seconds"]))), "~"
    return None, ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lamina", default=os.path.join(ROOT, "build/renderer/lamina"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out/tradeoff"))
    ap.add_argument("--quick", action="store_true",
                    help="pipeline check: 8x8 pixels, spp 1 and 2 (table 1), reference 8 spp, spheres only")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--spp", default="1,4,16,64", help="spp of random-walk, first-order, lambert")
    ap.add_argument("--table-spp", default="4,64",
                    help="spp of table (each run rebuilds the tables, ~50-100 s)")
    ap.add_argument("--ref-spp", type=int, default=512)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--replot", action="store_true",
                    help="no rendering: the summary and plot from OUT/tradeoff.csv")
    ap.add_argument("--targets", default="0.05,0.02", help="RMSE targets for the log's table")
    args = ap.parse_args()
    args.lamina = os.path.abspath(args.lamina)
    args.out = os.path.abspath(args.out)
    scenes = args.scenes.split(",")
    for s in scenes:
        if s not in SCENES:
            fail(f"unknown scene {s!r} (known: {', '.join(SCENES)})")
    spps = {m: [int(x) for x in args.spp.split(",")] for m in MODES}
    spps["table"] = [int(x) for x in args.table_spp.split(",")]
    if args.quick:
        for s in SCENES:
            g, e, _, _ = SCENES[s]
            SCENES[s] = (g, e, 8, 8)
        scenes = ["spheres"] if args.scenes == ",".join(SCENES) else scenes
        spps = {m: [1, 2] for m in MODES}
        spps["table"] = [1]  # each table run rebuilds the tables (~45 s on 2 loaded cores)
        args.ref_spp = 8
    if not os.access(args.lamina, os.X_OK):
        fail(f"{args.lamina}: no lamina executable (build it, or pass --lamina)")
    os.makedirs(os.path.join(args.out, "runs"), exist_ok=True)
    log = open(os.path.join(args.out, "tradeoff.log"), "a" if args.replot else "w")

    def say(text):
        print(text)
        log.write(text + "\n")
        log.flush()

    rows = []
    refs = {}
    if args.replot:
        with open(os.path.join(args.out, "tradeoff.csv")) as f:
            head = f.readline().strip().split(",")
            for line in f:
                v = dict(zip(head, line.strip().split(",")))
                rows.append({k: (v[k] if k in ("scene", "mode") else
                                 int(v[k]) if k == "spp" else float(v[k])) for k in head})
        scenes = [s for s in scenes if any(r["scene"] == s for r in rows)]
        spps = {m: sorted({r["spp"] for r in rows if r["mode"] == m}) for m in MODES}
    for scene in ([] if args.replot else scenes):
        _, _, w, h = SCENES[scene]
        ref = os.path.join(args.out, f"ref-{scene}-{w}x{h}-{args.ref_spp}spp.exr")
        if not os.path.exists(ref):
            say(f"{scene}: rendering the reference, random-walk {args.ref_spp} spp at {w}x{h} ...")
            secs, _, _ = render(args, scene, "random-walk", args.ref_spp, 1000, ref + ".tmp.exr")
            os.replace(ref + ".tmp.exr", ref)
        refs[scene] = ref
        say(f"{scene}: reference {os.path.basename(ref)} ({float(exr_attributes(ref)['lamina:seconds']):.1f} s)")
        for mode in MODES:
            for spp in spps[mode]:
                exr = os.path.join(args.out, "runs", f"{scene}-{mode}-{spp}.exr")
                t0 = time.time()
                render_s, pre_s, _ = render(args, scene, mode, spp, 1, exr)
                rmse, rel = compare(args, ref, exr, exr[:-4] + ".json")
                row = dict(scene=scene, mode=mode, spp=spp, seconds=render_s + pre_s, rmse=rmse,
                           rel_rms=rel, render_seconds=render_s, precompute_seconds=pre_s)
                rows.append(row)
                say(f"{scene:8s} {mode:12s} {spp:5d} spp: {row['seconds']:8.3f} s "
                    f"(render {render_s:.3f} + precompute {pre_s:.2f}), RMSE {rmse:.4f}, "
                    f"rel RMS {rel:.3f}   [wall {time.time() - t0:.1f} s]")

    cols = ["scene", "mode", "spp", "seconds", "rmse", "rel_rms", "render_seconds",
            "precompute_seconds"]
    with open(os.path.join(args.out, "tradeoff.csv"), "w") as f:
        f.write(",".join(cols) + "\n")
        for r in rows:
            f.write(",".join(str(r[c]) if isinstance(r[c], (str, int)) else f"{r[c]:.6g}"
                             for c in cols) + "\n")

    # Check the CSV as written: every scene x mode x spp row, finite values.
    with open(os.path.join(args.out, "tradeoff.csv")) as f:
        lines = f.read().splitlines()
    if lines[0] != ",".join(cols):
        fail("tradeoff.csv: wrong header")
    seen = set()
    for line in lines[1:]:
        v = line.split(",")
        for x in v[3:]:
            if not math.isfinite(float(x)) or float(x) < 0:
                fail(f"tradeoff.csv: not a finite non-negative value in {line!r}")
        seen.add((v[0], v[1], int(v[2])))
    want = {(s, m, n) for s in scenes for m in MODES for n in spps[m]}
    if seen != want or len(lines) - 1 != len(want):
        fail(f"tradeoff.csv: rows missing {sorted(want - seen)} or extra {sorted(seen - want)}")

    # Summary: reference noise, floors, time to the targets.
    targets = [float(x) for x in args.targets.split(",")]
    ref_noise = {}
    for scene in scenes:
        rw = [r for r in rows if r["scene"] == scene and r["mode"] == "random-walk"]
        last = rw[-1]
        # E[RMSE^2] of an s-spp walk against an N-spp walk = sigma^2 (1/s + 1/N), sigma^2 the
        # per-sample pixel variance averaged over pixels; the reference's own noise is sigma/sqrt(N).
        sigma2 = last["rmse"] ** 2 / (1.0 / last["spp"] + 1.0 / args.ref_spp)
        ref_noise[scene] = math.sqrt(sigma2 / args.ref_spp)
        say(f"{scene}: reference noise (RMSE of the {args.ref_spp}-spp reference itself, from the "
            f"{last['spp']}-spp walk) ~ {ref_noise[scene]:.4f}")
        for t in targets:
            # Against a noiseless reference the walk reaches RMSE t at spp = sigma^2 / t^2; its
            # time scales with spp (the measured seconds per sample of the largest run).
            n = sigma2 / t ** 2
            say(f"  random-walk extrapolated (1/sqrt(spp), noiseless reference): RMSE {t} at "
                f"~{n:.0f} spp, ~{last['seconds'] / last['spp'] * n:.3g} s")
        for mode in MODES:
            mr = sorted([r for r in rows if r["scene"] == scene and r["mode"] == mode],
                        key=lambda r: r["spp"])
            parts = []
            for t in targets:
                sec, how = time_to(mr, t)
                parts.append(f"to RMSE {t}: " + (f"{how}{sec:.3g} s" if sec is not None else "never (measured)"))
            say(f"  {mode:12s} lowest RMSE {min(r['rmse'] for r in mr):.4f}; "
                f"precompute {mr[0]['precompute_seconds']:.2f} s; " + "; ".join(parts))

    panels = [(scene, f"{scene} ({SCENES[scene][2]}x{SCENES[scene][3]}, ref. random-walk {args.ref_spp} spp)",
               ref_noise[scene]) for scene in scenes]
    fig = package_plot().tradeoff(rows, panels, MODES)
    png = os.path.join(args.out, "tradeoff.png")
    fig.savefig(png, dpi=90)
    say(f"tradeoff.py: wrote {os.path.join(args.out, 'tradeoff.csv')}, {png} "
        f"({len(rows)} rows)")


if __name__ == "__main__":
    main()
