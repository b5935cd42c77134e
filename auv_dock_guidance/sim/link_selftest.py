"""The bridge against the simulated main controller over a real pseudo-terminal.

Measures what a bench test of the serial link would: frames each way, CRC errors, the
command -> telemetry round trip (a command's sequence number echoed back in telemetry),
and the failsafe time: from the last command guidance sent to the first neutral command
the controller received.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.link.bridge import LinkBridge
from auv_dock_guidance.link.protocol import TelemetryMsg
from auv_dock_guidance.link.transport import SerialTransport
from auv_dock_guidance.sim.main_controller import MainControllerSim


@dataclass(frozen=True)
class SelftestReport:
    frames_sent: int
    frames_received: int
    crc_errors: int
    roundtrip_ms_p50: float | None
    roundtrip_ms_p95: float | None
    failsafe_ms: float | None
    controller_crc_errors: int


def run_selftest(
    seconds: float = 3.0, command_hz: float = 30.0, tick_hz: float = 50.0,  # the node's tick rate
    progress: Callable[[int, int], None] | None = None,
) -> SelftestReport:
    with MainControllerSim() as controller:
        bridge = LinkBridge(SerialTransport(controller.port))
        bridge.set_armed(True)
        sent_at: dict[int, float] = {}
        roundtrips: list[float] = []
        received = 0
        start = time.monotonic()
        next_command = start
        step = 0
        total_steps = int(seconds * command_hz)
        while step < total_steps:
            now = time.monotonic()
            if now >= next_command:
                pwm = 1500 + 300 * math.sin(step / 10.0)
                bridge.command([pwm, 3000 - pwm, pwm, 3000 - pwm])
                sent_at[bridge.last_command_seq] = time.monotonic()
                next_command += 1.0 / command_hz
                step += 1
                if progress is not None:
                    progress(step, total_steps)
            for frame in bridge.tick():
                received += 1
                msg = frame.message
                if isinstance(msg, TelemetryMsg) and msg.last_command_seq in sent_at:
                    roundtrips.append(time.monotonic() - sent_at.pop(msg.last_command_seq))
            time.sleep(1.0 / tick_hz)
        failsafe_ms = _wait_for_neutral(bridge, controller, bridge.last_command_time, tick_hz)
        bridge.transport.close()
    return SelftestReport(
        frames_sent=bridge.stats.frames_sent,
        frames_received=received,
        crc_errors=bridge.decoder.stats.crc_errors,
        roundtrip_ms_p50=float(np.percentile(roundtrips, 50) * 1000) if roundtrips else None,
        roundtrip_ms_p95=float(np.percentile(roundtrips, 95) * 1000) if roundtrips else None,
        failsafe_ms=failsafe_ms,
        controller_crc_errors=controller.decoder.stats.crc_errors,
    )


def _wait_for_neutral(bridge: LinkBridge, controller: MainControllerSim, since: float, tick_hz: float) -> float | None:
    """Keep ticking without commands; when did the controller first receive neutral?"""
    deadline = since + 2.0
    while time.monotonic() < deadline:
        bridge.tick()
        for record in controller.records():
            if record.time_s > since and record.pwm_us == (1500, 1500, 1500, 1500):
                return (record.time_s - since) * 1000.0
        threading.Event().wait(1.0 / tick_hz)
    return None
