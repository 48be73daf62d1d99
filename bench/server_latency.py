#!/usr/bin/env python3
"""What a user of the render server feels, measured through the real server (issue 13).

Starts `candela serve` on a free loopback port and, over HTTP and SSE:
  * first  - POST -> first `snapshot` SSE event (and -> its PNG fetched), per integrator, in four
             states of the kernels: `cold` (fresh data dir, nothing compiled), `hot` (a second
             job in the same process), `disk` (a restarted server with the kernel cache on
             disk, no warm-up) and `warmed` (a restarted server after `--warm-kernels`
             finished). Binaries without a kernel cache (--base) measure cold and hot only.
  * busy   - GPU busy fraction per integrator and time budget: the finished job's
             gpu_time_s / time_s (its passes' GPU time over its wall time), and Msamples/s.
  * cadence - snapshots per second of a long job at a large film with a short
             --snapshot-interval, and its throughput against the same job without snapshots.

Writes DIR/results.jsonl (one JSON object per measurement) and DIR/summary.md, and prints the
summary. Only the Python standard library is needed. Example (GPU machine):
  python3 bench/server_latency.py --candela .carry/candela --out $OUT/server
"""

import argparse
import http.client
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

INTEGRATORS = ["nee", "pt", "bdpt", "vct", "whitted", "deferred"]


