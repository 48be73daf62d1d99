#!/usr/bin/env python3
"""Does a render process's memory stop growing once it has seen every kernel variant? (issue 18)

Starts `candela serve` on a temporary data directory (or, with --farm, a throwaway PostgreSQL
cluster, `candela serve --workers 0` and one `candela worker`) and submits, in --rounds rounds,
one small job of every built-in scene with every integrator the server lists (the soak's mix,
bench/soak.py), waiting for each round to end. After each round it records the render process's
resident size and, from `/metrics` (serve) or `GET /api/workers` (farm), the pipelines it
caches, the kernel variants it has compiled since it started and glibc malloc's account. Bounded
caches show as a resident size that stops rising after the first round or two; a leak as one
that rises by about the same amount every round.

    python3 bench/memory_rounds.py --rounds 5 --json memory-rounds.json
    python3 bench/memory_rounds.py --farm --rounds 5
    python3 bench/memory_rounds.py --rounds 3 --server-arg=--cache-pipelines=1000

Python 3 standard library only.
"""

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
import urllib.request

from soak import REPO, TERMINAL, Server
from soak_farm import Postgres, Worker, rss_mb


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--candela", default=os.path.join(REPO, "target", "debug", "candela"))
    p.add_argument("--farm", action="store_true",
                   help="measure one `candela worker` on a throwaway PostgreSQL cluster")
    p.add_argument("--size", type=int, default=16, help="film width and height (default 16)")
    p.add_argument("--spp", type=int, default=4, help="spp of each job (default 4)")
    p.add_argument("--server-arg", action="append", default=[],
                   help="extra argument for the render process (repeatable)")
    p.add_argument("--round-timeout", type=float, default=1800.0)
    p.add_argument("--json", help="where to write the rounds")
    return p.parse_args()


def metric(text, name, labels=""):
    """The value of series `name{labels}` in Prometheus text, or None."""
    want = f"{name}{{{labels}}}" if labels else name
    for line in text.splitlines():
        if line.startswith(want + " "):
            return float(line.rsplit(" ", 1)[1])
    return None


def main():
    a = parse_args()
    data_dir = tempfile.mkdtemp(prefix="candela-memrounds-")
    log_path = data_dir + ".log"
    pg, worker = None, None
    extra = [] if a.farm else list(a.server_arg)
    if a.farm:
        pg = Postgres(log_path)
        pg.start()
        extra += ["--workers", "0", "--database", pg.url]
    server = Server(a.candela, data_dir, log_path, extra)
    rounds = []
    try:
        server.start()
        if a.farm:
            worker = Worker(a.candela, 0, data_dir, pg.url, log_path, 15.0, a.server_arg, REPO)
            worker.start()
        render_pid = worker.proc.pid if a.farm else server.proc.pid
        ints = [i["name"] for i in server.call("GET", "/api/integrators")[1]["integrators"]]
        scenes = [s["name"] for s in server.call("GET", "/api/scenes")[1]["scenes"]]
        print(f"memory_rounds: {len(scenes)} scenes x {len(ints)} integrators, "
              f"{a.size}x{a.size}, {a.spp} spp, {'worker' if a.farm else 'serve'} pid "
              f"{render_pid}; log {log_path}", flush=True)
        t0 = time.time()
        for r in range(a.rounds):
            t_round = time.time()
            ids = []
            for s in scenes:
                for i in ints:
                    st, job = server.call("POST", "/api/jobs", {
                        "scene_name": s, "integrator": i, "width": a.size, "height": a.size,
                        "spp": a.spp, "seed": r, "name": f"round {r} {s} {i}"})
                    if st != 201:
                        sys.exit(f"memory_rounds: POST {s} {i}: {st} {job}")
                    ids.append(job["id"])
            while time.time() - t_round < a.round_timeout:
                jobs = server.call("GET", "/api/jobs?limit=100000")[1]["jobs"]
                states = {j["id"]: j["state"] for j in jobs}
                if all(states.get(i) in TERMINAL for i in ids):
                    break
                time.sleep(1)
            failed = sum(1 for i in ids if states.get(i) != "done")
            time.sleep(3)  # a heartbeat after the last job, for the worker's report
            row = {"round": r + 1, "t_s": round(time.time() - t0, 1),
                   "round_s": round(time.time() - t_round, 1), "jobs": len(ids),
                   "not_done": failed, "rss_mb": round(rss_mb(render_pid), 1)}
            if a.farm:
                ws = server.call("GET", "/api/workers")[1]["workers"]
                w = next((w for w in ws if w.get("pid") == render_pid), {})
                row.update({"pipelines": w.get("pipelines_cached"),
                            "kernel_variants": w.get("kernel_variants_seen")})
            else:
                with urllib.request.urlopen(server.url + "/metrics") as f:
                    text = f.read().decode()
                mib = lambda v: None if v is None else round(v / 2**20, 1)
                row.update({
                    "heap_allocated_mib": mib(metric(text, "candela_heap_bytes",
                                                     'kind="allocated"')),
                    "heap_free_mib": mib(metric(text, "candela_heap_bytes", 'kind="free"')),
                    "pipelines": metric(text, "candela_cache_entries", 'cache="pipelines"'),
                    "pipelines_live": metric(text, "candela_pipelines_live"),
                    "pipeline_evictions": metric(text, "candela_cache_evictions_total",
                                                 'cache="pipelines"'),
                    "kernel_variants": metric(text, "candela_kernel_variants_seen_total"),
                })
            rounds.append(row)
            print("memory_rounds: " + ", ".join(f"{k} {v}" for k, v in row.items()), flush=True)
            # The round's jobs go, as the soak deletes finished ones.
            for i in ids:
                server.call("DELETE", f"/api/jobs/{i}")
    finally:
        server.terminate()
        if worker:
            worker.terminate()
        if pg:
            pg.stop()
            pg.remove()
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"args": vars(a), "rounds": rounds}, f, indent=1)
    shutil.rmtree(data_dir, ignore_errors=True)


if __name__ == "__main__":
    main()
