#!/usr/bin/env python3
"""Where an emulated flight CPU's instructions go: reads QEMU's `-d in_asm,exec,nochain`
log (every translated block's instructions, every block executed) and the image's
symbols, and prints the instructions executed per function, the most first.

    tools/flight_profile.py IMAGE LOG [--nm NM] [--top N]

Called by `tools/flight-qemu --profile N` (LOG a FIFO); the counts are QEMU's
instructions, as `-icount shift=0` counts them."""
import argparse
import bisect
import re
import subprocess
import sys


def symbols(image, nm):
    out = subprocess.run([nm, "-n", "--defined-only", image], capture_output=True, text=True, check=True).stdout
    addrs, names = [], []
    for line in out.splitlines():
        parts = line.split()
        # ($t, $a, $d: ARM's mapping symbols, not functions.)
        if len(parts) == 3 and parts[1] in "TtWw" and not parts[2].startswith("$"):
            addrs.append(int(parts[0], 16))
            names.append(parts[2])
    demangled = subprocess.run(["c++filt", "-s", "rust"], input="\n".join(names), capture_output=True,
                               text=True).stdout.splitlines()
    if len(demangled) == len(names):
        names = [re.sub(r"\[[0-9a-f]{16}\]", "", re.sub(r"::h[0-9a-f]{16}$", "", d)) for d in demangled]
        names = [d if len(d) <= 90 else "…" + d[-89:] for d in names]
    return addrs, names


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("image")
    ap.add_argument("log")
    ap.add_argument("--nm", default="nm")
    ap.add_argument("--top", type=int, default=25)
    a = ap.parse_args()
    insn = re.compile(r"^0x([0-9a-f]+):")
    trace = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
    size, runs = {}, {}
    block, n = None, 0
    with open(a.log, errors="replace") as f:
        for line in f:
            m = trace.match(line)
            if m:
                pc = int(m.group(1), 16)
                runs[pc] = runs.get(pc, 0) + 1
                continue
            if line.startswith("IN:"):
                block, n = None, 0
                continue
            m = insn.match(line)
            if m:
                if block is None:
                    block = int(m.group(1), 16)
                n += 1
                size[block] = n
                continue
            if not line.strip():
                block, n = None, 0
    addrs, names = symbols(a.image, a.nm)
    per = {}
    for pc, k in runs.items():
        i = bisect.bisect_right(addrs, pc) - 1
        name = names[i] if i >= 0 else f"0x{pc:x}"
        per[name] = per.get(name, 0) + k * size.get(pc, 0)
    total = sum(per.values())
    if total == 0:
        sys.exit("flight_profile: no executed block in the log")
    print(f"{total:,} instructions executed".replace(",", " "))
    print("| function | instructions | share |")
    print("|---|---|---|")
    for name, k in sorted(per.items(), key=lambda x: -x[1])[: a.top]:
        print(f"| `{name}` | {k:,} | {100 * k / total:.1f} % |".replace(",", " "))


if __name__ == "__main__":
    main()
