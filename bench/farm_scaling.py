#!/usr/bin/env python3
"""One job split across the GPUs of a farm (issue 15, deliver 3 and 8): for each device list of
--configs, a fresh PostgreSQL cluster (bench/soak_farm.py), `candela serve --workers 0` for the
API and one `candela worker --devices LIST --shard-spp N` (a render thread per device, each
claiming shards of N sample indices), then one job of --spp samples per pixel at
--width x --height; the job's wall time from its start to its end (`started_at`, `finished_at`)
gives its Msamples/s, and each list's scaling against the first list (with --repeats N, N rounds
of all the lists; the medians). A small job first makes
every device compile its kernels, and the timed job starts once the worker's background kernel
warm-up (one per device) has ended, so it meets warm caches and a worker with nothing else to
do on all of them.

    python3 bench/farm_scaling.py --candela .carry/main/candela --configs 0 0,1 --json OUT/farm.json

Python 3 standard library only; PostgreSQL from scripts/setup.sh (or, on the GPU machine,
bench/gpu_farm.sh's bundle).
"""

import argparse
import datetime
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from soak_farm import Postgres  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def call(url, method="GET", body=None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(url, data=data, method=method,
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=60) as r:
        return json.loads(r.read())


def seconds(rfc3339):
    return datetime.datetime.fromisoformat(rfc3339.replace("Z", "+00:00")).timestamp()


def wait_done(url, job, timeout):
    t0 = time.time()
    while time.time() - t0 < timeout:
        j = call(f"{url}/api/jobs/{job}")
        if j["state"] in ("done", "failed", "canceled"):
            return j
        time.sleep(0.2)
    raise RuntimeError(f"job {job} not done within {timeout} s")


def run_config(a, devices, env, tag):
    work = tempfile.mkdtemp(prefix="candela-farm-")
    log = os.path.join(work, "log.txt")
    pg = Postgres(log)
    procs = []
    try:
        pg.start()
        data = os.path.join(work, "data")
        os.makedirs(data)
        common = ["--data-dir", data, "--database", pg.url]
        serve = subprocess.Popen([a.candela, "serve", "--workers", "0", "--bind", "127.0.0.1:0"]
                                 + common, stdout=subprocess.PIPE, stderr=open(log, "a"),
                                 text=True, env=env, cwd=REPO)
        procs.append(serve)
        url = None
        for line in serve.stdout:
            if line.startswith("candela: listening on "):
                url = line.split("listening on ", 1)[1].strip()
                break
        if url is None:
            raise RuntimeError(f"serve did not start; see {log}")
        worker = subprocess.Popen([a.candela, "worker", "--devices", devices, "--shard-spp",
                                   str(a.shard_spp), "--lease", "120", "--checkpoint-interval",
                                   "1000"] + common, stdout=open(log, "a"),
                                  stderr=subprocess.STDOUT, env=env, cwd=REPO)
        procs.append(worker)
        n = len(devices.split(","))
        base = {"scene_name": a.scene, "integrator": a.integrator, "seed": 1}
        # Step 1: every device compiles its kernels (one shard each of a small job).
        warm = call(f"{url}/api/jobs", "POST", dict(base, width=64, height=64,
                                                   spp=a.shard_spp * n, name="warm-up"))
        wait_done(url, warm["id"], a.timeout)
        # (And the worker's background kernel warm-up, one per device, has ended: a farm's
        # long-running workers render with nothing else under way.)
        # (`warming kernels` when one starts, `kernels warm` when it ends; none on a CPU device.)
        def warming():
            text = open(log).read()
            return text.count("kernels warm") < text.count("warming kernels")
        deadline = time.time() + a.timeout
        while warming() and time.time() < deadline:
            time.sleep(0.2)
        if warming():
            print(f"{devices}: the kernel warm-up did not end in {a.timeout} s; timing anyway",
                  file=sys.stderr)
        # Step 2: the timed job.
        job = call(f"{url}/api/jobs", "POST", dict(base, width=a.width, height=a.height,
                                                  spp=a.spp, name=f"farm {devices}"))
        j = wait_done(url, job["id"], a.timeout)
        wall = seconds(j["finished_at"]) - seconds(j["started_at"])
        samples = a.width * a.height * j["progress"]["spp"]
        workers = call(f"{url}/api/workers")
        return {"devices": devices, "state": j["state"], "spp": j["progress"]["spp"],
                "wall_s": wall, "msamples_per_s": samples / wall * 1e-6,
                "job_time_s": j["progress"]["time_s"], "gpu_time_s": j["progress"]["gpu_time_s"],
                "error": j["error"], "workers": workers}
    finally:
        for p in procs:
            p.terminate()
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()
        pg.stop()
        shutil.copy(log, os.path.join(a.out, f"farm_{tag}.log"))
        pg.remove()
        shutil.rmtree(work, ignore_errors=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--candela", default=os.path.join(REPO, "target", "release", "candela"))
    p.add_argument("--configs", nargs="+", default=["0", "0,1"], help="device lists")
    p.add_argument("--scene", default="cornell")
    p.add_argument("--integrator", default="nee")
    p.add_argument("--width", type=int, default=3840)
    p.add_argument("--height", type=int, default=2160)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--shard-spp", type=int, default=128)
    p.add_argument("--timeout", type=float, default=300)
    p.add_argument("--repeats", type=int, default=1, help="rounds of all the configurations")
    p.add_argument("--out", default=".")
    a = p.parse_args()
    if a.repeats < 1:
        p.error("--repeats must be at least 1")
    env = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    rows = []
    # (A time limit's SIGTERM ends the runs as an exception: the table of what ran still prints.)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    try:
        # Rounds of every configuration in turn, so that a drift of the machine (clocks, heat)
        # spreads over all of them. farm.json is rewritten after each run.
        for rnd in range(a.repeats):
            for devices in a.configs:
                tag = devices.replace(",", "_") + (f"_r{rnd}" if a.repeats > 1 else "")
                r = dict(run_config(a, devices, env, tag), round=rnd)
                rows.append(r)
                print(json.dumps({k: v for k, v in r.items() if k != "workers"}), flush=True)
                with open(os.path.join(a.out, "farm.json"), "w") as f:
                    json.dump(rows, f, indent=1)
    finally:
        print_table(a, rows)


def print_table(a, rows):
    """Each configuration's runs that ended done: their walls, the median, and the scaling
    against the first configuration — of the median walls, and per round (the first
    configuration's wall in the same round over this one's)."""
    done = [r for r in rows if r["state"] == "done"]
    walls = {d: sorted(r["wall_s"] for r in done if r["devices"] == d) for d in a.configs}
    median = {d: (w[len(w) // 2] if len(w) % 2 else (w[len(w) // 2 - 1] + w[len(w) // 2]) / 2)
              for d, w in walls.items() if w}
    first = median.get(a.configs[0])
    base = {r["round"]: r["wall_s"] for r in done if r["devices"] == a.configs[0]}
    print(f"| devices | spp | wall s (each run) | median wall s | Msamples/s | scaling (median "
          f"walls) | scaling per round |\n|---|---|---|---|---|---|---|", flush=True)
    for d in a.configs:
        mine = [r for r in done if r["devices"] == d]
        if not mine:
            print(f"| {d} | — | — | — | — | — | — |")
            continue
        each = " / ".join(f"{r['wall_s']:.2f}" for r in mine)
        rounds = " / ".join(f"{base[r['round']] / r['wall_s']:.2f}" for r in mine
                            if r["round"] in base)
        ratio = f"{first / median[d]:.2f}" if first else "—"
        print(f"| {d} | {mine[0]['spp']} | {each} | {median[d]:.2f} | "
              f"{a.width * a.height * mine[0]['spp'] / median[d] * 1e-6:.1f} | {ratio} | "
              f"{rounds or '—'} |", flush=True)

if __name__ == "__main__":
    main()
