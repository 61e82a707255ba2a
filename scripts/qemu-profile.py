#!/usr/bin/env python3
"""Guest instructions per symbol from a QEMU exec log: how the profile in BENCHMARKS.md was made.

    scripts/firmware.sh --cycles 2 --build-only --elf-out /tmp/fw.elf specs/paper-limits.toml
    qemu-system-arm -M xilinx-zynq-a9 -nographic -monitor none \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -d in_asm,exec,nochain -D /tmp/q.log -kernel /tmp/fw.elf
    scripts/qemu-profile.py /tmp/q.log

`in_asm` gives each translated block's instruction count, `exec` each execution of a block with its
symbol; the product, summed per symbol, is the instructions spent there (the calibration loop in
`main` included).
"""
import collections
import re
import sys


def main(path, top=25):
    size = {}
    start, count = None, 0
    per_symbol = collections.Counter()
    for line in open(path, errors="replace"):
        if line.startswith("IN:"):
            start, count = None, 0
            continue
        m = re.match(r"0x([0-9a-f]{8}):", line)
        if m:
            if start is None:
                start = int(m.group(1), 16)
            count += 1
            size[start] = count
            continue
        if line.startswith("Trace"):
            m = re.search(r"\[[0-9a-f]+/([0-9a-f]+)/[^\]]*\] ?(.*)", line)
            if m:
                per_symbol[m.group(2).strip()] += size.get(int(m.group(1), 16), 0)
    total = sum(per_symbol.values())
    print(f"total {total}")
    for symbol, n in per_symbol.most_common(top):
        print(f"{n:>10} {100 * n / max(total, 1):5.1f}% {symbol[:120]}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
