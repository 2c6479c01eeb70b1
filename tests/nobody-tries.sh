#!/bin/sh
# Run as another user (nobody): tries to read, open for writing and remove each file given, and to list and
# create in each directory given. Prints one line per success, nothing when every attempt was refused.
# Used by tests/tests/vservod_isolation.rs and scripts/test-systemd.sh (inside the container). POSIX sh,
# coreutils only: a minimal Debian has them.
for f in "$@"; do
  if [ -d "$f" ]; then
    ls "$f" >/dev/null 2>&1 && echo "listed $f"
    ( : > "$f/nobody-was-here" ) 2>/dev/null && echo "created in $f"
  else
    # nocreat: a file that vanished meanwhile is not created (and then wrongly counted)
    dd if="$f" of=/dev/null count=1 2>/dev/null && echo "read $f"
    dd if=/dev/null of="$f" conv=notrunc,nocreat 2>/dev/null && echo "opened for writing $f"
    rm "$f" 2>/dev/null && echo "removed $f"
  fi
done
true
