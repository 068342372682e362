"""Where the independent runs of an experiment execute: local processes (default) or a Ray cluster.

A run is a pure function of its EvolutionConfig, so both backends give bit-identical run folders for the same
seeds; the backend only decides where the work happens.  Every run checkpoints each generation, so an
interrupted experiment (Ctrl-C, a lost node) loses at most one generation per run when it is started again.
Local workers die with the experiment process, even when it is killed by SIGKILL (`die_with_parent`), and each
run holds its folder's lock while it writes, so a rerun never works beside the orphans of a killed one.

With Ray on more than one machine the experiment folder must be on a file system every node sees (NFS, a
mounted bucket): the runs write their files there, as they do locally.
"""
from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import get_context
from pathlib import Path
from typing import Any

BACKENDS = ("local", "ray")

Task = tuple[str, dict[str, Any], str]  # (run name, EvolutionConfig dict, run folder)


def run_one(config: dict[str, Any], run_dir: str, threads: int = 1) -> dict[str, Any]:
    """Run (or finish, or just read) one training run, holding its folder's lock; returns its summary."""
    import numba

    from ..storage.files import read_json_object
    from ..storage.folder_lock import folder_lock
    from ..training.config import EvolutionConfig
    from ..training.trainer import Trainer

    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    cfg = EvolutionConfig.from_mapping(config)
    out = Path(run_dir)
    with folder_lock(out, "run folder"):
        # a run killed before its first checkpoint has only its config.json: resuming starts it over
        resume = (out / "checkpoint.json").exists() or (out / "config.json").exists()
        trainer = Trainer(cfg, out, resume=resume)
        if resume and trainer.done() and (out / "summary.json").exists():
            try:
                summary = read_json_object(out / "summary.json", "summary")
            except ValueError:
                summary = {}  # a damaged summary is rewritten from the checkpoint below
            if summary.get("generations") == trainer.generation:
                return summary
        return trainer.run()


#: seconds between a worker's checks that its parent is still alive (where the kernel cannot tell it)
PARENT_POLL_SECONDS = 1.0


def die_with_parent(parent_pid: int) -> None:
    """Worker initializer: end this worker when the experiment process that started it dies, even by SIGKILL,
    so no orphan keeps writing into the run folders beside a rerun's workers.

    On Linux the kernel sends SIGKILL at the parent's death (prctl PR_SET_PDEATHSIG); everywhere a daemon thread
    also polls the parent pid (an orphan is re-parented, so its parent pid changes).  Runs checkpoint
    atomically, so a worker killed mid-generation loses only that generation.
    """
    import signal
    import threading

    if sys.platform.startswith("linux"):
        import ctypes

        PR_SET_PDEATHSIG = 1
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass  # the watchdog below still ends the worker
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)

    def watchdog() -> None:
        while True:
            time.sleep(PARENT_POLL_SECONDS)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watchdog, name="mahn-parent-watchdog", daemon=True).start()


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=5)


def _threads_per_run(workers: int) -> int:
    return max(1, (os.cpu_count() or 1) // max(1, workers))


def map_in_processes(fn: Callable[..., Any], items: Sequence[tuple], workers: int) -> list[Any]:
    """[fn(*item) for item in items], on up to `workers` fresh processes (spawned, ended with this one) when
    there is more than one item and worker; `fn` must be a module-level function.  For the report's independent,
    deterministic pieces of work (each champion's transfer tests): the results are those of the serial loop,
    in the items' order."""
    if workers <= 1 or len(items) <= 1:
        return [fn(*item) for item in items]
    pool = ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=get_context("spawn"),
                               initializer=die_with_parent, initargs=(os.getpid(),))
    try:
        futures = [pool.submit(fn, *item) for item in items]
        try:
            return [f.result() for f in futures]
        except BrokenProcessPool as exc:
            raise RuntimeError("a worker process died (killed, or out of memory) during the report; the runs are "
                               "saved: run the command again with --report-only") from exc
    finally:
        _stop_workers(pool)


