"""The time limits of the test suite judge what a call does (CPU time), not how busy the machine is."""

import sys

import pytest

import cpu_limits


def test_a_subprocess_that_loops_is_stopped_by_its_cpu_time():
    with pytest.raises(cpu_limits.CpuLimitExceeded, match="CPU time"):
        cpu_limits.run([sys.executable, "-c", "while True: pass"], cpu_seconds=1.0)


def test_a_subprocess_that_waits_off_the_cpu_is_not_stopped_before_the_backstop():
    done = cpu_limits.run([sys.executable, "-c", "import time; time.sleep(2.5); print('slept')"], cpu_seconds=1.0,
                          capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.strip() == "slept"
    with pytest.raises(cpu_limits.CpuLimitExceeded):
        cpu_limits.run([sys.executable, "-c", "import time; time.sleep(60)"], cpu_seconds=5.0, wall_backstop=2.0)


def test_the_cpu_time_of_children_counts():
    """A build's work is done by its children (a kernel, xelatex): their loops count against the limit."""
    child = "import subprocess, sys; subprocess.run([sys.executable, '-c', 'while True: pass'])"
    with pytest.raises(cpu_limits.CpuLimitExceeded):
        cpu_limits.run([sys.executable, "-c", child], cpu_seconds=1.0)
