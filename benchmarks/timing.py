"""Shared by the benchmark scripts: how a figure is timed, and the machine
line printed above each table."""

from __future__ import annotations

import os
import platform
import statistics
import time
import timeit


def min_seconds(function, repeat: int) -> float:
    """Minimum over ``repeat`` timeit repeats of the time per call, after one
    warm-up call (loop count from ``Timer.autorange``, ≥ 0.2 s per repeat)."""
    function()
    timer = timeit.Timer(function)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat=repeat, number=number)) / number


def _timed_calls(function, repeat: int) -> list[float]:
    """Seconds of ``repeat`` calls, after one warm-up call (imports and caches paid once)."""
    function()
    samples = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return samples


def median_seconds(function, repeat: int) -> float:
    """Median of ``repeat`` timed calls, after one warm-up call."""
    return statistics.median(_timed_calls(function, repeat))


def interleaved_medians(functions, repeat: int) -> list[float]:
    """Median seconds per call of each of ``functions``, their calls taken in
    turn (one of each, ``repeat`` times) after one warm-up call each, so that
    the shared machine's changing load falls on all of them alike: for ratios."""
    for function in functions:
        function()
    samples = [[] for _ in functions]
    for _ in range(repeat):
        for function, times in zip(functions, samples):
            start = time.perf_counter()
            function()
            times.append(time.perf_counter() - start)
    return [statistics.median(times) for times in samples]


def best_seconds(function, repeat: int) -> float:
    """Fastest of ``repeat`` timed calls, after one warm-up call (for long
    calls, where timeit's loop would take too long)."""
    return min(_timed_calls(function, repeat))


def machine(repeat: int) -> str:
    """Machine, Python and library versions, and the timing rule."""
    import numpy
    import scipy
    import xarray

    import harmbal

    return (f"machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.python_implementation()} "
            f"{platform.python_version()}, numpy {numpy.__version__}, scipy {scipy.__version__}, "
            f"xarray {xarray.__version__}, harmbal {harmbal.__version__}; min of {repeat} timeit repeats")
