"""A single-node Slurm cluster for the tests, from Debian's packages, started by hand (no systemd).

:func:`slurm_available` installs ``slurm-wlm`` and ``munge`` with apt-get where they are missing (root only) and
says why not where that cannot be done; :class:`SlurmCluster` starts ``munged`` (its own key and socket in the test
folder), ``slurmctld`` and ``slurmd`` as child processes, waits until the node is idle, and stops exactly those
processes again. A daemon that does not come up is an error carrying its log's tail, never a skip.

Slurm's client commands inside a job (the ``srun`` that the executor plugin's job step runs) see none of the
submitting shell's ``SLURM_*`` variables, so the configuration must be where Slurm looks without ``SLURM_CONF``:
``/etc/slurm/slurm.conf``. The cluster writes it there and removes it when it stops; a machine that already has a
``slurm.conf`` (a real Slurm host) is left alone, and the tests using the cluster are skipped there.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

PACKAGES = ("slurm-wlm", "munge")
DAEMONS = ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel")
SYSTEM_CONF = Path("/etc/slurm/slurm.conf")
CLUSTER_NAME = "porepipe-test"
#: finished jobs stay listed this long: the plugin's `squeue` status query needs >= 120 s, the test checks them at its end
MIN_JOB_AGE_S = 3600


def slurm_available() -> str | None:
    """None where a cluster can be started here; otherwise the reason (for ``pytest.skip``)."""
    missing = [tool for tool in DAEMONS if shutil.which(tool) is None]
    if missing:
        reason = _install()
        if reason:
            return f"Slurm is not installed ({', '.join(missing)} missing) and {reason}"
    if SYSTEM_CONF.exists() and not _stale_test_conf():
        return (
            f"{SYSTEM_CONF} exists (a configured Slurm host, or another test session's running cluster); "
            "the test's own cluster will not replace it"
        )
    return None


def _stale_test_conf() -> bool:
    """True (and the file removed) where /etc/slurm/slurm.conf is a killed test session's, its controller gone."""
    text = SYSTEM_CONF.read_text(errors="replace")
    if f"ClusterName={CLUSTER_NAME}" not in text:
        return False
    pid_file = Path(text.split("SlurmctldPidFile=", 1)[1].split()[0]) if "SlurmctldPidFile=" in text else None
    try:
        os.kill(int(pid_file.read_text()), 0)
        return False  # another test session's cluster is running
    except (AttributeError, OSError, ValueError):
        SYSTEM_CONF.unlink(missing_ok=True)
        return True


def _install() -> str | None:
    """apt-get install the Debian packages; None on success, else why it could not."""
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        return "cannot be installed here (needs root and apt-get: apt-get install slurm-wlm munge)"
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for cmd in (
        ["apt-get", "update", "-q"],
        ["apt-get", "install", "-y", "-q", "--no-install-recommends", *PACKAGES],
    ):
        out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900, check=False)
        if out.returncode != 0:
            return f"`{' '.join(cmd)}` failed: {(out.stderr or out.stdout).strip().splitlines()[-1:]}"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("", 0))
        return s.getsockname()[1]


def _node_line(name: str) -> str:
    """This machine's NodeName line as ``slurmd -C`` reports it (CPUs, sockets, memory), named ``name``."""
    out = subprocess.run(["slurmd", "-C"], capture_output=True, text=True, check=True).stdout
    fields = out.splitlines()[0].split()
    keep = [
        f
        for f in fields[1:]
        if f.split("=")[0]
        in {"CPUs", "Boards", "SocketsPerBoard", "CoresPerSocket", "ThreadsPerCore", "RealMemory"}
    ]
    return " ".join([f"NodeName={name}", *keep, "State=UNKNOWN"])


def _tail(path: Path, lines: int = 25) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return f"({path} was not written)"


