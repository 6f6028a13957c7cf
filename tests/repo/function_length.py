#!/usr/bin/env python3
"""No function outside tests over 80 lines (docs/conventions.md "Functions"): a function body is read from its
signature's first line at column 0 to the closing brace at column 0 (the layout clang-format gives every
namespace-level definition here). Member functions defined inside a class body are short by the same rule's
spirit and are not measured. Usage: function_length.py REPO [LIMIT]. Exit 1 naming each function over LIMIT."""
import re
import subprocess
import sys

repo = sys.argv[1]
limit = int(sys.argv[2]) if len(sys.argv) > 2 else 80
try:
    files = subprocess.check_output(["git", "-C", repo, "ls-files", "*.cpp", "*.hpp"], text=True).split()
except (OSError, subprocess.CalledProcessError):
    print("not a git checkout: nothing to check")
    sys.exit(0)

starts = re.compile(r"^[A-Za-z_~].*\(")
not_function = re.compile(r"^(namespace|struct|class|enum|union|using|typedef|template\s*<[^>]*>\s*(struct|class)|#|static_assert|extern)")
long_ones = []
for f in files:
    if f.startswith(("tests/", "bench/")):
        continue
    try:
        lines = open(f"{repo}/{f}", encoding="utf-8", errors="replace").read().split("\n")
    except OSError:
        continue
    start = None
    for i, line in enumerate(lines):
        if start is None:
            if starts.match(line) and not not_function.match(line) and not line.rstrip().endswith(";"):
                for j in range(i, min(i + 8, len(lines))):
                    text = lines[j].rstrip()
                    if text.endswith("{"):
                        start = i
                        break
                    if text.endswith(";") or text.endswith("}"):
                        break
        elif line.startswith("}"):
            n = i - start + 1
            if n > limit:
                long_ones.append((n, f, start + 1, lines[start].strip()))
            start = None
for n, f, at, sig in sorted(long_ones, reverse=True):
    print(f"{f}:{at}: {n} lines (at most {limit}): {sig[:100]}")
if not long_ones:
    print(f"no function outside tests over {limit} lines")
sys.exit(1 if long_ones else 0)
