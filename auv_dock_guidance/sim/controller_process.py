"""The simulated main controller and its vehicle in a process of their own, as on a vehicle.

A real main controller is another computer: its telemetry keeps its rate however busy the
guidance computer is. In the process that also spins ROS, records bags and decodes images,
the simulator's thread waited for the interpreter often enough under load to miss the
0.5 s telemetry deadline, and guidance rightly aborted on a fault of the simulation. Here
the controller thread runs in a child process; the parent reads the vehicle pose from
shared memory and sends fault injections and repositions through a pipe.
"""

from __future__ import annotations

import multiprocessing
import shutil
import signal
import tempfile
import threading
from dataclasses import astuple
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from auv_dock_guidance.sim.main_controller import CommandRecord, MainControllerSim
from auv_dock_guidance.sim.vehicle import AuvDynamics
from auv_dock_guidance.sim.world import VehiclePose

_START_TIMEOUT_S = 20.0  # a spawned interpreter imports numpy and the simulator first
_POLL_S = 0.005  # how often the child publishes the pose and looks for requests


class ControllerProcess:
    """``port`` (the link the serial bridge opens) exists once ``start`` returns.

    ``pose`` is the vehicle's newest pose; the fault injections of ``MainControllerSim``
    (``inject``, ``pause_telemetry``, ``unplug``) and ``records`` work as on the thread.
    ``link``: where to put the link; default a private temporary folder, removed by ``stop``.
    """

    def __init__(self, start: VehiclePose, seed: int, link: Path | None = None) -> None:
        self._own_folder = None if link is not None else tempfile.mkdtemp(prefix="main-controller-")
        link = link if link is not None else Path(self._own_folder, "main_controller")  # type: ignore[arg-type]
        self.port = str(link)
        self._context = multiprocessing.get_context("spawn")  # no forked copy of rclpy or of threads
        self._pose = self._context.Array("d", astuple(start))
        self._start_pose, self._seed, self._link = start, seed, link
        self._conn: Connection | None = None
        self._process: multiprocessing.process.BaseProcess | None = None
        self._lock = threading.Lock()  # one request and its answer at a time

    def start(self) -> ControllerProcess:
        parent, child = self._context.Pipe()
        process = self._context.Process(
            target=_serve, args=(child, self._pose, self._start_pose, self._seed, self._link),
            name="main-controller-sim", daemon=True)
        process.start()  # if this raises, there is no child for stop() to end: its error is the one to see
        self._process = process
        child.close()
        self._conn = parent
        if not parent.poll(_START_TIMEOUT_S):
            self.stop()
            raise RuntimeError(f"the simulated main controller did not start within {_START_TIMEOUT_S:.0f} s")
        reply = parent.recv()
        if isinstance(reply, BaseException):
            self.stop()
            raise reply
        return self

    @property
    def pose(self) -> VehiclePose:
        with self._pose.get_lock():
            return VehiclePose(*self._pose[:])

    def reposition(self, pose: VehiclePose) -> None:
        """A new start, at rest."""
        self._send("reposition", pose)

    def inject(self, data: bytes) -> None:
        self._send("inject", data)

    def pause_telemetry(self, seconds: float) -> None:
        self._send("pause_telemetry", seconds)

    def unplug(self, seconds: float) -> None:
        self._send("unplug", seconds)

    def records(self) -> list[CommandRecord]:
        return self._send("records", None)

    def stop(self) -> None:
        """Neutral and gone: the child removes its terminal and link before it exits."""
        if self._process is not None:
            self._end_child(self._process)
            self._process = None
        if self._own_folder is not None:
            shutil.rmtree(self._own_folder, ignore_errors=True)

    def _end_child(self, process: multiprocessing.process.BaseProcess) -> None:
        if self._conn is not None:
            try:
                self._send("stop", None)
            except (OSError, EOFError):
                pass  # already gone
            self._conn.close()
            self._conn = None
        process.join(timeout=3.0)
        if process.is_alive():
            process.kill()
            process.join(timeout=2.0)

    def _send(self, request: str, argument: Any) -> Any:
        if self._conn is None:
            raise RuntimeError("the simulated main controller is not running")
        with self._lock:
            self._conn.send((request, argument))
            reply = self._conn.recv()
        if isinstance(reply, BaseException):
            raise reply
        return reply


def _serve(conn: Connection, shared_pose: Any, start: VehiclePose, seed: int, link: Path) -> None:
    """The child: the controller thread runs; this loop mirrors the pose and answers the parent."""
    for sig in (signal.SIGINT, signal.SIGHUP):
        signal.signal(sig, signal.SIG_IGN)  # the parent stops us after its nodes, neutral last
    vehicle = AuvDynamics(start, seed=seed)
    try:
        controller = MainControllerSim(vehicle=vehicle, link=link).start()
    except OSError as exc:
        conn.send(exc)
        return
    conn.send("ready")
    try:
        while True:
            _mirror(vehicle, shared_pose)
            if not conn.poll(_POLL_S):
                continue
            request, argument = conn.recv()
            if request == "stop":
                break
            reply = _answer(controller, vehicle, request, argument)
            _mirror(vehicle, shared_pose)  # a reposition is seen as soon as it is answered
            conn.send(reply)
    except (EOFError, OSError):
        pass  # the parent is gone: stop too
    finally:
        controller.stop()
    try:
        conn.send(None)
    except OSError:
        pass


def _mirror(vehicle: AuvDynamics, shared_pose: Any) -> None:
    with shared_pose.get_lock():
        shared_pose[:] = astuple(vehicle.pose)


def _answer(controller: MainControllerSim, vehicle: AuvDynamics, request: str, argument: Any) -> Any:
    if request == "records":
        return controller.records()
    if request == "reposition":
        vehicle.pose = argument
        vehicle.velocity[:] = 0.0
        vehicle.rates[:] = 0.0
    elif request == "inject":
        controller.inject(argument)
    elif request == "pause_telemetry":
        controller.pause_telemetry(argument)
    elif request == "unplug":
        controller.unplug(argument)
    else:
        return ValueError(f"unknown request {request!r}")
    return None
