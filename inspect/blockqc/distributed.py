"""Inspecting a batch on a dask.distributed cluster: the same per-block jobs, as tasks.

Paths go in and each block's line of the summary comes out — no data frame enters the task
graph; the workers read the deliveries and write the outputs themselves, so every worker must
see the batch and the output folder under the same paths (a shared file system). A task whose
worker dies is retried on another (`retries`); one whose outputs cannot be written is not (the
run stops). `blockqc[dask]` installs what it needs.
"""

from __future__ import annotations

import logging
import signal
import socket
import struct
import threading
import uuid
from collections.abc import Callable
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from blockqc.errors import OutputError, Problem, UsageError

RETRIES = 2
#: the transports a dask scheduler listens on over a network
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def check_scheduler(address: str) -> str:
    """'local', or SCHEME://HOST:PORT of a running scheduler; UsageError naming what is wrong."""
    if address == "local":
        return address
    scheme, sep, rest = address.partition("://")
    host, colon, port = rest.rpartition(":")
    problem = None
    if not sep or scheme not in SCHEMES:
        problem = f"expected 'local' or {'|'.join(SCHEMES)}://HOST:PORT (e.g. tcp://10.0.0.5:8786)"
    elif not colon or not host.strip("[]"):
        problem = "expected HOST:PORT after the scheme (e.g. tcp://10.0.0.5:8786)"
    elif not (port.isdigit() and 0 < int(port) < 65536):
        problem = f"the port {port!r} is not a number from 1 to 65535"
    if problem:
        raise UsageError(f"--scheduler {address or repr(address)}: {problem}")
    return address


def _probe(address: str) -> None:
    """A tcp:// address whose host is unknown, or where nothing listens, refused at once (the
    client would try for its whole timeout); one that answers is left to the client."""
    scheme, _, rest = address.partition("://")
    if scheme != "tcp":
        return
    host, _, port = rest.rpartition(":")
    try:
        sock = socket.create_connection((host.strip("[]"), int(port)), timeout=5)
    except socket.gaierror as exc:
        raise UsageError(f"--scheduler {address}: unknown host {host} ({exc.strerror})") from None
    except TimeoutError:
        return  # slow to answer: the client waits its own timeout
    except OSError as exc:  # refused, unreachable
        why = exc.strerror or type(exc).__name__
        raise UsageError(f"--scheduler {address}: no scheduler answers there ({why})") from None
    with sock:
        if (why := _not_a_scheduler(sock)) is not None:
            raise UsageError(f"--scheduler {address}: {why}")


#: how long a scheduler may take to greet a client that connected
GREETING_S = 10.0


def _not_a_scheduler(sock: socket.socket) -> str | None:
    """Why what answers on `sock` is no Dask scheduler; None when it greets as one. A scheduler
    writes its handshake as soon as a client connects: its length first (8 bytes, a count of a
    few hundred), where a web server (the dashboard's port, 8787) waits for a request, and
    another service writes text, which dask read as a length of exabytes (MemoryError)."""
    sock.settimeout(GREETING_S)
    head = b""
    try:
        while len(head) < 8 and (part := sock.recv(8 - len(head))):
            head += part
    except TimeoutError:
        return (
            f"something answers there, but no Dask scheduler: it said nothing within "
            f"{GREETING_S:g} s, where a scheduler greets a client at once (the dashboard's "
            "port, 8787, for the scheduler's, 8786?)"
        )
    except OSError as exc:
        return f"no scheduler answers there ({exc.strerror or type(exc).__name__})"
    if len(head) < 8:
        return "no scheduler answers there (the connection was closed without a greeting)"
    if not 0 < struct.unpack("Q", head)[0] < 2**20:
        return f"something answers there, but no Dask scheduler (it began {head!r})"
    return None


def check_reachable(scheduler: str) -> None:
    """dask.distributed installed, and a tcp:// scheduler answering (`_probe`): refused
    before a run sets anything of its output folder aside or writes into it."""
    _dask()
    if scheduler != "local":
        _probe(scheduler)


def _dask():
    try:
        import dask.distributed
    except ImportError:
        raise UsageError(
            "--scheduler needs dask.distributed: pip install 'blockqc[dask]'"
        ) from None
    return dask.distributed


@contextmanager
def client_for(scheduler: str):
    """A client of the scheduler at `scheduler`, or of a LocalCluster for 'local'."""
    dd = _dask()
    Client, LocalCluster = dd.Client, dd.LocalCluster
    if scheduler == "local":
        # the scheduler's HTTP server (its dashboard) on a free port: blockqc shows its own
        # progress, and on dask's fixed default two runs on one machine contend for one port
        # (dask then warns on the console and takes another)
        # each worker process leaves Ctrl-C to this one (`dask_setup`)
        cluster = LocalCluster(
            processes=True,
            threads_per_worker=1,
            dashboard_address=":0",
            preload=[__name__],
        )
        try:
            with Client(cluster) as c, _quiet_if_stopped(c, workers=True):
                yield c
        finally:
            # a worker its nanny is starting again (one died on the last block) as the cluster
            # closes fails dask's own teardown ("can only join a started process"): every
            # outcome is in by then, and the workers are ended all the same
            with suppress(AssertionError):
                cluster.close()
            _restore_logs()
        return
    _probe(scheduler)
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, ValueError) as exc:
        raise UsageError(f"--scheduler {scheduler}: no scheduler answers there ({exc})") from None
    try:
        with client, _quiet_if_stopped(client, workers=False):
            yield client
    finally:
        _restore_logs()


