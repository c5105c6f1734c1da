"""Where the shots run: in this process, in spawned local worker processes, or on a Dask cluster.

Each runner yields ``(task, record)`` as shots finish. Local workers die with the export
(:func:`_exit_with_parent`); a cluster's workers are the cluster's and never write into OUTDIR.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import multiprocessing.connection
import os
import re
import signal
import socket
import sys
import threading
from concurrent.futures import ProcessPoolExecutor, as_completed

from mrcheck.apps.export.shot import run_shot
from mrcheck.apps.export.tasks import lost
from mrcheck.core.errors import MrcheckError

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
SCHEDULER_TIMEOUT = "30s"  # how long to try reaching --scheduler before giving up


def _worker_init(gl_threads: int | None) -> None:
    _exit_with_parent()
    # llvmpipe rasterises with one thread per core; N processes on the same cores share them
    if gl_threads and "LP_NUM_THREADS" not in os.environ:
        os.environ["LP_NUM_THREADS"] = str(gl_threads)


def _exit_with_parent() -> None:
    """End this worker when the export that spawned it dies (``kill -9``, OOM killer). Otherwise it
    finishes the shots already queued to it, writing into OUTDIR while a rerun works there, and
    then waits for more forever.

    Linux: the kernel's parent-death signal, at once, even in a long GL call that holds the GIL.
    It is sent when the *thread* that started this process ends; ProcessPoolExecutor starts its
    workers in the thread that submits the shots, which holds the pool until it is shut down.
    Everywhere, and for a parent already gone before prctl: multiprocessing's parent sentinel, a
    pipe from the parent that reads end-of-file once the parent has exited, watched by a thread.
    """
    parent = multiprocessing.parent_process()
    if parent is None:  # not started by multiprocessing: no parent to follow
        return
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    threading.Thread(target=_exit_on_eof, args=(parent.sentinel,), name="mrcheck-parent-watch", daemon=True).start()


def _exit_on_eof(sentinel) -> None:
    multiprocessing.connection.wait([sentinel])
    os._exit(1)  # no cleanup: every file is written atomically, a rerun removes the temp files


def local_workers(workers: int, shots: int) -> int:
    """Processes :func:`run_local` uses: 1 (this one) for one shot or one worker."""
    return 1 if workers <= 1 or shots <= 1 else min(workers, shots)


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """``workers`` spawned processes that die with this one, each giving llvmpipe its share of
    the cores (the export's shots; ``mrcheck regress``'s views)."""
    threads = max(1, (os.cpu_count() or 1) // workers)
    return ProcessPoolExecutor(
        max_workers=workers,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=_worker_init,
        initargs=(threads,),
    )


def run_local(tasks, workers: int, scene=None):
    """The shots in this process (``scene``: the job's loaded Scene) or in spawned workers, each
    with its own EGL context, keeping its scene and Renderer across shots."""
    workers = local_workers(workers, len(tasks))
    if workers == 1:
        for task in tasks:
            yield task, run_shot(task, scene)
        return
    with worker_pool(workers) as pool:
        futures = {pool.submit(run_shot, task): task for task in tasks}
        for future in as_completed(futures):
            task = futures[future]
            try:
                yield task, future.result()
            except Exception as exc:  # the worker process died (BrokenProcessPool) or could not start
                yield task, lost(task, exc)


def connect(address: str):
    """A Dask client of the scheduler at ``address``; a bad or unreachable address is a one-line error."""
    try:
        from distributed import Client
    except ImportError:
        raise MrcheckError("--scheduler needs Dask distributed: pip install 'mrcheck[cluster]'") from None
    # Dask retries a refused connection until its timeout (30 s); a plain TCP connect answers a
    # closed port or an unknown host at once
    match = re.fullmatch(r"(?:tcp://)?\[?([^\]/]+?)\]?:(\d+)/?", address.strip())
    if match:
        try:
            socket.create_connection((match[1], int(match[2])), timeout=5).close()
        except (OSError, ValueError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
            raise MrcheckError(f"cannot connect to the Dask scheduler at {address} ({reason})") from None
    try:
        return Client(address, timeout=SCHEDULER_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as exc:
        raise MrcheckError(f"cannot connect to the Dask scheduler at {address} ({exc})") from None


def run_dask(tasks, client):
    """The shots on the cluster of ``client``; its workers return the files, written here."""
    from distributed import as_completed as dask_completed

    futures = client.map(run_shot, tasks, pure=False)
    owner = {f.key: t for f, t in zip(futures, tasks)}
    for future in dask_completed(futures):
        task = owner[future.key]
        try:
            record = future.result()
        except Exception as exc:  # a worker died or could not unpickle the task
            record = lost(task, exc)
        future.release()
        yield task, record


__all__ = ["run_local", "run_dask", "connect", "local_workers", "worker_pool", "SCHEDULER_TIMEOUT"]
