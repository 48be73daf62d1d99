import sys, json, math
sys.path.insert(0, "/work/main/tests/mitsuba")
import audit
R = audit.read_exr("/tmp/pt704/" + (sys.argv[1]) + "")
bR = audit.blocks(R)
k = 0.3 / (sum(audit.means(bR)) / 3)
def stats(name):
    im = audit.read_exr(name)
    b = audit.blocks(im)
    m = audit.means(b)
    rm = audit.rel_mse(audit.scaled(b, k), audit.scaled(bR, k))
    mx = max(im[2])
    # worst block
    worst = max(range(len(b)), key=lambda i: sum((k*b[i][c] - k*bR[i][c]) ** 2 / ((k * bR[i][c]) ** 2 + 0.01) for c in range(3)))
    return name.split("/")[-1], [round(x, 4) for x in m], "blockrelMSE vs T %.3e" % rm, "max px %.3f" % mx, "worst block", worst, [round(x, 4) for x in b[worst]], [round(x, 4) for x in bR[worst]]
for n in sys.argv[2:]:
    print(*stats(n))
