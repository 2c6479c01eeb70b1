"""Reads JSON lines of events from stdin — {"gain": [...]} first, then {"mode": M, "sequence": S} or {"command":
[speeds]} — and prints, for each command, what clients/python/vservo_driver.py's `HeldCell` makes of it (null:
taken, else the refusal's kind), one JSON line each, so that a test can hand the Rust driver side the same events.
Usage: held.py CLIENTS_DIR"""

import json
import sys

sys.path.insert(0, sys.argv[1])

import vservo_driver  # noqa: E402

held = None
for line in sys.stdin:
    event = json.loads(line)
    if "gain" in event:
        held = vservo_driver.HeldCell(event["gain"])
    elif "mode" in event:
        held.cell_mode(event["mode"], event["sequence"])
    else:
        refusal = held.refusal(event["command"])
        if refusal is None:
            held.took(event["command"])
        print(json.dumps(refusal))
