#!/usr/bin/env python3
"""Soak test of `candela serve` (issue 18): hours of mixed traffic with kill -9 of the server
(and, with --farm N, of N `candela worker` processes and of PostgreSQL).

Starts `candela serve` on a temporary data directory and, for --duration seconds, submits a
mix of small jobs (every integrator the server lists, small films, spp and time budgets,
random priorities), cancels some, pauses and resumes some, changes priorities, deletes finished
ones, and kills the server with SIGKILL at random intervals, restarting it on the same data
directory. With --farm N the store is a throwaway PostgreSQL cluster, the server only serves
the API (`--workers 0`), N workers render, and each kill picks the server, one worker or
PostgreSQL (bench/soak_farm.py), each restarted at once. Then it stops making trouble, resumes what is paused, waits for every job to end and
checks the invariants:

  1. every job ended done, canceled or failed, and every failed job has a reason;
  2. every done job with an spp budget has exactly that spp (also those deleted, checked just
     before deleting them);
  3. no orphaned files: every folder under <data>/jobs belongs to a job the server lists, and
     no deleted job's folder is left;
  4. memory is flat: the RSS of the server and of each worker, sampled every few seconds, has
     its high-water mark rise by less than --rss-slope-limit MB/hour over the measurement
     window of the longest-measured lifetime of each role (server, worker): the peak of the
     window's second half less the peak of its first half, per hour of half (the least-squares
     slope is reported beside it). A render process's window starts
     once it has compiled every kernel variant it will use in its lifetime (its
     `kernel_variants_seen`, from `GET /api/workers`, at its final value) and --rss-warmup
     seconds after its start, whichever is later: its caches fill as new scene/integrator
     variants appear, so growth before that is the fill, not a leak. Before the traffic, a
     warm-up renders every scene with every integrator on each render process (with --farm,
     one worker at a time, the others stopped with SIGSTOP; no kills), so that the first
     lifetimes have seen every variant when the traffic starts.
     The memory series of /metrics (in-memory cache entries and bytes, glibc malloc's
     allocated and free bytes) are sampled beside it, to say where the memory went.

It prints a summary and writes everything to --json. Python 3 standard library only.

    python3 bench/soak.py --duration 600 --json bench/results/soak-lavapipe-600s.json
    python3 bench/soak.py --duration 20 --kill-every 6:10 --max-spp 64   # smoke run
    python3 bench/soak.py --farm 2 --duration 3600 --json soak-farm.json
"""

import argparse
import json
import os
import random
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

from soak_farm import Postgres, Worker, rss_mb, terminate

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TERMINAL = ("done", "canceled", "failed")
MEMORY_SERIES = ("process_resident_memory_bytes", "candela_heap_bytes", "candela_cache_",
                 "candela_pipelines_live", "candela_snapshot")


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--duration", type=float, default=3600, help="seconds of traffic (default 3600)")
    p.add_argument("--candela", default=os.path.join(REPO, "target", "debug", "candela"),
                   help="the candela binary (default: target/debug/candela)")
    p.add_argument("--data-dir", help="data directory (default: a new temporary one, removed "
                   "after a passing run)")
    p.add_argument("--json", default="soak.json", help="where to write the results")
    p.add_argument("--seed", type=int, default=1, help="random seed of the traffic")
    p.add_argument("--kill-every", default="45:120", metavar="MIN:MAX",
                   help="seconds between kill -9 of the server, uniform (default 45:120; 0: never)")
    p.add_argument("--max-unfinished", type=int, default=10,
                   help="most unfinished jobs the script keeps (default 10)")
    p.add_argument("--tick", type=float, default=0.5, help="seconds between actions")
    p.add_argument("--rss-every", type=float, default=2.0, help="seconds between RSS samples")
    p.add_argument("--metrics-every", type=float, default=10.0,
                   help="seconds between samples of the server's memory metrics (cache sizes, "
                   "malloc; 0: none)")
    p.add_argument("--rss-warmup", type=float, default=20.0,
                   help="seconds of each process lifetime always left out of the RSS fit (the "
                   "window starts later if the process compiles new kernel variants later)")
    p.add_argument("--warmup-rounds", type=int, default=1, metavar="K",
                   help="before the traffic, render every scene with every integrator K times "
                   "(8x8, 1 spp) on each render process (with --farm, on one worker at a time, "
                   "the others stopped), so that each sees every kernel variant (default 1; 0: "
                   "none)")
    p.add_argument("--rss-slope-limit", type=float, default=50.0,
                   help="largest rise of the RSS's peak, MB/hour, that counts as flat "
                   "(default 50)")
    p.add_argument("--rss-min-window", "--rss-min-lifetime", dest="rss_min_window", type=float,
                   default=300.0,
                   help="shortest measurement window, seconds, whose RSS slope is judged "
                   "(default 300; shorter ones report the slope as n/a)")
    p.add_argument("--max-spp", type=int, default=256,
                   help="largest spp budget submitted (default 256)")
    p.add_argument("--drain-timeout", type=float, default=300.0,
                   help="seconds to wait for the last jobs to end")
    p.add_argument("--server-arg", action="append", default=[],
                   help="extra argument for candela serve (repeatable)")
    p.add_argument("--farm", type=int, default=0, metavar="N",
                   help="N candela worker processes on a throwaway PostgreSQL cluster, the server "
                   "serving the API only; kills pick the server, a worker or PostgreSQL "
                   "(default 0: one server on SQLite)")
    p.add_argument("--lease", type=float, default=15.0,
                   help="the workers' --lease, seconds (farm only; default 15)")
    p.add_argument("--worker-arg", action="append", default=[],
                   help="extra argument for candela worker (repeatable)")
    return p.parse_args()


