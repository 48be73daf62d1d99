# Mitsuba 3 decides an area emitter's front by the shading normal, and its two strategies then
# disagree: one triangle (normals 53 deg off its face) lighting a floor, `direct` with emitter
# sampling alone, BSDF sampling alone, and both (bench/RESULTS.md, seeds 180-301).
import os
import mitsuba as mi
mi.set_variant("scalar_rgb")
def scene(integ):
    return mi.load_dict({"type":"scene","integrator":integ,
      "sensor":{"type":"perspective","to_world":mi.ScalarTransform4f().look_at([0,5,3],[0,0,0],[0,1,0]),"fov":40,
                "film":{"type":"hdrfilm","width":16,"height":16,"rfilter":{"type":"box"}},"sampler":{"type":"independent","sample_count":2048}},
      "m":{"type":"obj","filename":os.path.join(os.path.dirname(os.path.abspath(__file__)), "mitsuba_emitter_front.obj"),"emitter":{"type":"area","radiance":{"type":"rgb","value":10.0}}},
      "floor":{"type":"rectangle","to_world":mi.ScalarTransform4f().rotate([1,0,0],-90).scale(3),"bsdf":{"type":"diffuse"}}})
def mean(img):
    a = mi.TensorXf(img); h,w,c = a.shape
    return sum(a[y,x,0] for y in range(h) for x in range(w))/(h*w)
for name, integ in [("emitter", {"type":"direct","emitter_samples":16,"bsdf_samples":0}),
                    ("bsdf", {"type":"direct","emitter_samples":0,"bsdf_samples":16}),
                    ("both", {"type":"direct"})]:
    print(name, mean(mi.render(scene(integ))))
