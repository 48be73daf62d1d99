#!/usr/bin/env python3
"""Render a Mitsuba 3 XML scene with Mitsuba itself, for the importer tests (see README.md).

    render_xml.py SCENE.xml OUT.exr [--spp N] [--seed K] [-D NAME=VALUE ...] [--variant V]

The scene is loaded with `mi.load_file` (its own integrator, sensor and film; `-D` sets `$NAME`
parameters as `mitsuba -D` does) and rendered with `mi.render(spp=N, seed=K)`. Writes a linear
float32 RGB EXR and prints one JSON line. Exit codes: 0 rendered, 1 error.
"""
import argparse
import json
import sys
import time


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("out")
    p.add_argument("--spp", type=int, help="samples per pixel (default: the scene's sampler)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    p.add_argument("--variant", default="scalar_rgb", choices=["scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb"])
    args = p.parse_args(argv)
    import mitsuba as mi
    mi.set_variant(args.variant)
    params = {}
    for d in args.defines:
        if "=" not in d:
            print(f"error: -D {d}: expected NAME=VALUE", file=sys.stderr)
            return 1
        k, v = d.split("=", 1)
        params[k] = v
    try:
        scene = mi.load_file(args.scene, **params)
    except Exception as e:  # Mitsuba raises RuntimeError with file and line
        print(f"error: {e}", file=sys.stderr)
        return 1
    t0 = time.perf_counter()
    img = mi.render(scene, spp=args.spp or 0, seed=args.seed)
    seconds = time.perf_counter() - t0
    bmp = mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False).write(args.out)
    print(json.dumps({"render_time_s": round(seconds, 3), "out": args.out, "spp": args.spp,
                      "seed": args.seed, "variant": args.variant}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
