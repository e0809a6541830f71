#!/usr/bin/env python3
"""Runs a `lamina batch` on a Ray cluster: one Ray task per shard, then the finalize step.

    python3 scripts/batch_ray.py MANIFEST.json --out DIR [--shards N] [--address ADDR]
                                 [--lamina PATH] [--cpus-per-shard C]

Each task runs `lamina batch MANIFEST --out DIR --shard i/N --threads C` (the shards split the
job list deterministically: job k goes to shard k mod N); when every shard has succeeded the
driver runs `lamina batch MANIFEST --out DIR --finalize` for the comparisons, the contact sheet
and the summary. Jobs are resumable, so rerunning after a failure redoes only what is missing.

Without --address Ray starts a local cluster in this process (ray.init()). For several
machines: `ray start --head` on one, `ray start --address HEAD:6379` on the others, then run
this script with --address HEAD:6379 (or --address auto on a cluster node). Every node needs
the `lamina` binary at the same path and the manifest, its scenes and DIR on a shared file
system (NFS or similar) at the same paths. See docs/batch.md.
"""
import argparse
import os
import subprocess
import sys


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("manifest", help="batch manifest (JSON)")
    p.add_argument("--out", required=True, help="output directory (on a file system every node sees)")
    p.add_argument("--shards", type=int, default=0, help="number of shards (default: the cluster's CPUs / --cpus-per-shard)")
    p.add_argument("--address", default=None, help="Ray cluster address (HEAD:6379 or 'auto'); default: a local cluster")
    p.add_argument("--lamina", default=None, help="path of the lamina binary (default: build/renderer/lamina beside this script)")
    p.add_argument("--cpus-per-shard", type=int, default=1, help="CPUs each shard reserves and renders with (default 1)")
    p.add_argument("--num-cpus", type=int, default=None, help="CPUs of the local cluster (ignored with --address)")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    here = os.path.dirname(os.path.abspath(__file__))
    lamina = os.path.abspath(args.lamina or os.path.join(here, "..", "build", "renderer", "lamina"))
    manifest = os.path.abspath(args.manifest)
    out = os.path.abspath(args.out)
    if not os.access(lamina, os.X_OK):
        sys.exit(f"batch_ray: {lamina}: no lamina binary (build it, or pass --lamina)")
    if not os.path.isfile(manifest):
        sys.exit(f"batch_ray: {manifest}: no such manifest")
    if args.cpus_per_shard < 1:
        sys.exit("batch_ray: --cpus-per-shard must be at least 1")

    # Validate the manifest before starting anything (the same errors `lamina batch` gives).
    check = subprocess.run([lamina, "batch", manifest, "--out", out, "--list"], capture_output=True, text=True)
    if check.returncode != 0:
        sys.exit(check.stderr.strip() or f"batch_ray: lamina batch --list failed ({check.returncode})")
    job_count = len(check.stdout.splitlines())

    import ray  # imported late so --help and bad input need no Ray

    if args.address:
        ray.init(address=args.address)
    else:
        ray.init(num_cpus=args.num_cpus, include_dashboard=False)
    try:
        cpus = int(ray.cluster_resources().get("CPU", 1))
        shards = args.shards or max(1, cpus // args.cpus_per_shard)
        shards = max(1, min(shards, job_count))
        print(f"batch_ray: {job_count} jobs in {shards} shards on {cpus} CPUs", flush=True)

        @ray.remote(num_cpus=args.cpus_per_shard)
        def run_shard(i):
            r = subprocess.run([lamina, "batch", manifest, "--out", out, "--shard", f"{i}/{shards}",
                                "--threads", str(args.cpus_per_shard)], capture_output=True, text=True)
            return i, r.returncode, r.stdout, r.stderr

        failed = []
        for i, code, stdout, stderr in ray.get([run_shard.remote(i) for i in range(shards)]):
            summary = [line for line in stdout.splitlines() if "rendered" in line]
            print(f"batch_ray: shard {i}/{shards}: " + (summary[-1] if summary else f"exit {code}"), flush=True)
            if code != 0:
                failed.append(i)
                sys.stderr.write(stderr)
        if failed:
            sys.exit(f"batch_ray: shards {failed} failed; rerun to retry their missing jobs")
    finally:
        ray.shutdown()

    final = subprocess.run([lamina, "batch", manifest, "--out", out, "--finalize"])
    return final.returncode


if __name__ == "__main__":
    sys.exit(main())
