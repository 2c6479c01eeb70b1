#!/usr/bin/env python3
"""Lists the longest Rust functions under the given paths (non-test code: `#[cfg(test)]` modules and tests/
directories are skipped), longest first. A function runs from its `fn` line to the line of its closing brace
at the same indentation. Usage: scripts/longest-functions.py [--top N] PATH..."""

import argparse
import pathlib
import re

FN = re.compile(r"^(\s*)(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?fn\s+(\w+)")


def functions(path: pathlib.Path):
    lines = path.read_text(encoding="utf-8").splitlines()
    skip_from = next((i for i, line in enumerate(lines) if line.strip() == "#[cfg(test)]"), len(lines))
    for i, line in enumerate(lines[:skip_from]):
        match = FN.match(line)
        if not match or line.rstrip().endswith(";"):
            continue
        indent = match.group(1)
        for j in range(i, skip_from):
            if lines[j] == indent + "}" or (j == i and line.rstrip().endswith("}")):
                yield match.group(7), i + 1, j - i + 1
                break


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=10)
    parser.add_argument("paths", nargs="+", type=pathlib.Path)
    args = parser.parse_args()
    found = []
    for root in args.paths:
        files = [root] if root.is_file() else sorted(root.rglob("*.rs"))
        for path in files:
            if "tests" in path.parts or "benches" in path.parts:
                continue
            found.extend((length, f"{path}:{line}", name) for name, line, length in functions(path))
    for length, where, name in sorted(found, reverse=True)[: args.top]:
        print(f"{length:5d}  {name}  {where}")


if __name__ == "__main__":
    main()
