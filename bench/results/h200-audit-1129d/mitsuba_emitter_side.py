# Mitsuba 3 takes an area emitter's front side from the shading normal: the same triangle, seen
# from its geometric front (+z), with every vertex normal leaning away (z < 0) and towards the
# camera; the centre pixel is 0 and 1 (bench/RESULTS.md, seeds 180-301).
import os
import mitsuba as mi
mi.set_variant("scalar_rgb")
here = os.path.dirname(os.path.abspath(__file__))
for f in ["mitsuba_emitter_back.obj", "mitsuba_emitter_front_normals.obj"]:
    s = mi.load_dict({"type": "scene", "integrator": {"type": "path"},
                      "sensor": {"type": "perspective", "fov": 20,
                                 "to_world": mi.ScalarTransform4f().look_at([0, 0, 5], [0, 0, 0], [0, 1, 0]),
                                 "film": {"type": "hdrfilm", "width": 8, "height": 8, "rfilter": {"type": "box"}},
                                 "sampler": {"type": "independent", "sample_count": 4}},
                      "m": {"type": "obj", "filename": os.path.join(here, f),
                            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}}})
    a = mi.TensorXf(mi.render(s))
    print(f, "centre", [a[4, 4, c] for c in range(3)])
