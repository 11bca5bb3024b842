#!/usr/bin/env python3
"""Lines per function body in posekit's C++ sources, and a check against a limit.

  scripts/function-sizes.py                 table of every function over the limit (default 150)
  scripts/function-sizes.py --check         exit 1 when a function not in the allowance file is over
                                            the limit, or an allowed one grew past its allowance
  scripts/function-sizes.py --top 20        the 20 longest functions

A function is a definition whose body opens at the end of a line at namespace level (column 0 or
inside `namespace` blocks only) and closes with a `}` at the same indentation; lambdas and local
classes count toward the function that holds them. This is the layout .clang-format gives every
file, so the scan needs no compiler and runs in a second; clang-tidy's readability-function-size
(.clang-tidy) counts the same bodies from the AST when run by hand.
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
SOURCES = ("modules", "datasets", "tools", "viewers", "python", "examples")
ALLOWANCE = ROOT / "scripts" / "function-size-allowance.txt"
NOT_FUNCTIONS = re.compile(r"^\s*(namespace\b|extern\b|struct\b|class\b|enum\b|union\b|template\s*<[^>]*>\s*(struct|class)\b)")


def strip_strings_and_comments(text):
    """The source with string/char literals and comments blanked (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (j - i - 1) + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path):
    """(name, first line, lines) of each function defined in the file."""
    lines = strip_strings_and_comments(path.read_text(encoding="utf-8", errors="replace")).split("\n")
    found, depth, scopes, i = [], 0, [], 0  # scopes: namespace-like braces open at this point
    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        opens_body = stripped.endswith("{") and depth == len(scopes)
        if opens_body and NOT_FUNCTIONS.match(line):
            scopes.append(depth)
            depth += line.count("{") - line.count("}")
            i += 1
            continue
        if opens_body and ")" in "".join(lines[max(0, i - 6):i + 1]) and not stripped.startswith(("=", "return")):
            # the signature: back to the previous line that ends a statement or a block
            start = i
            while start > 0 and lines[start - 1].strip() and not lines[start - 1].strip().endswith((";", "}", "{", ":")) \
                    and not lines[start - 1].lstrip().startswith("#"):
                start -= 1
            signature = " ".join(l.strip() for l in lines[start:i + 1])
            name = re.search(r"([~\w:]+(?:operator\S*)?)\s*\(", signature)
            level, j = 0, i
            while j < len(lines):
                level += lines[j].count("{") - lines[j].count("}")
                if level <= 0:
                    break
                j += 1
            if name and "=" not in signature.split("(")[0]:
                found.append((name.group(1), i + 1, j - i + 1))
                i = j + 1
                continue
        depth += line.count("{") - line.count("}")
        while scopes and depth <= scopes[-1]:
            scopes.pop()
        i += 1
    return found


def all_functions():
    for folder in SOURCES:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix in (".cpp", ".h", ".cc") and "build" not in path.parts:
                for name, line, size in functions(path):
                    yield str(path.relative_to(ROOT)), name, line, size


def read_allowance():
    allowed = {}
    if ALLOWANCE.exists():
        for row in ALLOWANCE.read_text().splitlines():
            if row.strip() and not row.startswith("#"):
                file, name, size = row.split()
                allowed[(file, name)] = int(size)
    return allowed


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--limit", type=int, default=150, help="lines per function (default 150)")
    parser.add_argument("--top", type=int, default=0, help="list the N longest functions")
    parser.add_argument("--check", action="store_true", help="fail on functions over the limit that the allowance file does not allow")
    args = parser.parse_args()
    every = sorted(all_functions(), key=lambda f: -f[3])
    if args.top:
        for file, name, line, size in every[:args.top]:
            print(f"{size:5d}  {file}:{line}  {name}")
        return 0
    over = [f for f in every if f[3] > args.limit]
    total = len(every)
    if not args.check:
        print(f"{len(over)} of {total} functions over {args.limit} lines")
        for file, name, line, size in over:
            print(f"{size:5d}  {file}:{line}  {name}")
        return 0
    allowed = read_allowance()
    bad = [f for f in over if f[3] > allowed.get((f[0], f[1]), args.limit)]
    for file, name, line, size in bad:
        limit = allowed.get((file, name))
        why = f"over its allowance of {limit}" if limit else f"over {args.limit} lines"
        print(f"{file}:{line}: {name} is {size} lines, {why}: split it into named stages", file=sys.stderr)
    print(f"function sizes: {len(over)} of {total} functions over {args.limit} lines, {len(bad)} not allowed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
