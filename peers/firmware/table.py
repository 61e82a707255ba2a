"""The firmware's RESULT lines (stdin) as a markdown table; with --sizes, the SIZE lines of run.sh
as the bytes each solver adds to an image (its build minus the one with neither solver)."""
import json
import sys


def results(lines):
    print("| board | problem | solver | instructions per solve (min / median / p99 / max) | of which forming f, bounds (max) | iterations (min / median / p99 / max) | \\|U − U*\\|∞ (median / max) | stack of a solve, B | state between solves, B | not optimal |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for line in lines:
        if not line.startswith("RESULT "):
            continue
        r = json.loads(line[len("RESULT "):])
        if r["solver"] == "none":  # the replay without a solver, for --sizes
            continue
        q = lambda k: " / ".join(f"{r[k + '_' + s]:,}" for s in ("min", "median", "p99", "max"))
        e = lambda k: f"{r[k] * 1e-15:.1e}"
        solver = {"generated": "generated", "active_set": "generated active set"}.get(r["solver"], "DAQP")
        print(f"| {r['board']} | {r['problem']} | {solver} | {q('instructions')} | {r['form_instructions_max']:,} | "
              f"{q('iterations') if solver != 'generated' else 'fixed'} | {e('error_median_fp')} / {e('error_max_fp')} | "
              f"{r['solve_stack_bytes']:,}{' (overflowed)' if r['solve_stack_overflowed'] else ''} | {r['state_bytes']:,} | {r['not_optimal']} |")


def sizes(lines):
    rows = {}
    for line in lines:
        parts = line.split()
        if len(parts) < 4 or parts[0] != "SIZE":
            continue
        _, board, problem, variant, *secs = parts
        rows.setdefault((board, problem), {})[variant] = {k: int(v) for k, v in (s.split("=") for s in secs)}
    print("| board | problem | solver | .text B | .rodata B | .data + .bss B (static) |")
    print("|---|---|---|---|---|---|")
    for (board, problem), v in rows.items():
        if "none" not in v:
            continue
        for variant in ("ours", "active_set", "daqp"):
            if variant not in v:
                continue
            d = {k: v[variant].get(k, 0) - v["none"].get(k, 0) for k in ("text", "rodata", "data", "bss")}
            name = {"ours": "generated", "active_set": "generated active set"}.get(variant, "DAQP")
            print(f"| {board} | {problem} | {name} | {d['text']:,} | {d['rodata']:,} | {d['data'] + d['bss']:,} |")


if __name__ == "__main__":
    lines = sys.stdin.read().splitlines()
    (sizes if "--sizes" in sys.argv else results)(lines)
