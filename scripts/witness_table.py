"""The table of scripts/witness.sh: each problem's witness replayed (the SOLVES lines of
peers/firmware/run.sh) against the estimate of a cold solve in its `mpcc check --json`.

    python3 scripts/witness_table.py DIR SOLVES PROBLEM...

Exits 1 where a measured solve exceeds its estimate."""
import json, sys
out, solves, problems = sys.argv[1], sys.argv[2], sys.argv[3:]
measured = {}
for line in open(solves):
    if line.startswith("SOLVES "):
        v = json.loads(line[7:])
        if v["solver"] == "active_set":
            measured[v["problem"]] = (v["instructions"][0], v["iterations"][0])
print("| problem | witness: changes (cold cap) | work / 10 | measured instructions | per work / 10 | estimate of a cold solve, instructions | estimate / measured | estimate of a step (warm solve + cold restart), instructions |")
print("|---|---|---|---|---|---|---|---|")
worst = 0.0
for p in problems:
    c = json.load(open(f"{out}/{p}.check.json"))
    step = c["control_step"]
    cold = c.get("cold_iterations") or step["iterations"]
    # The solver's cycles for a cold solve (its budget of work, or its cap of changes at the worst
    # pass, and the once-per-solve part), and the rest of the step (the gradient map, the filter).
    solver = c["cold_solve_macs"] * step["solver_cycles_per_mac"]
    # In instructions, as the board counts them: cycles over the target's cycles per instruction.
    cpi = step["machine"]["cycles_per_instruction"]
    estimate = (solver + (step["cycles"] - step["solver_cycles"])) / cpi
    instructions, changes = measured[p]
    ratio = estimate / instructions
    worst = max(worst, 1 / ratio)
    # The witness's work (the kernel's weighed count, in tenths of a multiply-add of the factor's
    # loops) and the instructions per multiply-add of them: the figure `Machine::cycles_per_mac_active_set`
    # is set from.
    units = c["sampled"]["cold_work_worst"] / 10
    print(f"| {p} | {changes} ({cold}) | {units:,.0f} | {instructions:,} | {instructions / units:.1f} | {estimate:,.0f} | {ratio:.2f}× | {step['cycles'] / cpi:,.0f} |")
if worst > 1:
    print(f"witness.sh: a measured cold solve exceeds its estimate (by {worst:.2f}×)", file=sys.stderr)
    sys.exit(1)