class Server:
    """`candela serve` on a data dir, restarted on the same dir after each kill."""

    def __init__(self, binary, data_dir, log_path, extra):
        self.binary, self.data_dir, self.log_path, self.extra = binary, data_dir, log_path, extra
        self.proc = None
        self.url = None
        self.starts = []

    def start(self):
        args = [self.binary, "serve", "--bind", "127.0.0.1:0", "--data-dir", self.data_dir,
                "--checkpoint-interval", "1", "--snapshot-interval", "0.5", "--max-active", "3",
                "--pass-ms", "50", "--min-free-space", "0"] + self.extra
        log = open(self.log_path, "a")
        log.write(f"\n==== start {time.strftime('%H:%M:%S')}: {' '.join(args)}\n")
        log.flush()
        env = dict(os.environ, CANDELA_LOG=os.environ.get("CANDELA_LOG", "info"))
        env.pop("CANDELA_TOKEN", None)
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=log, cwd=REPO, env=env,
                                     text=True)
        t0 = time.time()
        for line in self.proc.stdout:  # the address line comes first on stdout
            log.write(line)
            if line.startswith("candela: listening on "):
                self.url = line.split("listening on ", 1)[1].strip()
                break
        else:
            raise RuntimeError(f"candela serve exited without an address; see {self.log_path}")
        # Keep draining stdout into the log.
        threading.Thread(target=self._pump, args=(self.proc.stdout, log), daemon=True).start()
        self.starts.append({"t": time.time(), "pid": self.proc.pid,
                            "startup_s": round(time.time() - t0, 3)})

    @staticmethod
    def _pump(stream, log):
        for line in stream:
            log.write(line)
            log.flush()

    def kill9(self):
        os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait()

    def terminate(self, timeout=60):
        return terminate(self.proc, timeout)

    def rss_mb(self):
        return rss_mb(self.proc.pid)

    def memory_metrics(self, timeout=10):
        """The memory series of /metrics ({"name{labels}": value}), or None if unreachable."""
        try:
            with urllib.request.urlopen(self.url + "/metrics", timeout=timeout) as r:
                text = r.read().decode()
        except (urllib.error.URLError, ConnectionError, TimeoutError, OSError):
            return None
        out = {}
        for line in text.splitlines():
            if line.startswith("#") or " " not in line:
                continue
            name, value = line.rsplit(" ", 1)
            if name.startswith(MEMORY_SERIES):
                out[name] = float(value)
        return out

    def call(self, method, path, body=None, timeout=30):
        """(status, parsed JSON or None); status 0 when the server could not be reached."""
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.url + path, data=data, method=method,
                                     headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=timeout) as r:
                raw = r.read()
                return r.status, (json.loads(raw) if raw else None)
        except urllib.error.HTTPError as e:
            raw = e.read()
            try:
                return e.code, json.loads(raw)
            except ValueError:
                return e.code, None
        except (urllib.error.URLError, ConnectionError, TimeoutError, OSError):
            return 0, None