class SlurmCluster:
    """One controller and one compute node on this machine, in partition ``compute`` (the profile's default).

    Parameters
    ----------
    directory : Path
        Folder for the munge key and socket, Slurm's state, spool, logs and pid files.
    """

    def __init__(self, directory: Path):
        self.dir = Path(directory)
        self.host = socket.gethostname().split(".")[0]
        self.procs: dict[str, subprocess.Popen] = {}
        self.cpus = 1

    # -- configuration -------------------------------------------------------------------------------------------
    def _munge_key(self) -> Path:
        munge = self.dir / "munge"
        munge.mkdir(mode=0o755, parents=True, exist_ok=True)
        key = munge / "munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o600)
        return key

    def _slurm_conf(self) -> str:
        d = self.dir
        node = _node_line(self.host)
        self.cpus = int(next(f for f in node.split() if f.startswith("CPUs=")).split("=")[1])
        return "\n".join(
            [
                f"ClusterName={CLUSTER_NAME}",
                f"SlurmctldHost={self.host}",
                f"SlurmctldPort={_free_port()}",
                f"SlurmdPort={_free_port()}",
                "SlurmUser=root",
                "SlurmdUser=root",
                "AuthType=auth/munge",
                "CredType=cred/munge",
                f"AuthInfo=socket={d / 'munge' / 'socket'}",
                f"StateSaveLocation={d / 'state'}",
                f"SlurmdSpoolDir={d / 'spool'}",
                f"SlurmctldPidFile={d / 'slurmctld.pid'}",
                f"SlurmdPidFile={d / 'slurmd.pid'}",
                f"SlurmctldLogFile={d / 'slurmctld.log'}",
                f"SlurmdLogFile={d / 'slurmd.log'}",
                "ProctrackType=proctrack/linuxproc",  # no cgroups: no systemd in a container
                "TaskPlugin=task/none",
                "JobAcctGatherType=jobacct_gather/none",
                "AccountingStorageType=accounting_storage/none",  # no slurmdbd: the plugin asks squeue
                "JobCompType=jobcomp/none",
                "SelectType=select/cons_tres",
                "SelectTypeParameters=CR_Core_Memory",
                "SchedulerType=sched/backfill",
                f"MinJobAge={MIN_JOB_AGE_S}",
                "ReturnToService=2",
                "MpiDefault=none",
                "SwitchType=switch/none",
                node,
                f"PartitionName=compute Nodes={self.host} Default=YES MaxTime=INFINITE State=UP",
                "",
            ]
        )

    # -- daemons -------------------------------------------------------------------------------------------------
    def _start(self, name: str, cmd: list[str]) -> None:
        with open(
            self.dir / f"{name}.out", "w"
        ) as out:  # the daemon writes to its own copy of the descriptor
            self.procs[name] = subprocess.Popen(
                cmd, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
            )

    def _fail(self, what: str) -> None:
        logs = [self.dir / f"{n}.out" for n in self.procs] + [
            self.dir / "slurmctld.log",
            self.dir / "slurmd.log",
        ]
        detail = "\n".join(f"--- {p.name}:\n{_tail(p)}" for p in logs if p.exists())
        self.stop()
        raise RuntimeError(f"single-node Slurm: {what}\n{detail}")

    def start(self) -> SlurmCluster:
        """Write the configuration, start munged, slurmctld and slurmd; return once the node takes jobs."""
        for sub in ("state", "spool"):
            (self.dir / sub).mkdir(parents=True, exist_ok=True)
        key = self._munge_key()
        sock = self.dir / "munge" / "socket"
        self._start(
            "munged",
            [
                "munged",
                "--foreground",
                "--force",
                f"--socket={sock}",
                f"--key-file={key}",
                f"--pid-file={self.dir / 'munge' / 'munged.pid'}",
                f"--seed-file={self.dir / 'munge' / 'seed'}",
                f"--log-file={self.dir / 'munge' / 'munged.log'}",
            ],
        )
        self._wait(lambda: sock.exists(), "munged did not create its socket")
        SYSTEM_CONF.parent.mkdir(parents=True, exist_ok=True)
        SYSTEM_CONF.write_text(self._slurm_conf())
        self._start("slurmctld", ["slurmctld", "-D", "-i"])
        self._start("slurmd", ["slurmd", "-D", "-N", self.host])
        self._wait(self._idle, "the node did not become idle")
        return self

    def _idle(self) -> bool:
        out = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True, check=False)
        return out.returncode == 0 and out.stdout.strip() == "idle"

    def _wait(self, ready, what: str, timeout_s: float = 60) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            dead = [n for n, p in self.procs.items() if p.poll() is not None]
            if dead:
                self._fail(f"{', '.join(dead)} exited")
            if ready():
                return
            time.sleep(0.5)
        self._fail(f"{what} within {timeout_s:g} s")

    def stop(self) -> None:
        """Cancel every job, stop the daemons this cluster started, remove its configuration."""
        if "slurmctld" in self.procs and self.procs["slurmctld"].poll() is None:
            subprocess.run(["scancel", "--full", "--user=root"], capture_output=True, check=False, timeout=30)
        for name in ("slurmd", "slurmctld", "munged"):
            proc = self.procs.pop(name, None)
            if proc is None or proc.poll() is not None:
                continue
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if SYSTEM_CONF.exists() and str(self.dir) in SYSTEM_CONF.read_text():
            SYSTEM_CONF.unlink()

    def __enter__(self) -> SlurmCluster:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
