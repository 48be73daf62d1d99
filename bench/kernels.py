#!/usr/bin/env python3
"""Specialised against generic kernels (issue 19): for every project scene and integrator,
`candela render --kernels specialized|generic --json` at one film size and time budget, each in a
fresh process with an empty driver shader cache (so `kernel_s` is a cold compile) and after an
untimed warm-up (`--warmup`: a long cold compile lets the GPU idle down, and the first fraction of
a second then runs at low clocks). Prints a markdown table: Msamples/s of each, their
ratio, kernel build seconds of each, and the driver's statistics of the pass kernel where it
reports them (VK_KHR_pipeline_executable_properties, e.g. NVIDIA's register count), plus the
number of distinct kernel variants the scenes need. Writes every report as JSON lines to
OUT/kernels.jsonl.

    python3 bench/kernels.py --candela .carry/candela --out $OUT [--time 1] [--width 1280 --height 720]
"""
import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile

INTEGRATORS = ["pt", "nee", "bdpt", "whitted", "deferred", "vct"]


def render(args, scene, integrator, kernels):
    cmd = [args.candela, "render", scene, "-o", "/tmp/kernels.exr", "--integrator", integrator,
           "--kernels", kernels, "--time", str(args.time), "--width", str(args.width),
           "--height", str(args.height), "--warmup", str(args.warmup), "--no-accel-cache", "--json"]
    # Every run compiles cold: a fresh, empty NVIDIA driver shader cache.
    env = dict(os.environ, __GL_SHADER_DISK_CACHE_PATH=tempfile.mkdtemp(prefix="nvcache"))
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        print(f"FAILED {' '.join(cmd)}: {r.stderr.strip()}", file=sys.stderr)
        return None
    return json.loads(r.stdout)


def register_count(report):
    """The driver's register statistic of the pass kernel, if it reports one."""
    for name, value in (report.get("kernel_stats") or {}).items():
        if "register" in name.lower():
            return int(value)
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--candela", default=".carry/candela")
    ap.add_argument("--out", default=os.environ.get("OUT", "/tmp"))
    ap.add_argument("--time", type=float, default=1.0)
    ap.add_argument("--warmup", type=float, default=0.5,
                    help="untimed seconds first (GPU clocks ramp up after a cold compile)")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--scenes", default="scenes/*.json")
    ap.add_argument("--integrators", default=",".join(INTEGRATORS))
    args = ap.parse_args()
    scenes = sorted(glob.glob(args.scenes))
    rows = []
    variants = set()
    with open(os.path.join(args.out, "kernels.jsonl"), "w") as log:
        for scene in scenes:
            for integ in args.integrators.split(","):
                pair = {}
                for mode in ("specialized", "generic"):
                    rep = render(args, scene, integ, mode)
                    if rep is None:
                        break
                    rep["scene"] = scene
                    log.write(json.dumps(rep) + "\n")
                    log.flush()
                    pair[mode] = rep
                if len(pair) < 2:
                    continue
                s, g = pair["specialized"], pair["generic"]
                variants.add((integ, tuple(s["features"])))
                rows.append((os.path.basename(scene), integ, s, g))
                print(f"{os.path.basename(scene)} {integ}: {s['msamples_per_s']:.1f} vs "
                      f"{g['msamples_per_s']:.1f} Msamples/s", file=sys.stderr, flush=True)
    print("| scene | integrator | features | Msamples/s specialised | generic | ratio | "
          "kernel s specialised | generic | registers specialised | generic |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, integ, s, g in rows:
        ratio = s["msamples_per_s"] / g["msamples_per_s"] if g["msamples_per_s"] > 0 else float("nan")
        rs, rg = register_count(s), register_count(g)
        print(f"| {name} | {integ} | {', '.join(s['features'])} | {s['msamples_per_s']:.1f} | "
              f"{g['msamples_per_s']:.1f} | {ratio:.2f} | {s['kernel_s']:.2f} | {g['kernel_s']:.2f} | "
              f"{rs if rs is not None else '-'} | {rg if rg is not None else '-'} |")
    print(f"\n{len(variants)} distinct specialised pass-kernel variants over {len(scenes)} scenes "
          f"and {len(args.integrators.split(','))} integrators (generic: one per integrator).")


if __name__ == "__main__":
    main()