def peak_growth(samples):
    """How fast the RSS's high-water mark rose over `samples` (t, mb): the peak of their second
    half less the peak of their first half, per hour of half; None with fewer than 4. A bounded
    process, its caches and allocator arenas full, steps up and down within a band whose top it
    has reached: its second half peaks no higher. A leak of L MB/h raises the peak by about L
    per hour. (A least-squares slope over minutes mostly measures where in the band the window
    starts and ends.)"""
    if len(samples) < 4:
        return None
    mid = (samples[0][0] + samples[-1][0]) / 2
    first = [m for t, m in samples if t < mid]
    second = [m for t, m in samples if t >= mid]
    half_h = (samples[-1][0] - samples[0][0]) / 2 / 3600.0
    if not first or not second or half_h <= 0:
        return None
    return (max(second) - max(first)) / half_h


def fit_slope(samples):
    """Least-squares slope of (t, mb) samples, MB per hour; None with fewer than 3."""
    if len(samples) < 3:
        return None
    ts = [t for t, _ in samples]
    ms = [m for _, m in samples]
    mt, mm = statistics.fmean(ts), statistics.fmean(ms)
    var = sum((t - mt) ** 2 for t in ts)
    if var == 0:
        return None
    return sum((t - mt) * (m - mm) for t, m in zip(ts, ms)) / var * 3600.0


