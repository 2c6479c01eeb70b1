"""Reads JSON lines of commands from stdin — each {"epoch", "mode", "joint_count", "last_tick", "command": {field:
value}} — and prints, for each, what clients/python/vservo_driver.py's `refusal` makes of it (null: taken), one
JSON line each, so that a test can hand the Rust driver side the same commands. Usage: admission.py CLIENTS_DIR"""

import json
import sys

sys.path.insert(0, sys.argv[1])

import vservo_driver  # noqa: E402

for line in sys.stdin:
    case = json.loads(line)
    command = vservo_driver.JointCommand()
    for field, value in case["command"].items():
        if isinstance(value, list):
            getattr(command, field)[:len(value)] = [float(v) if v is not None else float("nan") for v in value]
        else:
            setattr(command, field, value)
    print(json.dumps(vservo_driver.refusal(command, epoch=case["epoch"], mode=case["mode"],
                                           joint_count=case["joint_count"], last_tick=case["last_tick"])))
