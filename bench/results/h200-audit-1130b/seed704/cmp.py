import sys, json
sys.path.insert(0, "/work/main/tests/mitsuba")
import audit
a1, a2, b1, b2 = sys.argv[1:5]
r = audit.compare("/work/main/target/release/candela", [audit.read_exr(a1), audit.read_exr(a2)], [audit.read_exr(b1), audit.read_exr(b2)], ((a1, a2), (b1, b2)))
print(json.dumps({k: (round(v, 6) if isinstance(v, float) else v) for k, v in r.items()}))
print("ratio", r["block_rel_mse"] / r["noise"])
