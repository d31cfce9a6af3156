#!/usr/bin/env python3
"""Where an emulated flight CPU's instructions go: reads QEMU's `-d in_asm,exec,nochain`
log (every translated block's instructions, every block executed) and the image's
symbols, and prints the instructions executed per function, the most first.

    tools/flight_profile.py IMAGE LOG [--nm NM] [--top N] [--lines PATTERN]

--lines PATTERN also prints, for the functions whose name holds PATTERN (or one of its
`|`-separated alternatives), the instructions executed per source line (llvm-addr2line: the innermost inlined frame in the project's own code).

Called by `tools/flight-qemu --profile N` (LOG a FIFO); the counts are QEMU's
instructions, as `-icount shift=0` counts them."""
import argparse
import bisect
import json
import re
import shutil
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
    ap.add_argument("--lines", default=None)
    a = ap.parse_args()
    insn = re.compile(r"^0x([0-9a-f]+):")
    trace = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
    size, runs, pcs = {}, {}, {}
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
                    # A block translated again starts its list afresh.
                    pcs[block] = []
                n += 1
                size[block] = n
                pcs[block].append(int(m.group(1), 16))
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
    print(f"{total:,} instructions executed\n".replace(",", " "))
    print("| function | instructions | share |")
    print("|---|---|---|")
    for name, k in sorted(per.items(), key=lambda x: -x[1])[: a.top]:
        print(f"| `{name}` | {k:,} | {100 * k / total:.1f} % |".replace(",", " "))
    if a.lines:
        source_lines(a, addrs, names, runs, pcs)


def source_lines(a, addrs, names, runs, pcs):
    """Instructions per source line inside the functions whose name holds one of a.lines's
    `|`-separated alternatives."""
    wanted = a.lines.split("|")
    per_pc = {}
    for block, k in runs.items():
        i = bisect.bisect_right(addrs, block) - 1
        if i < 0 or not any(w in names[i] for w in wanted):
            continue
        for pc in pcs.get(block, []):
            per_pc[pc] = per_pc.get(pc, 0) + k
    if not per_pc:
        return
    order = sorted(per_pc)
    if shutil.which("llvm-addr2line") is None:
        print(f"\n(no per-line table for `{a.lines}`: it needs llvm-addr2line, Debian's package llvm)")
        return
    out = subprocess.run(["llvm-addr2line", "-i", "--output-style=JSON", "-e", a.image]
                         + [hex(pc) for pc in order], capture_output=True, text=True).stdout
    recs = []
    for line in out.splitlines():
        r = json.loads(line) if line.strip() else []
        recs.extend(r if isinstance(r, list) else [r])
    per_line = {}
    for pc, rec in zip(order, recs):
        # The innermost frame in the project's own code (not the iterator or the
        # arithmetic of core and nalgebra inlined into it).
        frames = rec.get("Symbol", [])
        own = [f for f in frames if "/crates/" in f.get("FileName", "") or "/tools/" in f.get("FileName", "")]
        f = (own or frames or [{}])[0]
        loc = re.sub(r".*/crates/taiji-core/src/", "", f.get("FileName", "?"))
        loc = re.sub(r".*/(crates|tools)/", r"\1/", loc) + f":{f.get('Line', 0)}"
        per_line[loc] = per_line.get(loc, 0) + per_pc[pc]
    total = sum(per_line.values())
    named = ", ".join(f"`{w.split('::')[-1]}`" for w in a.lines.split("|"))
    total_s = f"{total:,}".replace(",", " ")
    print(f"\n{total_s} instructions in the functions named {named}, per source line (of crates/taiji-core/src)\n")
    print("| line | instructions | share |")
    print("|---|---|---|")
    for loc, k in sorted(per_line.items(), key=lambda x: -x[1])[: a.top * 2]:
        print(f"| `{loc}` | {k:,} | {100 * k / total:.1f} % |".replace(",", " "))


if __name__ == "__main__":
    main()