class Soak:
    def __init__(self, args):
        self.args = args
        self.rng = random.Random(args.seed)
        self.counts = {k: 0 for k in ("submitted", "refused", "cancel", "pause", "resume",
                                       "priority", "delete", "kills", "unreachable")}
        self.kills = {}  # target -> kills
        self.refusals = {}
        self.jobs = {}  # id -> {"budget": ("spp", n) | ("time", s), "integrator", ...}
        self.deleted = {}  # id -> final record (just before DELETE)
        self.rss = []  # (t, mb, lifetime: "server#K" or "workerI#K")
        self.variants = []  # (t, lifetime, kernel variants the process has compiled so far)
        self.warmup = None
        self.mem = []  # (t, lifetime index, {series: value})
        self.kill_range = None
        if args.kill_every not in ("0", ""):
            lo, hi = (float(x) for x in args.kill_every.split(":"))
            self.kill_range = (lo, hi)

    def pick_job(self, server):
        """Integrator, scene and budget of a new small job."""
        integrators = self.integrators
        body = {
            "scene_name": self.rng.choice(self.scenes),
            "integrator": self.rng.choice(integrators),
            "width": self.rng.choice([8, 12, 16, 24, 32]),
            "height": self.rng.choice([8, 12, 16, 24]),
            "seed": self.rng.randrange(1 << 31),
            "priority": self.rng.choice([1, 5, 10, 10, 10, 50, 100]),
        }
        if self.rng.random() < 0.75:
            body["spp"] = self.rng.choice([n for n in (1, 4, 16, 32, 64, 128, 256)
                                           if n <= self.args.max_spp] or [1])
        else:
            body["time_s"] = self.rng.choice([0.2, 0.5, 1.0, 2.0])
        body["name"] = f"soak {body['integrator']} {body['scene_name']}"
        return body

    def list_jobs(self, server):
        st, body = server.call("GET", "/api/jobs?limit=100000")
        return body["jobs"] if st == 200 and body else None

    def act(self, server):
        """One random action."""
        jobs = self.list_jobs(server)
        if jobs is None:
            self.counts["unreachable"] += 1
            return
        by_state = {}
        for j in jobs:
            by_state.setdefault(j["state"], []).append(j)
        unfinished = sum(len(by_state.get(s, [])) for s in ("queued", "running", "paused"))
        r = self.rng.random()
        if r < 0.35 and unfinished < self.args.max_unfinished:
            body = self.pick_job(server)
            st, job = server.call("POST", "/api/jobs", body)
            if st == 201:
                self.counts["submitted"] += 1
                budget = ("spp", body["spp"]) if "spp" in body else ("time", body["time_s"])
                self.jobs[job["id"]] = {"budget": budget, "integrator": body["integrator"],
                                        "scene": body["scene_name"]}
            elif st != 0:
                self.counts["refused"] += 1
                err = (job or {}).get("error")
                code = err.get("code", "") if isinstance(err, dict) else ""
                key = f"{st} {code}: {err.get('message', '')[:80] if isinstance(err, dict) else ''}"
                self.refusals[key] = self.refusals.get(key, 0) + 1
        elif r < 0.45 and (by_state.get("running") or by_state.get("queued")):
            j = self.rng.choice(by_state.get("running", []) + by_state.get("queued", []))
            if server.call("POST", f"/api/jobs/{j['id']}/cancel")[0] == 200:
                self.counts["cancel"] += 1
        elif r < 0.55 and by_state.get("running"):
            j = self.rng.choice(by_state["running"])
            if server.call("POST", f"/api/jobs/{j['id']}/pause")[0] == 200:
                self.counts["pause"] += 1
        elif r < 0.70 and by_state.get("paused"):
            j = self.rng.choice(by_state["paused"])
            if server.call("POST", f"/api/jobs/{j['id']}/resume")[0] == 200:
                self.counts["resume"] += 1
        elif r < 0.80 and unfinished:
            j = self.rng.choice([j for s in ("queued", "running", "paused")
                                 for j in by_state.get(s, [])])
            p = self.rng.choice([1, 10, 50, 100])
            if server.call("PATCH", f"/api/jobs/{j['id']}", {"priority": p})[0] == 200:
                self.counts["priority"] += 1
        elif r < 0.95:
            finished = [j for s in TERMINAL for j in by_state.get(s, [])]
            if finished:
                j = self.rng.choice(finished)
                st, rec = server.call("GET", f"/api/jobs/{j['id']}")
                if st == 200 and server.call("DELETE", f"/api/jobs/{j['id']}")[0] == 204:
                    self.counts["delete"] += 1
                    self.deleted[j["id"]] = rec

    def run(self):
        """The soak; on an exception or Ctrl-C, every process it started is stopped first."""
        self.server, self.pg, self.workers = None, None, []
        try:
            return self._run()
        except BaseException:
            self._abort()
            raise

    def _abort(self):
        for p in ([self.server.proc] if self.server and self.server.proc else []) + \
                [w.proc for w in self.workers if w.proc]:
            if p.poll() is None:
                p.kill()
        if self.pg:
            self.pg.stop()

    def _run(self):
        a = self.args
        data_dir = a.data_dir or tempfile.mkdtemp(prefix="candela-soak-")
        os.makedirs(data_dir, exist_ok=True)
        log_path = os.path.join(data_dir, "..", os.path.basename(data_dir) + ".log")
        log_path = os.path.abspath(log_path)
        t_start = time.time()
        # The farm: PostgreSQL and the workers first; the server then serves the API only.
        self.pg, self.workers = None, []
        extra = list(a.server_arg)
        if a.farm > 0:
            self.pg = Postgres(log_path)
            self.pg.start()
            extra += ["--workers", "0", "--database", self.pg.url]
            self.workers = [Worker(a.candela, i, data_dir, self.pg.url, log_path, a.lease,
                                   a.worker_arg, REPO) for i in range(a.farm)]
        server = self.server = Server(a.candela, data_dir, log_path, extra)
        server.start()
        for w in self.workers:
            w.start()
        st, ints = server.call("GET", "/api/integrators")
        self.integrators = [i["name"] for i in ints["integrators"]]
        st, scenes = server.call("GET", "/api/scenes")
        self.scenes = [s["name"] for s in scenes["scenes"]]
        print(f"soak: {a.duration:.0f} s on {data_dir} (log {log_path}); integrators "
              f"{', '.join(self.integrators)}; scenes {', '.join(self.scenes)}", flush=True)

        # Step 1: the warm-up (every kernel variant the traffic uses), then traffic, RSS
        # samples and kills until the duration is over.
        self.warmup = self.warm_up(server, t_start)
        t_traffic = time.time()
        next_kill = self.next_kill_time()
        next_rss = time.time()
        next_mem = time.time()
        next_report = time.time() + 60
        while time.time() - t_traffic < a.duration:
            now = time.time()
            if now >= next_rss:
                self.sample_rss(server, now - t_start)
                next_rss = now + a.rss_every
            if a.metrics_every > 0 and now >= next_mem:
                m = server.memory_metrics()
                if m is not None:
                    self.mem.append((round(now - t_start, 1), len(server.starts) - 1, m))
                next_mem = now + a.metrics_every
            if next_kill is not None and now >= next_kill:
                self.kill_one(server)
                next_kill = self.next_kill_time()
            self.act(server)
            if now >= next_report:
                print(f"soak: {now - t_start:.0f} s, {self.counts}", flush=True)
                next_report = now + 60
            time.sleep(a.tick)

        # Step 2: drain: resume what is paused, wait for every job to end.
        t_drain = time.time()
        jobs = []
        while time.time() - t_drain < a.drain_timeout:
            jobs = self.list_jobs(server) or []
            for j in jobs:
                if j["state"] == "paused":
                    server.call("POST", f"/api/jobs/{j['id']}/resume")
            if all(j["state"] in TERMINAL for j in jobs):
                break
            for w in self.workers:
                if not w.alive():  # a worker that exited on its own is started again
                    w.start()
            self.sample_rss(server, time.time() - t_start)
            time.sleep(1)
        drain_s = time.time() - t_drain
        jobs = self.list_jobs(server) or []

        # Step 3: the invariants, with the server, the workers and PostgreSQL stopped.
        exit_status = server.terminate()
        worker_exits = [w.terminate() for w in self.workers]
        if self.pg:
            self.pg.stop()
        result = self.check(jobs, data_dir)
        result.update({
            "duration_s": a.duration,
            "wall_s": round(time.time() - t_start, 1),
            "drain_s": round(drain_s, 1),
            "seed": a.seed,
            "kill_every": a.kill_every,
            "counts": self.counts,
            "refusals": self.refusals,
            "server_starts": server.starts,
            "final_exit": exit_status,
            "farm": a.farm,
            "kills_by_target": self.kills,
            "worker_starts": [w.starts for w in self.workers],
            "worker_exits": worker_exits,
            "postgres_starts": self.pg.starts if self.pg else None,
            "data_dir": data_dir,
            "log": log_path,
            "candela": a.candela,
            "warmup": self.warmup,
            "rss_samples": [(round(t, 1), round(m, 2), k) for t, m, k in self.rss],
            "variant_samples": self.variants,
            "memory_samples": self.mem,
            "memory_growth": self.memory_growth(),
        })
        self.report(result)
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)
        print(f"soak: wrote {a.json}")
        if result["ok"] and not a.data_dir:
            shutil.rmtree(data_dir, ignore_errors=True)
        if result["ok"] and self.pg:
            self.pg.remove()
        return 0 if result["ok"] else 1

    def sample_rss(self, server, t):
        """One RSS sample of the server and of each live worker, keyed by process lifetime,
        and the kernel variants each render process reported with its last heartbeat."""
        procs = [(f"server#{len(server.starts) - 1}", server.proc.pid)]
        procs += [(f"worker{w.index}#{len(w.starts) - 1}", w.proc.pid)
                  for w in self.workers if w.alive()]
        for key, pid in procs:
            mb = rss_mb(pid)
            if mb is not None:
                self.rss.append((t, mb, key))
        st, body = server.call("GET", "/api/workers", timeout=5)
        by_pid = {pid: key for key, pid in procs}
        for w in (body or {}).get("workers", []) if st == 200 else []:
            key = by_pid.get(w.get("pid"))
            if key and w.get("kernel_variants_seen") is not None and w["state"] == "running":
                self.variants.append((round(t, 1), key, w["kernel_variants_seen"]))

    def warm_up(self, server, t_start):
        """Every scene with every integrator, --warmup-rounds times (8x8, 1 spp), on each render
        process in turn before the traffic (no kills meanwhile): with --farm, one worker at a
        time, the others stopped (SIGSTOP, holding no job) so that it renders every job itself.
        Each render process thus compiles every kernel variant the traffic will use. The jobs
        are then deleted (done ones checked for their spp like the traffic's)."""
        a = self.args
        if a.warmup_rounds <= 0:
            return None
        t0 = time.time()
        ids, ended, not_submitted = [], {}, 0
        for w in self.workers or [None]:
            others = [o for o in self.workers if o is not w]
            for o in others:
                os.kill(o.proc.pid, signal.SIGSTOP)
            try:
                mine, left = self.warm_up_round(server, t_start)
            finally:
                for o in others:
                    os.kill(o.proc.pid, signal.SIGCONT)
            ids += mine
            not_submitted += left
        for jid in ids:
            st, rec = server.call("GET", f"/api/jobs/{jid}")
            if st == 200 and rec["state"] in TERMINAL:
                ended[rec["state"]] = ended.get(rec["state"], 0) + 1
                if server.call("DELETE", f"/api/jobs/{jid}")[0] == 204:
                    self.deleted[jid] = rec
        w = {"rounds": a.warmup_rounds, "processes": max(1, len(self.workers)), "jobs": len(ids),
             "not_submitted": not_submitted, "ended": ended,
             "seconds": round(time.time() - t0, 1)}
        print(f"soak: warm-up: {w}", flush=True)
        return w

    def warm_up_round(self, server, t_start):
        """Submits every scene x integrator --warmup-rounds times (as many at once as the
        server's queue takes) and waits for them to end: (job ids, jobs not submitted)."""
        a = self.args
        todo = [(r, sc, i) for r in range(a.warmup_rounds) for sc in self.scenes
                for i in self.integrators]
        ids, waiting = [], []
        deadline = time.time() + a.drain_timeout * 6
        next_rss = 0.0
        while time.time() < deadline:
            if time.time() >= next_rss:
                self.sample_rss(server, time.time() - t_start)
                next_rss = time.time() + a.rss_every
            while todo:
                r, sc, i = todo[0]
                st, job = server.call("POST", "/api/jobs", {
                    "scene_name": sc, "integrator": i, "width": 8, "height": 8, "spp": 1,
                    "seed": r, "priority": 10, "name": f"soak warm-up {i} {sc}"})
                if st != 201:
                    break
                todo.pop(0)
                ids.append(job["id"])
                waiting.append(job["id"])
            states = {j["id"]: j["state"] for j in self.list_jobs(server) or []}
            waiting = [j for j in waiting if states.get(j) not in TERMINAL]
            if not todo and not waiting:
                break
            time.sleep(1)
        return ids, len(todo)

    def kill_one(self, server):
        """kill -9 of the server, or in a farm of the server, one worker or PostgreSQL, each
        equally likely; the victim is started again at once."""
        targets = ["server"] + (["worker", "postgres"] if self.workers else [])
        target = self.rng.choice(targets)
        if target == "server":
            server.kill9()
            server.start()
        elif target == "worker":
            w = self.rng.choice(self.workers)
            target = f"worker{w.index}"
            w.kill9()
            w.start()
        else:
            self.pg.kill9()
            self.pg.start()
        self.counts["kills"] += 1
        self.kills[target] = self.kills.get(target, 0) + 1

    def memory_growth(self):
        """Each memory series (the server's /metrics) at the first and last sample of the
        longest server lifetime."""
        lifetimes = {}
        for t, k, m in self.mem:
            lifetimes.setdefault(k, []).append((t, m))
        if not lifetimes:
            return None
        s = max(lifetimes.values(), key=lambda v: v[-1][0] - v[0][0])
        (t0, first), (t1, last) = s[0], s[-1]
        return {"from_s": t0, "to_s": t1,
                "series": {k: [first.get(k), last.get(k)] for k in sorted(last)}}

    def next_kill_time(self):
        if self.kill_range is None:
            return None
        return time.time() + self.rng.uniform(*self.kill_range)

    def check(self, jobs, data_dir):
        listed = {j["id"]: j for j in jobs}
        problems = []
        states = {}
        for j in jobs:
            states[j["state"]] = states.get(j["state"], 0) + 1
        # 1. Every job ended; failures say why.
        for j in jobs:
            if j["state"] not in TERMINAL:
                problems.append(f"job {j['id']} still {j['state']}")
            if j["state"] == "failed" and not (j.get("error") or "").strip():
                problems.append(f"job {j['id']} failed without a reason")
        failures = {}
        for j in list(jobs) + list(self.deleted.values()):
            if j and j["state"] == "failed":
                key = (j.get("error") or "")[:120]
                failures[key] = failures.get(key, 0) + 1
        # 2. Exact spp for done spp-budget jobs (listed, or checked before deletion).
        spp_checked = 0
        for j in list(jobs) + list(self.deleted.values()):
            if not j or j["state"] != "done":
                continue
            want = j["settings"].get("spp")
            if want is None:
                continue
            spp_checked += 1
            got = j["progress"]["spp"]
            if got != want:
                problems.append(f"job {j['id']} done with {got} spp, budget {want}")
        # Jobs the script submitted that vanished without being deleted by it.
        for jid in self.jobs:
            if jid not in listed and jid not in self.deleted:
                problems.append(f"job {jid} is gone but was never deleted")
        # 3. Orphaned files.
        jobs_dir = os.path.join(data_dir, "jobs")
        orphans, stray_tmp = [], []
        for name in sorted(os.listdir(jobs_dir)) if os.path.isdir(jobs_dir) else []:
            path = os.path.join(jobs_dir, name)
            if not name.isdigit() or int(name) not in listed:
                orphans.append(name)
                continue
            for root, _, files in os.walk(path):
                stray_tmp += [os.path.join(root, f) for f in files if f.endswith(".tmp")]
        for jid in self.deleted:
            if os.path.exists(os.path.join(jobs_dir, str(jid))) and str(jid) not in orphans:
                orphans.append(str(jid))
        if orphans:
            problems.append(f"orphaned job folders: {orphans}")
        # 4. Memory: per process lifetime, the slope over its measurement window: from when it
        # had compiled every kernel variant of its lifetime (and --rss-warmup after its start)
        # to its end; the longest window of each role (server, worker) decides.
        lifetimes, variants = {}, {}
        for t, mb, k in self.rss:
            lifetimes.setdefault(k, []).append((t, mb))
        for t, k, n in self.variants:
            variants.setdefault(k, []).append((t, n))
        segments = []
        for k, s in sorted(lifetimes.items()):
            t0, t_end = s[0][0], s[-1][0]
            vs = variants.get(k, [])
            final = max((n for _, n in vs), default=None)
            complete = next((t for t, n in vs if n == final), None)
            start = max(t0 + self.args.rss_warmup, complete if complete is not None else t0)
            warm = [(t, m) for t, m in s if t >= start]
            half = [(t, m) for t, m in s if t - t0 >= (t_end - t0) / 2]
            slope = fit_slope(warm)
            segments.append({
                "lifetime": k, "role": k.split("#")[0].rstrip("0123456789"),
                "start_s": round(t0, 1), "length_s": round(t_end - t0, 1),
                "kernel_variants": final,
                "variants_complete_s": None if complete is None else round(complete - t0, 1),
                "window_from_s": round(start - t0, 1),
                "window_s": round(max(0.0, t_end - start), 1),
                "slope_last_half_mb_per_h":
                    None if fit_slope(half) is None else round(fit_slope(half), 2),
                "rss_first_mb": round(s[0][1], 1), "rss_last_mb": round(s[-1][1], 1),
                "rss_max_mb": round(max(m for _, m in s), 1),
                "window_rss_min_mb": round(min(m for _, m in warm), 1) if warm else None,
                "window_rss_max_mb": round(max(m for _, m in warm), 1) if warm else None,
                "slope_mb_per_h": None if slope is None else round(slope, 2),
                "peak_growth_mb_per_h":
                    None if peak_growth(warm) is None else round(peak_growth(warm), 2),
            })
        fitted = [s for s in segments if s["peak_growth_mb_per_h"] is not None]
        longest_by_role = {}
        for seg in fitted:
            if seg["window_s"] > longest_by_role.get(seg["role"], {"window_s": -1})["window_s"]:
                longest_by_role[seg["role"]] = seg
        longest = longest_by_role.get("server")
        rss_flat = None
        for role, seg in sorted(longest_by_role.items()):
            if seg["window_s"] < self.args.rss_min_window:
                continue
            flat = seg["peak_growth_mb_per_h"] <= self.args.rss_slope_limit
            rss_flat = flat if rss_flat is None else (rss_flat and flat)
            if not flat:
                problems.append(f"RSS peak grows {seg['peak_growth_mb_per_h']} MB/h over the longest "
                                f"{role} window ({seg['lifetime']}, {seg['window_s']} s from "
                                f"{seg['window_from_s']} s)")
        invariants = {
            "all_jobs_ended_with_reasons": not any(("still" in p or "without a reason" in p)
                                                   for p in problems),
            "done_spp_exact": not any("done with" in p for p in problems),
            "no_lost_jobs": not any("never deleted" in p for p in problems),
            "no_orphaned_folders": not orphans,
            "rss_flat": rss_flat,
        }
        return {
            "ok": not problems,
            "problems": problems,
            "invariants": invariants,
            "final_states": states,
            "jobs_listed": len(jobs),
            "jobs_deleted": len(self.deleted),
            "deleted_states": {s: sum(1 for r in self.deleted.values() if r and r["state"] == s)
                               for s in TERMINAL},
            "done_spp_checked": spp_checked,
            "failures": failures,
            "stray_tmp_files": stray_tmp,
            "rss_segments": segments,
            "rss_longest": longest,
            "rss_longest_by_role": longest_by_role,
        }

    def report(self, r):
        c = r["counts"]
        done = r["final_states"].get("done", 0) + r["deleted_states"]["done"]
        canceled = r["final_states"].get("canceled", 0) + r["deleted_states"]["canceled"]
        failed = r["final_states"].get("failed", 0) + r["deleted_states"]["failed"]
        print("\n=== candela soak summary ===")
        print(f"traffic: {r['duration_s']:.0f} s (+{r['drain_s']} s drain), kill -9 every "
              f"{r['kill_every']} s: {c['kills']} kills, {len(r['server_starts'])} server starts")
        print(f"jobs: {c['submitted']} submitted ({c['refused']} refused), {done} done, "
              f"{canceled} canceled, {failed} failed; {c['delete']} deleted")
        print(f"actions: {c['cancel']} cancels, {c['pause']} pauses, {c['resume']} resumes, "
              f"{c['priority']} priority changes; {c['unreachable']} ticks with the server down")
        if r["failures"]:
            print("failure reasons: " + "; ".join(f"{n}x {k}" for k, n in r["failures"].items()))
        for name, ok in r["invariants"].items():
            print(f"  {'PASS' if ok else ('n/a ' if ok is None else 'FAIL')}  {name}")
        print(f"  done jobs with exact spp checked: {r['done_spp_checked']}")
        seg = r["rss_segments"]
        if r["kills_by_target"]:
            print("kills: " + ", ".join(f"{k} {n}" for k, n in sorted(r["kills_by_target"].items())))
        if r.get("warmup"):
            w = r["warmup"]
            print(f"warm-up: every scene x integrator {w['rounds']}x on each of "
                  f"{w['processes']} render processes, {w['jobs']} jobs, {w['seconds']} s")
        for role, lg in sorted(r["rss_longest_by_role"].items()):
            of = [s for s in seg if s["role"] == role]
            v = ("kernel variants unknown" if lg["kernel_variants"] is None else
                 f"its {lg['kernel_variants']} kernel variants all seen at "
                 f"{lg['variants_complete_s']} s")
            print(f"RSS of the {role}s: first {of[0]['rss_first_mb']} MB, last "
                  f"{of[-1]['rss_last_mb']} MB, max {max(s['rss_max_mb'] for s in of)} MB; "
                  f"longest window: {lg['lifetime']} ({lg['length_s']} s; {v}), "
                  f"{lg['window_s']} s from {lg['window_from_s']} s: peak growth "
                  f"{lg['peak_growth_mb_per_h']} MB/h (least-squares slope "
                  f"{lg['slope_mb_per_h']} MB/h)"
                  f"{'' if lg['window_s'] >= self.args.rss_min_window else ' (not judged: shorter than --rss-min-window)'}, "
                  f"{lg['window_rss_min_mb']}-"
                  f"{lg['window_rss_max_mb']} MB; over the lifetime's second half: "
                  f"{lg['slope_last_half_mb_per_h']} MB/h")
        g = r.get("memory_growth")
        if g:
            print(f"memory series, first -> last sample of the longest lifetime "
                  f"({g['from_s']} s -> {g['to_s']} s):")
            for k, (a, b) in g["series"].items():
                big = "bytes" in k
                fmt = (lambda v: "-" if v is None else f"{v / 2**20:.1f} MiB") if big else \
                      (lambda v: "-" if v is None else f"{v:g}")
                print(f"  {k}: {fmt(a)} -> {fmt(b)}")
        if r["stray_tmp_files"]:
            print(f"note: {len(r['stray_tmp_files'])} .tmp files in job folders")
        for p in r["problems"]:
            print(f"PROBLEM: {p}")
        print("RESULT:", "PASS" if r["ok"] else "FAIL")


def main():
    args = parse_args()
    if not os.path.exists(args.candela):
        sys.exit(f"soak: no candela binary at {args.candela} (cargo build, or --candela PATH)")
    sys.exit(Soak(args).run())


if __name__ == "__main__":
    main()
