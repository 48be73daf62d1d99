#!/usr/bin/env python3
"""Render a candela scene with Mitsuba 3 as an independent reference (see README.md).

    render_reference.py SCENE.json OUT.exr [--spp N] [--seed K] [--max-depth D] [--rr-depth R]
                        [--width W --height H] [--variant scalar_rgb|llvm_ad_rgb|cuda_ad_rgb] [--env-mitsuba-rows]

Translates the scene (ref_scene.py), renders it with Mitsuba's `path` integrator (`volpath` when
alpha masks are present), writes a linear float32 RGB EXR and prints one JSON line. Exit codes:
0 rendered, 1 invalid scene or error, 2 the scene uses a feature Mitsuba cannot express exactly.
"""
import argparse
import json
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("out")
    p.add_argument("--spp", type=int, help="samples per pixel (default: render.spp or 256)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-depth", type=int, help="default: render.max_depth or 6; -1 unbounded")
    p.add_argument("--rr-depth", type=int, default=5)
    p.add_argument("--width", type=int)
    p.add_argument("--height", type=int)
    p.add_argument("--variant", default="scalar_rgb", choices=["scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb"])
    p.add_argument("--env-mitsuba-rows", action="store_true",
                   help="use the env map as-is (Mitsuba's row convention v*(H-1)) instead of "
                        "resampling it to candela's v*H-0.5")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    import mitsuba as mi
    if args.variant not in mi.variants():
        print(f"error: Mitsuba variant {args.variant} is not available", file=sys.stderr)
        return 1
    mi.set_variant(args.variant)
    from ref_common import SceneError, Untranslatable
    from ref_scene import build_scene

    try:
        with open(args.scene) as f:
            scene = json.load(f)
    except (OSError, ValueError) as e:
        print(f"error: {args.scene}: {e}", file=sys.stderr)
        return 1
    opts = {"spp": args.spp, "seed": args.seed, "max_depth": args.max_depth,
            "rr_depth": args.rr_depth, "width": args.width, "height": args.height,
            "env_resample": not args.env_mitsuba_rows}
    with tempfile.TemporaryDirectory(prefix="candela_mi_") as tmp:
        try:
            d, settings = build_scene(scene, os.path.dirname(os.path.abspath(args.scene)), tmp,
                                      opts)
            mi_scene = mi.load_dict(d)
        except Untranslatable as e:
            print(f"untranslatable: {e}", file=sys.stderr)
            return 2
        except SceneError as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        t0 = time.perf_counter()
        img = mi.render(mi_scene, spp=settings["spp"], seed=settings["seed"])
        bmp = mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB)
        seconds = time.perf_counter() - t0
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    bmp.write(args.out)
    print(json.dumps({"render_time_s": round(seconds, 3), "out": args.out,
                      "variant": args.variant, **settings}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
