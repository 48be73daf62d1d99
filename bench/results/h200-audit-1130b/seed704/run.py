import json, os, sys, tempfile, time
sys.path.insert(0, "/work/main/tests/mitsuba")
import mitsuba as mi
mi.set_variant("scalar_rgb")
from ref_scene import build_scene
scene_path = "/tmp/s704/scene.json"
scene = json.load(open(scene_path))
integ, spp, seed, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
opts = {"spp": spp, "seed": seed, "max_depth": None, "rr_depth": 5, "width": None, "height": None, "env_resample": True}
with tempfile.TemporaryDirectory() as tmp:
    d, settings = build_scene(scene, os.path.dirname(scene_path), tmp, opts)
    if integ != "default":
        old = d["integrator"]
        print("was", {k: v for k, v in old.items()}, file=sys.stderr)
        d["integrator"] = {"type": integ, "max_depth": old.get("max_depth", 4), "rr_depth": old.get("rr_depth", 5)}
    s = mi.load_dict(d)
    t = time.time()
    img = mi.render(s, spp=spp, seed=seed)
    bmp = mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    bmp.write(out)
    print(integ, spp, seed, round(time.time() - t, 1), "s", file=sys.stderr)
