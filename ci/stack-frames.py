#!/usr/bin/env python3
"""Largest stack frames of a built binary's functions, from their prologues.

usage: python3 ci/stack-frames.py BINARY [REGEX] [N]

Sums the `sub $N,%rsp` and the pushes in the first 25 instructions of each function whose
mangled name matches REGEX (default: relief_core) and prints the N largest (default 10), in
bytes, x86-64 only. Frames grow past what the prologue shows only through `alloca`, which the
core never uses. Needs binutils (`nm`, `objdump`).
"""
import re
import subprocess
import sys


def main():
    binary = sys.argv[1]
    pattern = re.compile(sys.argv[2] if len(sys.argv) > 2 else "relief_core")
    count = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    names = subprocess.run(["nm", binary], capture_output=True, text=True, check=True).stdout
    symbols = sorted({p[2] for p in (l.split() for l in names.splitlines())
                      if len(p) == 3 and p[1] in "tT" and pattern.search(p[2])})
    frames = []
    for sym in symbols:
        cmd = ["objdump", "-d", "--no-show-raw-insn", "--disassemble=" + sym, binary]
        asm = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
        head = [l for l in asm.splitlines() if re.match(r"\s+[0-9a-f]+:", l)][:25]
        sub = sum(int(m.group(1), 16) for l in head
                  for m in [re.search(r"sub\s+\$0x([0-9a-f]+),%rsp", l)] if m)
        pushes = sum(1 for l in head if re.search(r"\bpush\b", l))
        frames.append((sub + 8 * pushes, sym))
    for size, sym in sorted(frames, reverse=True)[:count]:
        print(size, sym)


if __name__ == "__main__":
    main()
