"""Limits on what a test's subprocess *does* (its CPU time), not on how fast the machine is (wall time).

``run`` is ``subprocess.run`` with ``cpu_seconds`` in place of ``timeout``: the command is stopped when it and its
descendants have used that much CPU time, however long that takes on the wall. On a busy machine a build gets less
of the CPU and takes longer, but not more CPU, so it is never failed for the machine's load; a process stuck in a
loop uses CPU and is stopped. A process stuck without using the CPU (waiting on a lock or on the network) is stopped
after ``wall_backstop`` seconds, a bound far above any normal run (default: 20 times the CPU limit).
"""

from __future__ import annotations

import subprocess
import threading
from typing import Any

import psutil

#: How often the CPU time of the process tree is read [s].
POLL_SECONDS = 1.0


class CpuLimitExceeded(subprocess.TimeoutExpired):
    """The command used more CPU time than allowed (a ``TimeoutExpired``, so callers' handlers still apply)."""

    def __str__(self) -> str:
        return f"Command {self.cmd!r} used more than {self.timeout:g} s of CPU time (or stalled) and was stopped"


def tree_cpu_seconds(process: psutil.Process) -> float:
    """User + system CPU time of ``process``, its living descendants and its children that have ended."""
    total = 0.0
    for proc in [process, *process.children(recursive=True)]:
        try:
            t = proc.cpu_times()
        except psutil.Error:                 # ended between the listing and the reading
            continue
        total += t.user + t.system + (t.children_user + t.children_system if proc is process else 0.0)
    return total


def _kill_tree(process: psutil.Process) -> None:
    for proc in [*process.children(recursive=True), process]:
        try:
            proc.kill()
        except psutil.Error:
            pass


def run(args: Any, *, cpu_seconds: float, wall_backstop: float | None = None, input: str | None = None,
        **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(args, **kwargs)`` stopped after ``cpu_seconds`` of CPU time of the whole process tree.

    Raises :class:`CpuLimitExceeded` (a ``subprocess.TimeoutExpired``) when stopped; its ``output`` holds what the
    command printed so far when its output was captured.
    """
    wall_backstop = 20.0 * cpu_seconds if wall_backstop is None else wall_backstop
    if kwargs.pop("capture_output", False):
        kwargs.setdefault("stdout", subprocess.PIPE)
        kwargs.setdefault("stderr", subprocess.PIPE)
    check = kwargs.pop("check", False)
    if input is not None:
        kwargs["stdin"] = subprocess.PIPE
    with subprocess.Popen(args, **kwargs) as popen:
        tree = psutil.Process(popen.pid)
        stopped = threading.Event()
        finished = threading.Event()

        def _watch() -> None:
            waited = 0.0
            while not finished.wait(POLL_SECONDS):
                waited += POLL_SECONDS
                try:
                    used = tree_cpu_seconds(tree)
                except psutil.Error:
                    return
                if used > cpu_seconds or waited > wall_backstop:
                    stopped.set()
                    _kill_tree(tree)
                    return
        watcher = threading.Thread(target=_watch, daemon=True)
        watcher.start()
        try:
            stdout, stderr = popen.communicate(input)
        finally:
            finished.set()
            watcher.join()
        if stopped.is_set():
            raise CpuLimitExceeded(args, cpu_seconds, output=stdout, stderr=stderr)
        result = subprocess.CompletedProcess(args, popen.returncode, stdout, stderr)
    if check:
        result.check_returncode()
    return result
