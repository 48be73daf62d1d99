"""Image means of run.sh's renders (EXR read with Mitsuba 3's Bitmap, scalar variant)."""
import sys
import mitsuba as mi
mi.set_variant("scalar_rgb")
d, lamp = sys.argv[1], sys.argv[2]
def mean(name):
    b = mi.Bitmap(f"{d}/{lamp}_{name}.exr").convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    v = list(mi.TensorXf(b).array)
    return sum(v[0::3]) / (len(v) // 3)
pt = mean("masked_pt")
print(f"{lamp}: pt masked {pt:.5f}, pt whole {mean('whole_pt'):.5f}")
for i in ["nee", "bdpt", "whitted", "deferred"]:
    m = mean(f"masked_{i}")
    print(f"{lamp}: {i} {m:.5f} ({m / pt:.4f} of pt)")
print(f"{lamp}: deferred masked/whole {mean('masked_deferred') / mean('whole_deferred'):.4f}, pt {pt / mean('whole_pt'):.4f}")
