"""Times Mitsuba 3 on its own Cornell box (mi.cornell_box()) at a given resolution, max_depth and
spp, to compare with `candela render scenes/cornell.json` on the same GPU; or, with --xml, on
exactly candela's scene, written as Mitsuba XML by `candela convert SCENE.json SCENE.xml`
(docs/import.md; film size and max_depth then come from the XML). Prints one JSON line.

usage: python3 bench/mitsuba_cornell.py [--variant cuda_ad_rgb] [--width 1280 --height 720]
                                        [--spp 256] [--max-depth 6] [--repeat 3] [--xml SCENE.xml]
"""
import argparse
import json
import time

import mitsuba as mi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="cuda_ad_rgb")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--max-depth", type=int, default=6)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--xml", help="a scene written by `candela convert SCENE.json SCENE.xml`")
    a = ap.parse_args()
    mi.set_variant(a.variant)
    if a.xml:
        scene = mi.load_file(a.xml)
        a.width, a.height = (int(x) for x in scene.sensors()[0].film().size())
        a.max_depth = None  # the XML's integrator
    else:
        d = mi.cornell_box()
        d["sensor"]["film"]["width"] = a.width
        d["sensor"]["film"]["height"] = a.height
        d["sensor"]["sampler"]["sample_count"] = a.spp
        d["integrator"] = {"type": "path", "max_depth": a.max_depth}
        scene = mi.load_dict(d)
    # Warm-up render compiles the kernels; then time full renders (evaluated, synchronised).
    img = mi.render(scene, spp=a.spp)
    mi.Bitmap(img)
    times = []
    for i in range(a.repeat):
        t0 = time.perf_counter()
        img = mi.render(scene, spp=a.spp, seed=i + 1)
        mi.Bitmap(img)  # forces evaluation
        times.append(time.perf_counter() - t0)
    best = min(times)
    samples = a.width * a.height * a.spp
    print(json.dumps({"renderer": "mitsuba3", "variant": a.variant, "scene": a.xml or "mi.cornell_box()",
                      "width": a.width, "height": a.height,
                      "spp": a.spp, "max_depth": a.max_depth, "times_s": times,
                      "msamples_per_s_best": samples / best / 1e6}))


if __name__ == "__main__":
    main()
