"""Prints, as one JSON object, the layout of every ctypes structure the Python clients declare
(clients/python/vservo_client.py and vservo_driver.py, and any the reference drivers declare themselves) and the codes they name, so that a test can check them
against the Rust declarations they must match. Usage: dump_layouts.py CLIENTS_DIR"""

import ctypes
import json
import os
import sys

sys.path.insert(0, sys.argv[1])
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco_driver  # noqa: E402
import pybullet_driver  # noqa: E402
import vservo_client  # noqa: E402
import vservo_driver  # noqa: E402


def layout(structure):
    fields = []
    for name, _ in structure._fields_:
        descriptor = getattr(structure, name)
        fields.append([name, descriptor.offset, descriptor.size])
    return {"size": ctypes.sizeof(structure), "fields": fields}


structures = {}
for module in (vservo_client, vservo_driver, mujoco_driver, pybullet_driver):
    for value in vars(module).values():
        if isinstance(value, type) and issubclass(value, ctypes.Structure) and not value.__name__.startswith("_"):
            name = f"vservo::{value.__name__}"
            # a structure two clients declare differently is reported under the second one's module too
            if name in structures and structures[name] != layout(value):
                name = f"{name} ({module.__name__})"
            structures[name] = layout(value)

codes = {
    "schema": [vservo_client.SCHEMA_VERSION, vservo_driver.SCHEMA],
    "daemon_state": vservo_client.STATES,
    "fault": vservo_client.FAULTS,
    "command_kind": {name: getattr(vservo_client, name) for name in
                     ["TARGET_FEATURES", "TARGET_POSE", "TARGET_TEACH", "OBJECT_HOLD", "OBJECT_STEP",
                      "OBJECT_CIRCLE", "RELOAD", "RESUME", "SAFE_STOP", "MOVE_JOINTS", "SERVO", "SPEED"]},
    "command_mode": {"TORQUE": vservo_driver.TORQUE, "VELOCITY": vservo_driver.VELOCITY,
                     "POSITION": vservo_driver.POSITION},
    "driver_status": {"FOLLOWING": vservo_driver.FOLLOWING, "HOLDING": vservo_driver.HOLDING},
}
print(json.dumps({"structures": structures, "codes": codes}))
