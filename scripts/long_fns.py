#!/usr/bin/env python3
"""Lists every Rust `fn` longer than a limit, longest first (issue 32: no fn in codegen/src over 300 lines).

    python3 scripts/long_fns.py [DIR] [LIMIT]      # defaults: codegen/src 300

A fn spans from the line of its `fn` keyword to the line of the brace closing its body, `quote!` bodies
included. Comments, strings, chars and raw strings are skipped when braces are counted; a `fn` without a
body (a trait method's declaration, a `fn(...)` pointer type) is not counted. Exits 1 if any fn is longer.
"""
import os
import re
import sys

FN = re.compile(r"\bfn\s+([A-Za-z_][A-Za-z0-9_]*)")


def code_only(text):
    """The text with comments, strings and char literals blanked (newlines kept), so braces count."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif (m := re.match(r'b?r(#*)"', text[i:i + 300])) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = '"' + m.group(1)
            j = text.find(end, i + m.end())
            j = n if j < 0 else j + len(end)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(re.sub(r"[^\n]", " ", text[i:j + 1]))
            i = j + 1
        elif c == "'" and (m := re.match(r"'(\\.[^']*|[^\\'])'", text[i:i + 12])):
            out.append(" " * m.end())
            i += m.end()
        else:
            out.append(c)
            i += 1
    return "".join(out)


def long_fns(path):
    """(line, length, name) of every fn with a body in one file."""
    code = code_only(open(path, encoding="utf-8").read())
    found = []
    for m in FN.finditer(code):
        # The body opens at the first `{` after the signature; a `;` first means no body.
        j = m.end()
        depth_paren = 0
        while j < len(code):
            ch = code[j]
            if ch in "([":
                depth_paren += 1
            elif ch in ")]":
                depth_paren -= 1
            elif ch == ";" and depth_paren == 0:
                j = -1
                break
            elif ch == "{" and depth_paren == 0:
                break
            j += 1
        if j < 0 or j >= len(code):
            continue
        depth = 0
        k = j
        while k < len(code):
            if code[k] == "{":
                depth += 1
            elif code[k] == "}":
                depth -= 1
                if depth == 0:
                    break
            k += 1
        start = code.count("\n", 0, m.start()) + 1
        end = code.count("\n", 0, k) + 1
        found.append((start, end - start + 1, m.group(1)))
    return found


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "codegen/src"
    limit = int(sys.argv[2]) if len(sys.argv) > 2 else 300
    rows = []
    for dirpath, _, files in os.walk(root):
        for f in files:
            if f.endswith(".rs"):
                p = os.path.join(dirpath, f)
                rows += [(length, p, line, name) for line, length, name in long_fns(p)]
    rows.sort(key=lambda r: (-r[0], r[1], r[2]))
    over = [r for r in rows if r[0] > limit]
    for length, p, line, name in over:
        print(f"{p}:{line}: fn {name}: {length} lines")
    if rows:
        length, p, line, name = rows[0]
        print(f"longest: {p}:{line}: fn {name}: {length} lines ({len(over)} over {limit})")
    sys.exit(1 if over else 0)


if __name__ == "__main__":
    main()