#: the levels of dask's loggers in this process before a stopped run quieted them
_LEVELS: dict[str, int] = {}


def quiet_logs() -> dict[str, int]:
    """dask's loggers (`distributed`, `distributed.nanny` …) quieted to errors: a run that
    stops (Ctrl-C, SIGTERM, an output it cannot write) cancels its tasks and closes its
    cluster, of which dask's workers and nannies tell in warnings and notes ('distributed.nanny
    - WARNING - …') over blockqc's console; their earlier levels."""
    manager = logging.root.manager
    names = ["distributed", *(n for n in manager.loggerDict if n.startswith("distributed."))]
    levels = {}
    for name in names:
        logger = logging.getLogger(name)
        levels[name] = logger.level
        logger.setLevel(max(logger.level, logging.ERROR))
    return levels


def _restore_logs() -> None:
    """dask's loggers in this process as they were before the run stopped (`quiet_logs`)."""
    for name, level in _LEVELS.items():
        logging.getLogger(name).setLevel(level)
    _LEVELS.clear()


@contextmanager
def _quiet_if_stopped(client: Any, workers: bool):
    """The run's client, dask's loggers quieted (`quiet_logs`) if the run stops: in this
    process (the local cluster's nannies and scheduler, the client), and with `workers` in the
    local cluster's worker processes, whose console is blockqc's (a remote cluster's workers
    log where their own logs go: left as they are). A normal run's logs are left whole."""
    try:
        yield
    except BaseException:
        for name, level in quiet_logs().items():
            _LEVELS.setdefault(name, level)
        if workers:
            with suppress(Exception):  # a worker already gone has nothing more to say
                client.run(quiet_logs)
        raise


def dask_setup(worker: Any) -> None:
    """Run in each worker process of the local cluster as it starts (dask's `preload`): Ctrl-C,
    which a terminal sends to every process of the run, is left to blockqc's process, which
    stops the run; a worker it reached printed Python's tracebacks ('Process Dask Worker
    process (from Nanny): Traceback … KeyboardInterrupt') over the console."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_on_dask(
    scheduler: str,
    job: Callable[..., Any],
    todo: list[tuple[Path, Any]],
    done: Callable[[Any], None],
    died: Callable[[Path, Any, str], None] | None = None,
) -> None:
    """Submit one task per delivery and hand each outcome on as it arrives. The tasks' keys
    are this run's own: a scheduler shared by several runs gives a task of a key it holds the
    outcome of that task, whatever run submitted it. A task whose workers all died running it
    (the scheduler gave up on it: KilledWorker) is handed to `died` (path, manifest, why), and
    the others go on; without `died` it stops the run."""
    from dask.distributed import as_completed
    from distributed import KilledWorker

    run = uuid.uuid4().hex
    with client_for(scheduler) as client:
        futures = {
            client.submit(
                _task, job, path, manifest, key=f"inspect-{run}-{i}", retries=RETRIES, pure=False
            ): (path, manifest)
            for i, (path, manifest) in enumerate(todo)
        }
        said = set()
        try:
            for future in as_completed(futures):
                said.add(future)  # before its line: a signal may stop the run as it is out
                try:
                    outcome = future.result()
                except KilledWorker:
                    if died is None:
                        raise
                    died(*futures[future], "every worker that ran it died")
                    continue
                if isinstance(outcome, _Stopped):
                    raise OutputError(outcome.problems)
                done(outcome)
        except BaseException:  # the run stops: the tasks not begun are dropped, those running
            _finish_running(client, [f for f in futures if f not in said], done)  # end, said
            raise


def _finish_running(client: Any, left: list[Any], done: Callable[[Any], None]) -> None:
    """A run that stops: of the tasks `left`, those not yet running cancelled, those running
    waited for (as a pool's workers finish the blocks they write), and done(outcome) of each
    that finished, its outputs written whole."""
    from dask.distributed import wait

    running = {key for keys in client.processing().values() for key in keys}
    client.cancel([f for f in left if f.key not in running])
    wait([f for f in left if f.key in running])
    for future in left:
        if future.status == "finished" and not isinstance(outcome := future.result(), _Stopped):
            done(outcome)


@dataclass(frozen=True)
class _Stopped:
    """A task's outputs that could not be written: handed back, not raised, since dask runs a
    failed task again (`retries`, meant for a worker that died) and this would fail again."""

    problems: list[Problem]


def _task(job: Callable[..., Any], path: Path, manifest: Any) -> Any:
    try:
        return job(path, manifest)
    except OutputError as exc:
        return _Stopped(exc.problems)
