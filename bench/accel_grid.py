#!/usr/bin/env python3
"""Grid and CWBVH vs BVH: times one integrator with the BVH, the compressed 8-wide BVH (`--accels`)
and uniform grids of several resolutions on a few scenes, using the built `candela` binary (`candela render --json`). No network.

For every scene and acceleration structure it renders `--repeats` times (seeds 1, 2, ...) with
`--no-accel-cache` (so the build is timed too), keeps the median of the render time, GPU time and
rays/s, and records the structure's build time, size and grid resolution from the JSON report.
One more run per configuration with a fresh cache directory, twice, records the cache-hit load
time. Writes OUT/results.csv (one row per run) and OUT/summary.md (a markdown table of medians).

usage:
  python3 bench/accel_grid.py [--candela target/release/candela] [--integrator whitted]
      [--scenes scenes/cornell.json,big] [--big-triangles 1000000]
      [--accels cwbvh] [--grids auto,16,32,64,128,256] [--spp 64] [--width 512 --height 512]
      [--repeats 3] [--out bench-out/accel_grid]

`big` in --scenes stands for a Cornell box holding a tessellated bumpy sphere of --big-triangles
triangles, generated with bench/make_big_scene.py into OUT/big/. The integrator defaults to
`whitted` when this candela has it, else `nee`.
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find_candela(path):
    if path:
        return path
    for profile in ("release", "debug"):
        p = os.path.join(ROOT, "target", profile, "candela")
        if os.path.exists(p):
            return p
    sys.exit("accel_grid.py: no candela binary; build it (cargo build --release -p candela-server) or pass --candela")


def render(candela, scene, out_dir, args, extra, spp=None):
    img = os.path.join(out_dir, "img.exr")
    cmd = [candela, "render", scene, "-o", img, "--json", "--integrator", args.integrator,
           "--spp", str(spp or args.spp), "--width", str(args.width), "--height", str(args.height)] + extra
    if args.device:
        cmd += ["--device", args.device]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()}")
    return json.loads(p.stdout)


def has_integrator(candela, name):
    with tempfile.TemporaryDirectory() as d:
        p = subprocess.run([candela, "render", os.path.join(ROOT, "scenes", "cornell.json"), "-o",
                            os.path.join(d, "x.exr"), "--integrator", name, "--spp", "1",
                            "--width", "8", "--height", "8", "--no-accel-cache"],
                           capture_output=True, text=True)
        return p.returncode == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--candela")
    ap.add_argument("--integrator")
    ap.add_argument("--scenes", default="scenes/cornell.json,big")
    ap.add_argument("--big-triangles", type=int, default=1_000_000)
    ap.add_argument("--accels", default="cwbvh",
                    help="other structures timed beside the BVH, comma-separated (e.g. cwbvh; empty: none)")
    ap.add_argument("--grids", default="auto,16,32,64,128,256")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--width", type=int, default=512)
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--device")
    ap.add_argument("--out", default="bench-out/accel_grid")
    args = ap.parse_args()
    candela = find_candela(args.candela)
    os.makedirs(args.out, exist_ok=True)
    if not args.integrator:
        args.integrator = "whitted" if has_integrator(candela, "whitted") else "nee"
    print(f"integrator {args.integrator}, {args.width}x{args.height}, {args.spp} spp, "
          f"{args.repeats} repeats", file=sys.stderr)

    # Step 1: scenes (the big mesh is generated here, never committed).
    scenes = []
    for s in args.scenes.split(","):
        if s == "big":
            d = os.path.join(args.out, "big")
            if not os.path.exists(os.path.join(d, "big.json")):
                subprocess.run([sys.executable, os.path.join(ROOT, "bench", "make_big_scene.py"), d,
                                "--triangles", str(args.big_triangles)], check=True)
            scenes.append(os.path.join(d, "big.json"))
        else:
            scenes.append(s)
    configs = [("bvh", None)] + [(k, None) for k in args.accels.split(",") if k]
    configs += [("grid", g) for g in args.grids.split(",") if g]

    # Step 2: the runs.
    rows, summary = [], []
    for scene in scenes:
        for kind, res in configs:
            extra = ["--accel", kind, "--no-accel-cache"]
            if res not in (None, "auto"):
                extra += ["--grid-resolution", res]
            runs = []
            for r in range(args.repeats):
                st = render(candela, scene, args.out, args, extra + ["--seed", str(r + 1)])
                runs.append(st)
                row = {
                    "scene": scene, "integrator": args.integrator, "accel": kind,
                    "grid_request": res or "", "repeat": r, "seed": r + 1,
                    "grid_cells": "x".join(map(str, st.get("grid_resolution") or [])),
                    "grid_refs": st.get("grid_refs", ""), "accel_bytes": st["accel_bytes"],
                    "accel_build_s": st["accel_build_s"], "time_s": st["time_s"],
                    "gpu_time_s": st["gpu_time_s"], "rays_per_s": st["rays_per_s"],
                    "msamples_per_s": st["msamples_per_s"], "triangles": st["triangles"],
                    "primitives": st["primitives"], "width": st["width"], "height": st["height"],
                    "spp": st["spp"], "device": st["device"]["name"],
                }
                rows.append(row)
                print(f"{os.path.basename(scene)} {kind} {res or ''} #{r}: "
                      f"{st['gpu_time_s']:.4f} s GPU, {st['rays_per_s'] * 1e-6:.1f} Mrays/s, "
                      f"build {st['accel_build_s'] * 1e3:.1f} ms", file=sys.stderr)
            # The cache: a miss (build + write), then a hit (load).
            with tempfile.TemporaryDirectory() as cache:
                ce = [e for e in extra if e != "--no-accel-cache"] + ["--accel-cache", cache]
                miss = render(candela, scene, args.out, args, ce, spp=1)
                hit = render(candela, scene, args.out, args, ce, spp=1)
                assert (miss["accel_cache"], hit["accel_cache"]) == ("miss", "hit"), (miss, hit)
            med = lambda k: statistics.median(x[k] for x in runs)
            summary.append({
                "scene": os.path.basename(os.path.dirname(scene)) + "/" + os.path.basename(scene)
                if scene.endswith("big/big.json") else os.path.basename(scene),
                "triangles": runs[0]["triangles"], "accel": kind, "grid": res or "",
                "cells": "x".join(map(str, runs[0].get("grid_resolution") or [])) or "-",
                "refs": runs[0].get("grid_refs", "-"),
                "mib": runs[0]["accel_bytes"] / 2**20, "build_ms": med("accel_build_s") * 1e3,
                "hit_ms": hit["accel_build_s"] * 1e3, "gpu_s": med("gpu_time_s"),
                "mrays": med("rays_per_s") * 1e-6, "device": runs[0]["device"]["name"],
            })

    # Step 3: outputs.
    with open(os.path.join(args.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    lines = [
        f"# Grid vs BVH: {args.integrator}, {args.width}x{args.height}, {args.spp} spp, "
        f"median of {args.repeats}, device {summary[0]['device']}",
        "",
        "| scene | triangles | accel | grid | cells | refs | MiB | build ms | cache hit ms | GPU s | Mrays/s | vs BVH |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    base = {}
    for s in summary:
        if s["accel"] == "bvh":
            base[s["scene"]] = s["gpu_s"]
        ratio = s["gpu_s"] / base[s["scene"]] if base.get(s["scene"]) else float("nan")
        lines.append(
            f"| {s['scene']} | {s['triangles']} | {s['accel']} | {s['grid']} | {s['cells']} | "
            f"{s['refs']} | {s['mib']:.2f} | {s['build_ms']:.1f} | {s['hit_ms']:.1f} | "
            f"{s['gpu_s']:.4f} | {s['mrays']:.1f} | {ratio:.2f}x |")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(args.out, "summary.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
