"""Tries to read other processes' memory as this (non-root) user can, the way the issue-22 campaign read the
seal key: for each `PID:ADDRESS` argument it reads /proc/PID/maps, opens /proc/PID/mem and reads 16 bytes at
ADDRESS (a mapped address the caller took from the maps as root), and calls process_vm_readv there.

First it asserts nothing itself: it starts a process of its own user (`sleep`, dumpable) and does the same to
it, so that the caller can check that these reads do work here (the premise). Prints one JSON object:
{"premise": {...}, "targets": [{...}, ...]}; each with what every attempt gave (bytes read, or the error).
Plain Python, no third-party module (run with any interpreter this user can run)."""

import ctypes
import json
import os
import subprocess
import sys
import time


class IoVec(ctypes.Structure):
    _fields_ = [("base", ctypes.c_void_p), ("length", ctypes.c_size_t)]


LIBC = ctypes.CDLL(None, use_errno=True)
LIBC.process_vm_readv.argtypes = [ctypes.c_int, ctypes.POINTER(IoVec), ctypes.c_ulong,
                                  ctypes.POINTER(IoVec), ctypes.c_ulong, ctypes.c_ulong]
LIBC.process_vm_readv.restype = ctypes.c_ssize_t

READ_BYTES = 16


def refused(error: OSError) -> dict:
    return {"ok": False, "error": f"{type(error).__name__} errno {error.errno} ({error.strerror})"}


def read_maps(pid: int) -> dict:
    try:
        with open(f"/proc/{pid}/maps") as maps:
            lines = maps.read().splitlines()
    except OSError as error:
        return refused(error)
    readable = [line for line in lines if line.split()[1].startswith("r")]
    first = int(readable[0].split("-")[0], 16) if readable else None
    return {"ok": True, "lines": len(lines), "first_readable": first}


def read_mem(pid: int, address: int) -> dict:
    try:
        mem = open(f"/proc/{pid}/mem", "rb", buffering=0)
    except OSError as error:
        return {"open": refused(error), "read": {"ok": False, "error": "not opened"}}
    with mem:
        try:
            mem.seek(address)
            data = mem.read(READ_BYTES)
        except OSError as error:
            return {"open": {"ok": True}, "read": refused(error)}
    return {"open": {"ok": True}, "read": {"ok": True, "bytes": len(data)}}


def vm_readv(pid: int, address: int) -> dict:
    buffer = ctypes.create_string_buffer(READ_BYTES)
    local = IoVec(ctypes.cast(buffer, ctypes.c_void_p), READ_BYTES)
    remote = IoVec(ctypes.c_void_p(address), READ_BYTES)
    count = LIBC.process_vm_readv(pid, ctypes.byref(local), 1, ctypes.byref(remote), 1, 0)
    if count < 0:
        errno = ctypes.get_errno()
        return {"ok": False, "error": f"errno {errno} ({os.strerror(errno)})"}
    return {"ok": True, "bytes": count}


def probe(pid: int, address: int) -> dict:
    maps = read_maps(pid)
    return {"pid": pid, "address": address, "maps": maps, "mem": read_mem(pid, address),
            "process_vm_readv": vm_readv(pid, address)}


def main() -> None:
    sleeper = subprocess.Popen(["sleep", "30"])
    time.sleep(0.2)  # past its start-up: the maps of a running `sleep`
    try:
        own = read_maps(sleeper.pid)
        premise = probe(sleeper.pid, own.get("first_readable") or 0)
    finally:
        sleeper.kill()
        sleeper.wait()
    targets = []
    for argument in sys.argv[1:]:
        pid, address = argument.split(":")
        targets.append(probe(int(pid), int(address, 16)))
    print(json.dumps({"uid": os.geteuid(), "premise": premise, "targets": targets}))


if __name__ == "__main__":
    main()