class Server:
    """A running `candela serve` (killed on close)."""

    def __init__(self, candela, data_dir, extra):
        cmd = [candela, "serve", "--bind", "127.0.0.1:0", "--data-dir", data_dir] + extra
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.log = []
        threading.Thread(target=self._drain, args=(self.proc.stderr,), daemon=True).start()
        deadline = time.time() + 120
        self.url = None
        while time.time() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            if "listening on http://" in line:
                self.url = line.strip().split("listening on ")[1]
                break
        if not self.url:
            self.close()
            raise RuntimeError("server did not start: " + "".join(self.log[-20:]))
        threading.Thread(target=self._drain, args=(self.proc.stdout,), daemon=True).start()
        self.host, self.port = self.url[len("http://"):].split(":")

    def _drain(self, stream):
        for line in stream:
            self.log.append(line)

    def get(self, path):
        with urllib.request.urlopen(self.url + path, timeout=600) as r:
            return r.read()

    def json(self, path):
        return json.loads(self.get(path))

    def post(self, path, body):
        req = urllib.request.Request(self.url + path, data=json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=600) as r:
            return json.loads(r.read())

    def wait_ready(self, kernels=False, timeout=600):
        """Waits for the device (and, with kernels, for the warm-up to finish)."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            h = self.json("/api/health")
            k = h.get("kernels", {}).get("state", "off")
            if h["gpu"]["state"] == "ready" and (not kernels or k in ("ready", "off")):
                return h
            time.sleep(0.05)
        raise RuntimeError("server not ready")

    def close(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def run_job(server, body, fetch_png=False):
    """POSTs a job and follows its events; returns timings (seconds from just before the POST)."""
    t0 = time.perf_counter()
    job = server.post("/api/jobs", body)
    t_post = time.perf_counter() - t0
    conn = http.client.HTTPConnection(server.host, int(server.port), timeout=600)
    conn.request("GET", f"/api/jobs/{job['id']}/events", headers={"Last-Event-ID": "0"})
    resp = conn.getresponse()
    snapshots, first_png, kind, done = [], None, None, None
    while True:
        line = resp.readline()
        if not line:
            break
        line = line.decode().rstrip("\n")
        if line.startswith("event:"):
            kind = line[6:].strip()
        elif line.startswith("data:"):
            t = time.perf_counter() - t0
            data = json.loads(line[5:])
            if kind == "snapshot":
                snapshots.append((t, data.get("spp")))
                if fetch_png and first_png is None:
                    server.get(data["url"])
                    first_png = time.perf_counter() - t0
            elif kind == "done":
                done = data
                break
            elif kind == "error":
                raise RuntimeError(f"job failed: {data}")
    conn.close()
    stats = (done or {}).get("stats", {})
    return {
        "post_s": t_post,
        "first_snapshot_s": snapshots[0][0] if snapshots else None,
        "first_png_s": first_png,
        "snapshots": snapshots,
        "end_s": time.perf_counter() - t0,
        "stats": {k: stats.get(k) for k in ("spp", "passes", "time_s", "gpu_time_s", "setup_s",
                                             "msamples_per_s", "kernel_build", "width", "height",
                                             "first_pass")},
        "details": stats.get("details"),
    }


def emit(out, rec):
    out.write(json.dumps(rec) + "\n")
    out.flush()
    print(json.dumps({k: v for k, v in rec.items() if k not in ("snapshots", "details")}), flush=True)


def first_snapshots(args, out, phase, server, integrators):
    rows = []
    for integ in integrators:
        body = {"scene_name": args.scene, "integrator": integ, "width": args.width,
                "height": args.height, "spp": 4}
        r = run_job(server, body, fetch_png=True)
        rec = {"test": "first", "phase": phase, "integrator": integ, **r}
        emit(out, rec)
        rows.append(rec)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--candela", default=".carry/candela")
    ap.add_argument("--out", default="/tmp/server-latency")
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--integrators", default=",".join(INTEGRATORS))
    ap.add_argument("--budgets", default="0.01,0.1,1", help="time budgets (s) of the busy test")
    ap.add_argument("--busy-sizes", default="256x256,1280x720")
    ap.add_argument("--cadence-size", default="1920x1080")
    ap.add_argument("--cadence-interval", type=float, default=0.1)
    ap.add_argument("--cadence-time", type=float, default=3.0)
    ap.add_argument("--base", action="store_true", help="a binary without kernel cache or warm-up")
    ap.add_argument("--tests", default="first,busy,cadence")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    integrators = args.integrators.split(",")
    tests = args.tests.split(",")
    data = tempfile.mkdtemp(prefix="candela-latency-")
    no_warm = [] if args.base else ["--warm-kernels", "none"]
    with open(os.path.join(args.out, "results.jsonl"), "w") as out:
        # Step 1: cold (fresh data dir) then hot (same process), then the busy fractions.
        s = Server(args.candela, data, no_warm)
        try:
            h = s.wait_ready()
            emit(out, {"test": "device", "gpu": h["gpu"]})
            if "first" in tests:
                first_snapshots(args, out, "cold", s, integrators)
                first_snapshots(args, out, "hot", s, integrators)
            if "busy" in tests:
                for size in args.busy_sizes.split(","):
                    w, hgt = map(int, size.split("x"))
                    for integ in integrators:
                        for b in map(float, args.budgets.split(",")):
                            body = {"scene_name": args.scene, "integrator": integ, "width": w,
                                    "height": hgt, "time_s": b}
                            r = run_job(s, body)
                            st = r["stats"]
                            busy = st["gpu_time_s"] / st["time_s"] if st.get("time_s") else None
                            emit(out, {"test": "busy", "integrator": integ, "size": size,
                                       "budget_s": b, "busy": busy, **r})
        finally:
            s.close()
        # Step 2: snapshot cadence and its cost, on a server with a short snapshot interval.
        if "cadence" in tests:
            w, hgt = map(int, args.cadence_size.split("x"))
            for interval in (args.cadence_interval, 1000.0):
                s = Server(args.candela, data, no_warm + ["--snapshot-interval", str(interval)])
                try:
                    s.wait_ready()
                    body = {"scene_name": args.scene, "integrator": "nee", "width": w, "height": hgt,
                            "time_s": args.cadence_time}
                    run_job(s, dict(body, time_s=0.2))  # kernels and clocks up
                    r = run_job(s, body)
                    times = [t for t, _ in r["snapshots"]]
                    gaps = [b - a for a, b in zip(times, times[1:])]
                    rate = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else None
                    emit(out, {"test": "cadence", "interval_s": interval, "size": args.cadence_size,
                               "snapshots_per_s": rate, "gap_mean_s": statistics.mean(gaps) if gaps else None,
                               "gap_max_s": max(gaps) if gaps else None, **r})
                finally:
                    s.close()
        # Step 3: restarted servers: kernels from the disk cache; then after a warm-up.
        if "first" in tests and not args.base:
            for phase, extra, wait in (("disk", ["--warm-kernels", "none"], False),
                                       ("warmed", ["--warm-kernels", "all"], True)):
                s = Server(args.candela, data, extra)
                try:
                    t = time.perf_counter()
                    h = s.wait_ready(kernels=wait)
                    emit(out, {"test": "warmup", "phase": phase, "kernels": h.get("kernels"),
                               "ready_s": time.perf_counter() - t})
                    first_snapshots(args, out, phase, s, integrators)
                finally:
                    s.close()
    shutil.rmtree(data, ignore_errors=True)
    summarize(args.out)


def summarize(out_dir):
    rows = [json.loads(l) for l in open(os.path.join(out_dir, "results.jsonl"))]
    lines = ["# candela through the server", ""]
    dev = [r for r in rows if r["test"] == "device"]
    if dev:
        g = dev[0]["gpu"].get("device") or {}
        lines += [f"Device: {g.get('name')} ({g.get('driver')})", ""]
    firsts = [r for r in rows if r["test"] == "first"]
    if firsts:
        phases = [p for p in ("cold", "hot", "disk", "warmed") if any(r["phase"] == p for r in firsts)]
        lines += ["POST -> first snapshot event / its PNG fetched, ms (setup_s of the job in brackets):", "",
                  "| integrator | " + " | ".join(phases) + " |", "|---|" + "---|" * len(phases)]
        for integ in dict.fromkeys(r["integrator"] for r in firsts):
            cells = []
            for p in phases:
                r = next((r for r in firsts if r["integrator"] == integ and r["phase"] == p), None)
                if r and r["first_snapshot_s"] is not None:
                    cells.append(f"{1e3 * r['first_snapshot_s']:.0f} / {1e3 * r['first_png_s']:.0f} "
                                 f"({r['stats']['setup_s']:.2f} s)")
                else:
                    cells.append("-")
            lines.append(f"| {integ} | " + " | ".join(cells) + " |")
        lines.append("")
    busy = [r for r in rows if r["test"] == "busy"]
    if busy:
        lines += ["GPU busy fraction (gpu_time_s / time_s of the job) and Msamples/s:", "",
                  "| size | integrator | budget s | busy | Msamples/s | spp | passes |", "|---|---|---|---|---|---|---|"]
        for r in busy:
            st = r["stats"]
            lines.append(f"| {r['size']} | {r['integrator']} | {r['budget_s']} | "
                         f"{r['busy']:.3f} | {st['msamples_per_s']:.1f} | {st['spp']} | {st['passes']} |")
        lines.append("")
    cad = [r for r in rows if r["test"] == "cadence"]
    if cad:
        lines += ["Snapshot cadence (nee, time budget; interval 1000 s = no snapshots but the first and last):", "",
                  "| size | interval s | snapshots/s | mean gap s | max gap s | Msamples/s |", "|---|---|---|---|---|---|"]
        for r in cad:
            f = lambda v: "-" if v is None else f"{v:.3f}"
            lines.append(f"| {r['size']} | {r['interval_s']} | {f(r['snapshots_per_s'])} | {f(r['gap_mean_s'])} | "
                         f"{f(r['gap_max_s'])} | {r['stats']['msamples_per_s']:.1f} |")
        lines.append("")
    warm = [r for r in rows if r["test"] == "warmup"]
    for r in warm:
        lines.append(f"Restart ({r['phase']}): ready after {r['ready_s']:.2f} s; kernels {json.dumps(r['kernels'])}")
    text = "\n".join(lines) + "\n"
    open(os.path.join(out_dir, "summary.md"), "w").write(text)
    print(text)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--summarize":
        summarize(sys.argv[2])
    else:
        main()
