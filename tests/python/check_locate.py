"""The Python client's rule for where an instance is (`decide_location`), case by case as vservoctl's
(`InstanceDir::locate`, crates/vservo-protocol/src/instance_dir.rs): the user's own instance wherever it is,
another user's only when none is ours. Prints "ok: N cases" or fails with the case."""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "clients", "python"))

from vservo_client import decide_location  # noqa: E402

SYSTEM_CLOSED = ("closed", 0, "/run/vservo")
OWN = ("ours", 65534, "/tmp/vservo-65534/x")
OWN_SYSTEM = ("ours", 999, "/run/vservo/x")
OTHERS = ("other", 999, "/run/vservo/x")
ABSENT = ("absent", None, "/tmp/vservo-65534/x")

CASES = [
    # the system's /run/vservo exists (root's, closed to this user); the user's daemon runs under /tmp
    ([SYSTEM_CLOSED, OWN], OWN),
    # the user's own instance under /run/vservo (the system service's user) comes first
    ([OWN_SYSTEM, OWN], OWN_SYSTEM),
    ([ABSENT, OWN], OWN),
    # another user is named only when no place holds one of ours
    ([SYSTEM_CLOSED, ABSENT], SYSTEM_CLOSED),
    ([OTHERS, ABSENT], OTHERS),
    # an instance seen to be another user's tells more than a closed base that may hold one
    ([SYSTEM_CLOSED, OTHERS], OTHERS),
    ([ABSENT, ABSENT], None),
    ([], None),
]

for sightings, expected in CASES:
    found = decide_location(sightings)
    assert found == expected, f"{sightings}: {found}, expected {expected}"
print(f"ok: {len(CASES)} cases")
