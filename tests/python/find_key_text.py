"""Counts, as root, the copies of the seal key's text left in processes' memory.

Usage: find_key_text.py HOLDER PID...

HOLDER is a process that holds the key in binary (vservod: `SealKey { k0, k1 }`, two little-endian u64). In the
private readable memory of each PID (heap, stacks, anonymous memory, the writable data of its binaries) every
run of exactly 32 lowercase hexadecimal digits is a candidate for the key's text (`{k0:016x}{k1:016x}`, as the
daemon writes it on a node's stdin); a candidate whose binary form is in HOLDER's memory is the key. Also counts
the whole key line (`vservo-seal-key=` and 32 digits). Prints one JSON object {pid: counts}. Plain Python, no
third-party module."""

import json
import re
import sys

KEY_LINE = re.compile(rb"vservo-seal-key=[0-9a-f]{32}")
HEX_32 = re.compile(rb"(?<![0-9a-f])[0-9a-f]{32}(?![0-9a-f])")
KERNEL_MAPPINGS = ("[vvar]", "[vvar_vclock]", "[vsyscall]")


def private_memory(pid: int) -> list:
    """The bytes of every private readable mapping of `pid` (not shared memory, not the kernel's)."""
    chunks = []
    with open(f"/proc/{pid}/maps") as maps, open(f"/proc/{pid}/mem", "rb", buffering=0) as mem:
        for line in maps:
            fields = line.split()
            start, end = (int(x, 16) for x in fields[0].split("-"))
            permissions = fields[1]
            name = fields[5] if len(fields) > 5 else ""
            if permissions[0] != "r" or permissions[3] != "p" or name in KERNEL_MAPPINGS:
                continue
            try:
                mem.seek(start)
                chunks.append(mem.read(end - start))
            except (OSError, OverflowError):
                continue
    return chunks


def binary_form(hex_text: bytes) -> bytes:
    k0, k1 = int(hex_text[:16], 16), int(hex_text[16:], 16)
    return k0.to_bytes(8, "little") + k1.to_bytes(8, "little")


def main() -> None:
    holder = b"\0".join(private_memory(int(sys.argv[1])))
    result = {}
    for pid in sys.argv[2:]:
        chunks = private_memory(int(pid))
        runs = [run for chunk in chunks for run in HEX_32.findall(chunk)]
        result[pid] = {
            "key_text": sum(binary_form(run) in holder for run in runs),
            "key_lines": sum(len(KEY_LINE.findall(chunk)) for chunk in chunks),
            "hex_32_runs": len(runs),
            "bytes_scanned": sum(len(chunk) for chunk in chunks),
        }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
