#!/usr/bin/env python3
"""Guest instructions per symbol from a QEMU exec log: how the profile in BENCHMARKS.md was made.

    scripts/firmware.sh --cycles 2 --build-only --elf-out /tmp/fw.elf specs/paper-limits.toml
    qemu-system-arm -M xilinx-zynq-a9 -nographic -monitor none \\
        -semihosting-config enable=on,target=native -icount shift=0 \\
        -d in_asm,exec,nochain -D /tmp/q.log -kernel /tmp/fw.elf
    scripts/qemu-profile.py /tmp/q.log
    scripts/qemu-profile.py /tmp/q.log --op vdiv     # also: executed instructions whose mnemonic starts so

`in_asm` gives each translated block's instructions, `exec` each execution of a block with its
symbol; the product, summed per symbol, is the instructions spent there (the calibration loop in
`main` included). With `--op PREFIX` the same product counts only the instructions whose mnemonic
starts with PREFIX (`vdiv`: the VFP's divisions, which QEMU counts as one instruction each and silicon
runs in tens of cycles).
"""
import argparse
import collections
import re


def main(path, op=None, top=25):
    size = {}
    ops = {}
    start, count, matched = None, 0, 0
    per_symbol = collections.Counter()
    per_symbol_op = collections.Counter()
    for line in open(path, errors="replace"):
        if line.startswith("IN:"):
            start, count, matched = None, 0, 0
            continue
        m = re.match(r"0x([0-9a-f]{8}):\s+(?:[0-9a-f]+\s+)?(\S+)", line)
        if m:
            if start is None:
                start = int(m.group(1), 16)
            count += 1
            if op is not None and m.group(2).startswith(op):
                matched += 1
            size[start] = count
            ops[start] = matched
            continue
        if line.startswith("Trace"):
            m = re.search(r"\[[0-9a-f]+/([0-9a-f]+)/[^\]]*\] ?(.*)", line)
            if m:
                block, symbol = int(m.group(1), 16), m.group(2).strip()
                per_symbol[symbol] += size.get(block, 0)
                per_symbol_op[symbol] += ops.get(block, 0)
    total = sum(per_symbol.values())
    print(f"total {total}")
    for symbol, n in per_symbol.most_common(top):
        print(f"{n:>10} {100 * n / max(total, 1):5.1f}% {symbol[:120]}")
    if op is not None:
        total_op = sum(per_symbol_op.values())
        print(f"\n{op}*: {total_op} executed")
        for symbol, n in per_symbol_op.most_common(top):
            if n:
                print(f"{n:>10} {100 * n / max(total_op, 1):5.1f}% {symbol[:120]}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log")
    parser.add_argument("--op", help="also count executed instructions whose mnemonic starts with this")
    args = parser.parse_args()
    main(args.log, args.op)
