"""The security review's replay, played by a process of the daemon's own user (run as that user by
tests/tests/vservod_key.rs, for a daemon of a user other than root): record the servo's sealed twists after a
step of the board it asks for (the transient, when they moved the arm), wait until the cell has converged and the
arm is at rest, measure the arm alone, SIGKILL the servo, take its writer slot while vservod restarts it, and play
the recorded moving twists again for 2 s at about 500 Hz while measuring the arm. Prints one JSON line: what was
recorded and sent, and the fastest joint alone and under the replay (rad/s).

usage: replay_attack.py INSTANCE
"""

import json
import os
import signal
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "clients", "python"))

import iceoryx2 as iox2  # noqa: E402
from vservo_client import CameraTwist, Client  # noqa: E402
from vservo_driver import JointState  # noqa: E402

SERVO = 2  # the servo's place in the status's nodes (vservo::NodeRole)


def drain(subscriber, payload):
    while True:
        sample = subscriber.receive()
        if sample is None:
            return
        yield payload.from_buffer_copy(sample.payload().contents)


def fastest(subscriber, seconds):
    until = time.monotonic() + seconds
    speed = 0.0
    while time.monotonic() < until:
        for state in drain(subscriber, JointState):
            speed = max([speed] + [abs(v) for v in state.qd_rad_s[:state.joint_count]])
        time.sleep(0.002)
    return speed


def main(instance):
    client = Client(instance)
    node = client.node
    twists = node.service_builder(client._service_name("camera_twist")).publish_subscribe(CameraTwist).open()
    states = node.service_builder(client._service_name("joint_state")).publish_subscribe(JointState).open()
    recorder = twists.subscriber_builder().create()
    # the board steps: the servo's twists move the arm while they are recorded
    client.object_step([0.0, 0.02, 0.0])
    recorded = []
    until = time.monotonic() + 30.0
    while time.monotonic() < until:
        recorded.extend(drain(recorder, CameraTwist))
        status = client.status()
        if status.feature_error_px < 1.0:
            break
        time.sleep(0.01)
    moving = [t for t in recorded if any(abs(v) > 0.01 for v in t.twist)]
    if not moving:
        raise SystemExit(f"the premise: no moving twist recorded ({len(recorded)} twists)")
    reader = states.subscriber_builder().create()
    # converged below a pixel, then settled: the arm alone at rest
    settle_until = time.monotonic() + 10.0
    while fastest(reader, 0.5) >= 0.01 and time.monotonic() < settle_until:
        pass
    alone = fastest(reader, 2.0)

    servo = client.status().nodes[SERVO].pid
    os.kill(servo, signal.SIGKILL)
    publisher = None
    deadline = time.monotonic() + 2.0
    while publisher is None:
        try:
            publisher = twists.publisher_builder().create()
        except Exception:  # the slot still held: by the dead servo's leftovers, then by its restart
            if time.monotonic() > deadline:
                raise
            time.sleep(0.0002)
    sent = 0
    attacked = 0.0
    until = time.monotonic() + 2.0
    while time.monotonic() < until:
        publisher.send_copy(moving[sent % len(moving)])
        sent += 1
        for state in drain(reader, JointState):
            attacked = max([attacked] + [abs(v) for v in state.qd_rad_s[:state.joint_count]])
        time.sleep(0.002)
    del publisher
    print(json.dumps({"recorded": len(recorded), "moving": len(moving), "sent": sent, "killed_servo": servo,
                      "alone_rad_s": alone, "attacked_rad_s": attacked}))


if __name__ == "__main__":
    main(sys.argv[1])
