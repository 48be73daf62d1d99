"""The farm side of bench/soak.py (`--farm N`): a throwaway PostgreSQL cluster and `candela worker`
processes, each of which the soak kills with SIGKILL and starts again.

- `Postgres`: initdb into a temporary folder (as user `nobody` when run as root, as PostgreSQL
  refuses root), the server on a free loopback port; a kill sends SIGKILL to the postmaster and
  every backend at once, as a lost database host would, and the restart runs PostgreSQL's crash
  recovery on the same data folder.
- `Worker`: `candela worker` on the soak's data directory and database, with the soak's short
  checkpoint interval and a short lease, so that a killed worker's jobs are taken over within
  seconds.

Python 3 standard library only.
"""

import glob
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _pg_bin():
    for d in sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True):
        if os.path.isfile(os.path.join(d, "initdb")):
            return d
    found = shutil.which("initdb")
    if found:
        return os.path.dirname(found)
    raise RuntimeError("PostgreSQL is not installed (no initdb): run scripts/setup.sh")


def terminate(proc, timeout=60):
    """SIGTERM, then SIGKILL if `proc` has not exited within `timeout` seconds: its exit status,
    or what happened."""
    proc.send_signal(signal.SIGTERM)
    try:
        return proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        return "killed after SIGTERM timeout"


def rss_mb(pid):
    """Resident memory of process `pid` in MB, or None when it is gone."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


class Postgres:
    """A PostgreSQL cluster of its own, killed with SIGKILL and restarted on demand."""

    def __init__(self, log_path):
        self.bin = _pg_bin()
        self.dir = tempfile.mkdtemp(prefix="candela-soak-pg-")
        self.data = os.path.join(self.dir, "data")
        self.log_path = log_path
        self.port = _free_port()
        self.proc = None
        self.starts = []
        self.root = os.geteuid() == 0
        if self.root:
            subprocess.run(["chown", "-R", "nobody", self.dir], check=True)
        out = subprocess.run(self._as_server_user([os.path.join(self.bin, "initdb"), "-A", "trust",
                                                   "-U", "candela", "-E", "UTF8", "-D",
                                                   self.data]),
                             capture_output=True, text=True)
        if out.returncode != 0:
            raise RuntimeError(f"initdb failed: {out.stderr}")

    def _as_server_user(self, argv):
        return (["runuser", "-u", "nobody", "--"] + argv) if self.root else argv

    @property
    def url(self):
        return f"postgres://candela@127.0.0.1:{self.port}/postgres"

    def start(self, timeout=60):
        """Starts the server and waits until it accepts connections; after a kill, retried
        until the killed backends are gone and the crash recovery is over."""
        argv = [os.path.join(self.bin, "postgres"), "-D", self.data, "-p", str(self.port),
                "-k", self.dir, "-c", "listen_addresses=127.0.0.1"]
        t0 = time.time()
        while time.time() - t0 < timeout:
            log = open(self.log_path, "a")
            log.write(f"\n==== postgres start {time.strftime('%H:%M:%S')}\n")
            log.flush()
            self.proc = subprocess.Popen(self._as_server_user(argv), stdout=log, stderr=log)
            while time.time() - t0 < timeout and self.proc.poll() is None:
                ok = subprocess.run([os.path.join(self.bin, "pg_isready"), "-q", "-h",
                                     "127.0.0.1", "-p", str(self.port)]).returncode == 0
                if ok:
                    self.starts.append({"t": time.time(), "pid": self.proc.pid,
                                        "startup_s": round(time.time() - t0, 3)})
                    return
                time.sleep(0.1)
            time.sleep(0.5)
        raise RuntimeError(f"postgres did not start; see {self.log_path}")

    def _cluster_pids(self):
        """Every process of this cluster: the postmaster and backends, whose working folder is
        the data folder (backends are session leaders of their own, so no process group holds
        them all)."""
        pids = []
        for d in glob.glob("/proc/[0-9]*"):
            try:
                if os.readlink(os.path.join(d, "cwd")) == self.data:
                    pids.append(int(os.path.basename(d)))
            except OSError:
                pass
        return pids

    def kill9(self):
        """SIGKILL to the postmaster and all its backends at once, as a lost database host."""
        deadline = time.time() + 30
        while True:
            pids = self._cluster_pids()
            if not pids or time.time() > deadline:
                break
            for pid in pids:
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass
            time.sleep(0.05)
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            pass

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.kill9()

    def remove(self):
        shutil.rmtree(self.dir, ignore_errors=True)


class Worker:
    """`candela worker` number `index`, restarted after each kill with a new name (HOST:PID)."""

    def __init__(self, binary, index, data_dir, database, log_path, lease, extra, cwd):
        self.binary, self.index, self.data_dir, self.database = binary, index, data_dir, database
        self.log_path, self.lease, self.extra, self.cwd = log_path, lease, extra, cwd
        self.proc = None
        self.starts = []

    def start(self):
        args = [self.binary, "worker", "--data-dir", self.data_dir, "--database", self.database,
                "--checkpoint-interval", "1", "--snapshot-interval", "0.5", "--max-active", "3",
                "--pass-ms", "50", "--min-free-space", "0", "--lease", str(self.lease)] + self.extra
        log = open(self.log_path, "a")
        log.write(f"\n==== worker {self.index} start {time.strftime('%H:%M:%S')}: "
                  f"{' '.join(args)}\n")
        log.flush()
        env = dict(os.environ, CANDELA_LOG=os.environ.get("CANDELA_LOG", "info"))
        # (A session of its own: the soak's warm-up stops workers with SIGSTOP, and a stopped
        # process in the soak's own process group would have the kernel send the whole group
        # SIGHUP if that group were orphaned, e.g. when the shell that started the soak exits.)
        self.proc = subprocess.Popen(args, stdout=log, stderr=log, cwd=self.cwd, env=env,
                                     start_new_session=True)
        self.starts.append({"t": time.time(), "pid": self.proc.pid})

    def alive(self):
        return self.proc is not None and self.proc.poll() is None

    def kill9(self):
        try:
            os.kill(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait()

    def terminate(self, timeout=60):
        if not self.alive():
            return f"exited with {self.proc.returncode}"
        return terminate(self.proc, timeout)
