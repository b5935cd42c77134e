"""Worker processes for runs spread over the cores."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

import cv2


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """``workers`` processes, each running OpenCV on one thread: the processes fill the cores
    already, and OpenCV's own threads (one per core in every process) would only contend
    with them for the cores. The numbers are the same on any count of threads."""
    return ProcessPoolExecutor(max_workers=workers, initializer=cv2.setNumThreads, initargs=(1,))
