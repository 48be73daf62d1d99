"""Side by side: one candela scene rendered by candela and by Mitsuba 3 on the same GPU, in one
command, with the same film size, pixel filter, max_depth and spp; prints both Msamples/s and
their ratio as one JSON line (issue 12's benchmark; run it on the GPU machine, see
../shared/gpu/README.md and bench/gpu_vs_mitsuba.sh).

How it keeps the two sides equal:
1. the scene's film size, filter, max_depth and spp are overridden in a copy of the scene JSON,
   written beside the original (so relative mesh and texture paths still resolve);
2. `candela convert` writes that copy as Mitsuba XML (docs/import.md: the same camera, materials,
   lights and filter; Mitsuba's `path` integrator, i.e. unidirectional with next-event estimation
   and MIS, the counterpart of candela's `nee`);
3. candela renders the copy with `--spp`, after a 1 s warm-up, and reports render time without setup
   (`--json`: `time_s`, `msamples_per_s`);
4. Mitsuba renders the XML once untimed (JIT compile), then `--repeat` times, each evaluated and
   synchronised; the best time counts (scene load and compile excluded on both sides);
5. the two images are compared (`images_rel_mse`: noise of two spp-sample renders when the scenes
   agree, much larger when the translation lost something).

usage: python3 bench/vs_mitsuba.py SCENE.json [--candela BIN] [--width 1280 --height 720]
           [--max-depth 6] [--spp 64] [--filter box|gaussian] [--integrator nee] [--repeat 3]
           [--variant cuda_ad_rgb] [--candela-args "--accel bvh"]
"""
import argparse
import json
import os
import shlex
import subprocess
import sys
import time

CANDELA_EXR, MITSUBA_EXR = "/tmp/vs_mitsuba_candela.exr", "/tmp/vs_mitsuba_mitsuba.exr"


def scene_copy(a):
    """Step 1: the scene with the benchmark's film, filter, depth and spp, beside the original."""
    scene = json.load(open(a.scene))
    film = scene.setdefault("film", {})
    film["width"], film["height"] = a.width, a.height
    film["filter"] = {"type": "gaussian", "stddev": 0.5} if a.filter == "gaussian" else "box"
    render = scene.setdefault("render", {})
    render["integrator"], render["max_depth"], render["spp"] = a.integrator, a.max_depth, a.spp
    base = os.path.splitext(os.path.abspath(a.scene))[0] + ".vs_mitsuba"
    json.dump(scene, open(base + ".json", "w"), indent=1)
    return base + ".json", base + ".xml"


def candela(a, scene_json, scene_xml):
    """Steps 2 and 3: convert to Mitsuba XML, then render with candela."""
    subprocess.run([a.candela, "convert", scene_json, scene_xml], check=True, stdout=subprocess.DEVNULL)
    cmd = [a.candela, "render", scene_json, "-o", CANDELA_EXR, "--spp", str(a.spp),
           "--warmup", "1", "--json"] + shlex.split(a.candela_args)
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"candela render failed ({run.returncode}): {run.stderr.strip()}")
    return json.loads(run.stdout)


def mitsuba(a, scene_xml):
    """Step 4: Mitsuba renders the same scene; best of `repeat` timed renders."""
    import mitsuba as mi
    mi.set_variant(a.variant)
    scene = mi.load_file(scene_xml)
    size = [int(x) for x in scene.sensors()[0].film().size()]
    assert size == [a.width, a.height], f"Mitsuba film {size} differs from {a.width}x{a.height}"
    mi.Bitmap(mi.render(scene, spp=a.spp))  # JIT compile, untimed
    times = []
    for i in range(a.repeat):
        t0 = time.perf_counter()
        bitmap = mi.Bitmap(mi.render(scene, spp=a.spp, seed=i + 1))  # forces evaluation
        times.append(time.perf_counter() - t0)
    bitmap.write(MITSUBA_EXR)
    return {"variant": a.variant, "times_s": times,
            "msamples_per_s": a.width * a.height * a.spp / min(times) / 1e6}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--candela", default=".carry/main/candela")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--max-depth", type=int, default=6)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--filter", choices=["box", "gaussian"], default="box")
    ap.add_argument("--integrator", default="nee")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--variant", default="cuda_ad_rgb")
    ap.add_argument("--candela-args", default="", help="extra `candela render` arguments, e.g. \"--accel bvh\"")
    a = ap.parse_args()
    scene_json, scene_xml = scene_copy(a)
    c = candela(a, scene_json, scene_xml)
    m = mitsuba(a, scene_xml)
    # Both images at the same spp: their relMSE is noise only when the scenes agree (a sanity check).
    cmp = subprocess.run([a.candela, "compare", CANDELA_EXR, MITSUBA_EXR, "--json"], check=True,
                         capture_output=True, text=True).stdout
    keep = ("triangles", "instances", "instanced_triangles", "bvh_depth", "accel", "time_s", "spp",
            "msamples_per_s", "bvh_build_s", "gpu_bytes_per_triangle", "gpu_bytes_per_instance",
            "scene_gpu_bytes", "peak_rss_bytes", "load_s", "device")
    print(json.dumps({
        "scene": a.scene, "width": a.width, "height": a.height, "max_depth": a.max_depth,
        "spp": a.spp, "filter": a.filter, "integrator": a.integrator, "mitsuba_integrator": "path",
        "candela": {k: c.get(k) for k in keep if k in c},
        "mitsuba": m,
        "ratio_candela_over_mitsuba": c["msamples_per_s"] / m["msamples_per_s"],
        "images_rel_mse": json.loads(cmp)["metrics"]["rel_mse"],
    }))


if __name__ == "__main__":
    sys.exit(main())