def run_local(tasks: Sequence[Task], workers: int, on_done: Callable[[str, dict], None] | None = None
              ) -> dict[str, dict[str, Any]]:
    """Runs in `workers` fresh processes (spawned: numba's thread pools do not survive a fork)."""
    threads = _threads_per_run(workers)
    results: dict[str, dict[str, Any]] = {}
    errors: dict[str, str] = {}
    if workers <= 1:
        for name, cfg, folder in tasks:
            try:
                results[name] = run_one(cfg, folder, threads)
            except Exception as exc:  # keep going: the other runs are independent
                errors[name] = f"{type(exc).__name__}: {exc}"
                continue
            if on_done:
                on_done(name, results[name])
    else:
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"), initializer=die_with_parent,
                                   initargs=(os.getpid(),))
        try:
            pending = {pool.submit(run_one, cfg, folder, threads): name for name, cfg, folder in tasks}
            while pending:
                # a timeout keeps the main process responsive to Ctrl-C / SIGTERM while runs go on
                done, _ = wait(pending, timeout=1.0, return_when=FIRST_COMPLETED)
                for fut in done:
                    name = pending.pop(fut)
                    try:
                        results[name] = fut.result()
                    except BrokenProcessPool as exc:
                        raise RuntimeError("a worker process died (killed, or out of memory); every run's last "
                                           "finished generation is saved: run the same command again to resume"
                                           ) from exc
                    except Exception as exc:
                        errors[name] = f"{type(exc).__name__}: {exc}"
                        continue
                    if on_done:
                        on_done(name, results[name])
        except BaseException:
            _stop_workers(pool)  # runs checkpoint atomically, so stopping mid-generation loses only that one
            raise
        pool.shutdown()
    _raise_errors(errors)
    return results


def run_ray(tasks: Sequence[Task], workers: int, address: str | None = None,
            on_done: Callable[[str, dict], None] | None = None) -> dict[str, dict[str, Any]]:
    """Runs as Ray tasks: on a running cluster (`address`) or on a local Ray instance of `workers` CPUs."""
    try:
        import ray
    except ImportError as exc:
        raise ValueError("the ray backend needs Ray: pip install 'mahn[distributed]'") from exc
    started_here = not ray.is_initialized()
    if started_here:
        if address:
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        else:
            ray.init(num_cpus=max(1, workers), include_dashboard=False, log_to_driver=False)
    threads = 1 if address else _threads_per_run(workers)
    remote = ray.remote(num_cpus=threads, max_retries=2)(run_one)
    refs = {remote.remote(cfg, str(Path(folder).resolve()), threads): name for name, cfg, folder in tasks}
    results: dict[str, dict[str, Any]] = {}
    errors: dict[str, str] = {}
    try:
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                name = refs.pop(ref)
                try:
                    results[name] = ray.get(ref)
                except Exception as exc:
                    errors[name] = f"{type(exc).__name__}: {exc}"
                    continue
                if on_done:
                    on_done(name, results[name])
    finally:
        for ref in refs:
            ray.cancel(ref, force=True)
        if started_here:
            ray.shutdown()
    _raise_errors(errors)
    return results


def _raise_errors(errors: dict[str, str]) -> None:
    if errors:
        lines = "; ".join(f"{k}: {v}" for k, v in sorted(errors.items()))
        raise RuntimeError(f"{len(errors)} run(s) failed (the others are saved; run the command again to retry "
                           f"them): {lines}")


def run_tasks(tasks: Sequence[Task], backend: str = "local", workers: int = 2, address: str | None = None,
              on_done: Callable[[str, dict], None] | None = None) -> dict[str, dict[str, Any]]:
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if backend == "ray":
        return run_ray(tasks, workers, address, on_done)
    return run_local(tasks, workers, on_done)
