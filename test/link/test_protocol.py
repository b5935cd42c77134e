import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auv_dock_guidance.link.protocol import (
    ArmMsg,
    HeartbeatMsg,
    StreamDecoder,
    TelemetryMsg,
    ThrusterCommandMsg,
    crc16_ccitt,
    encode,
)

MESSAGES = [
    ThrusterCommandMsg((1100, 1500, 1900, 1600), True),
    HeartbeatMsg(1, 2, 123456),
    ArmMsg(True),
    TelemetryMsg(1000, 0.1, -0.2, 3.0, 2.5, 0.01, 0.02, -0.03, 3, (1500, 1510, 1490, 1500), 7),
]


def test_crc_matches_the_ccitt_false_check_value():
    assert crc16_ccitt(b"123456789") == 0x29B1


@pytest.mark.parametrize("message", MESSAGES)
def test_every_message_round_trips(message):
    frames = StreamDecoder().feed(encode(message, 42))
    assert len(frames) == 1 and frames[0].seq == 42
    got = frames[0].message
    if isinstance(message, TelemetryMsg):
        assert got.applied_pwm_us == message.applied_pwm_us and abs(got.yaw - message.yaw) < 1e-6
    else:
        assert got == message


def test_frames_split_across_reads_are_reassembled():
    data = b"".join(encode(m, i) for i, m in enumerate(MESSAGES))
    decoder = StreamDecoder()
    frames = []
    for i in range(len(data)):
        frames += decoder.feed(data[i : i + 1])
    assert len(frames) == len(MESSAGES)


def test_bad_crc_and_wrong_length_are_rejected_and_counted():
    good = encode(MESSAGES[0], 1)
    corrupted = bytearray(good)
    corrupted[8] ^= 0xFF
    wrong_length = bytearray(encode(MESSAGES[2], 2))
    wrong_length[3] = 5
    decoder = StreamDecoder()
    frames = decoder.feed(bytes(corrupted) + bytes(wrong_length) + good)
    assert len(frames) == 1
    assert decoder.stats.crc_errors == 1 and decoder.stats.length_errors == 1


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.binary(max_size=40), st.sampled_from(MESSAGES)), min_size=1, max_size=20))
def test_every_valid_frame_in_random_garbage_is_recovered(chunks):
    stream = b"".join(garbage + encode(message, i) for i, (garbage, message) in enumerate(chunks))
    frames = StreamDecoder().feed(stream)
    recovered = [f.seq for f in frames]
    for i in range(len(chunks)):
        assert i in recovered


def test_long_random_stream_never_crashes_and_keeps_the_buffer_bounded():
    rng = random.Random(5)
    decoder = StreamDecoder(max_buffer=4096)
    sent = 0
    found = 0
    for i in range(3000):
        found += len(decoder.feed(rng.randbytes(rng.randint(0, 50))))
        if i % 3 == 0:
            found += len(decoder.feed(encode(MESSAGES[i % 4], i)))
            sent += 1
        assert len(decoder._buffer) <= 4096 + 64
    assert found >= sent
    assert decoder.stats.bytes_dropped > 0
