"""What a connection to `vservoctl view` gets, counted byte by byte, with the standard library only (so that it
runs as any user, fed on stdin: `python3 - HOST PORT PATH SECONDS < view_probe.py`). It asks for a WebSocket
upgrade on PATH (e.g. `/?token=…`) with Foxglove's subprotocol; when upgraded, it subscribes to every channel
advertised and counts what arrives for SECONDS. Prints one JSON line: the HTTP status, every byte received,
whether a serverInfo came, the channels advertised, and the data messages and their bytes.
With `--connections N` it opens N connections at once instead and prints their HTTP statuses, in order."""

import base64
import json
import os
import socket
import struct
import sys
import time


def upgrade(host: str, port: int, path: str) -> tuple[socket.socket, int, bytes]:
    """Connects and asks for the upgrade: the socket, the HTTP status and the bytes after the headers."""
    sock = socket.create_connection((host, port), timeout=3)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                  f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                  "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n").encode())
    received = b""
    while b"\r\n\r\n" not in received:
        chunk = sock.recv(65536)
        if not chunk:
            break
        received += chunk
    head, _, rest = received.partition(b"\r\n\r\n")
    parts = head.split(b" ", 2)
    status = int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else 0
    return sock, status, received


def read_exact(sock: socket.socket, buffer: bytearray, n: int) -> bytes:
    while len(buffer) < n:
        chunk = sock.recv(65536)
        if not chunk:
            raise EOFError
        buffer.extend(chunk)
    taken = bytes(buffer[:n])
    del buffer[:n]
    return taken


def read_frame(sock: socket.socket, buffer: bytearray) -> tuple[int, bytes, int]:
    """One frame from the server (unmasked): its opcode, payload and size on the wire."""
    b0, b1 = read_exact(sock, buffer, 2)
    length, size = b1 & 0x7F, 2
    if length == 126:
        (length,), size = struct.unpack(">H", read_exact(sock, buffer, 2)), size + 2
    elif length == 127:
        (length,), size = struct.unpack(">Q", read_exact(sock, buffer, 8)), size + 8
    return b0 & 0x0F, read_exact(sock, buffer, length), size + length


def send_text(sock: socket.socket, text: str) -> None:
    """A masked text frame, as a client must send."""
    payload = text.encode()
    mask = os.urandom(4)
    header = bytes([0x81])
    if len(payload) < 126:
        header += bytes([0x80 | len(payload)])
    else:
        header += bytes([0x80 | 126]) + struct.pack(">H", len(payload))
    sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


def probe(host: str, port: int, path: str, seconds: float) -> dict:
    sock, status, received = upgrade(host, port, path)
    figures = {"status": status, "bytes": len(received), "server_info": False, "channels": 0,
               "data_messages": 0, "data_bytes": 0}
    buffer = bytearray(received.partition(b"\r\n\r\n")[2])
    end = time.monotonic() + seconds
    sock.settimeout(0.2)
    while time.monotonic() < end:
        try:
            if status != 101:
                chunk = sock.recv(65536)
                if not chunk:
                    break
                figures["bytes"] += len(chunk)
                continue
            opcode, payload, size = read_frame(sock, buffer)
        except socket.timeout:
            continue
        except (EOFError, OSError):
            break
        figures["bytes"] += size
        if opcode == 1:
            message = json.loads(payload)
            if message.get("op") == "serverInfo":
                figures["server_info"] = True
            elif message.get("op") == "advertise":
                channels = message["channels"]
                figures["channels"] += len(channels)
                send_text(sock, json.dumps({"op": "subscribe", "subscriptions": [
                    {"id": figures["channels"] - len(channels) + n + 1, "channelId": c["id"]}
                    for n, c in enumerate(channels)]}))
        elif opcode == 2 and payload[:1] == b"\x01":
            figures["data_messages"] += 1
            figures["data_bytes"] += len(payload)
        elif opcode == 8:
            break
    sock.close()
    return figures


def statuses(host: str, port: int, path: str, count: int) -> dict:
    held = []
    codes = []
    for _ in range(count):
        sock, status, _ = upgrade(host, port, path)
        held.append(sock)
        codes.append(status)
    for sock in held:
        sock.close()
    return {"statuses": codes}


if __name__ == "__main__":
    host, port, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    if sys.argv[4] == "--connections":
        print(json.dumps(statuses(host, port, path, int(sys.argv[5]))))
    else:
        print(json.dumps(probe(host, port, path, float(sys.argv[4]))))
