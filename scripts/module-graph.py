#!/usr/bin/env python3
"""The posekit module graph, read from the posekit_add_module() calls of the CMakeLists.

  scripts/module-graph.py                 every module, its direct posekit deps and third-party libs
  scripts/module-graph.py --dot           the same as a Graphviz digraph (dot -Tsvg)
  scripts/module-graph.py --closure M...  what a program linking modules M... links, transitively
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
CALL = re.compile(r"posekit_add_(module|plugin)\((\w+)(.*?)\)\s*$", re.S | re.M)
KEYWORDS = ("SOURCES", "DEPS", "PUBLIC_LIBS", "PRIVATE_LIBS", "LIBS")


def parse_call(body):
    groups, key = {}, None
    for token in body.split():
        if token in KEYWORDS:
            key = token
            groups[key] = []
        elif key:
            groups[key].append(token)
    return groups


def read_graph():
    modules, plugins = {}, {}
    for cmake in sorted(ROOT.glob("**/CMakeLists.txt")):
        if "build" in cmake.relative_to(ROOT).parts[:1]:
            continue
        text = re.sub(r"#.*", "", cmake.read_text())
        for kind, name, body in CALL.findall(text):
            groups = parse_call(body)
            libs = [l for k in ("PUBLIC_LIBS", "PRIVATE_LIBS", "LIBS") for l in groups.get(k, [])]
            entry = {"deps": groups.get("DEPS", []), "libs": libs, "dir": str(cmake.parent.relative_to(ROOT))}
            (modules if kind == "module" else plugins)[name] = entry
    return modules, plugins


def closure(modules, roots):
    seen, stack = [], list(roots)
    while stack:
        name = stack.pop()
        if name in seen or name not in modules:
            continue
        seen.append(name)
        stack.extend(modules[name]["deps"])
    return seen


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--dot", action="store_true")
    parser.add_argument("--closure", nargs="+", metavar="MODULE")
    args = parser.parse_args()
    modules, plugins = read_graph()
    if args.closure:
        unknown = [m for m in args.closure if m not in modules]
        if unknown:
            sys.exit(f"module-graph: no module named {', '.join(unknown)} (modules: {', '.join(sorted(modules))})")
        names = closure(modules, args.closure)
        libs = sorted({l for n in names for l in modules[n]["libs"]})
        print("posekit modules:", " ".join(sorted(names)))
        print("third-party libraries:", " ".join(libs) if libs else "(Eigen only)")
        return
    if args.dot:
        print("digraph posekit {\n  rankdir=BT; node [shape=box, fontname=Helvetica];")
        for name, m in sorted(modules.items()):
            for dep in m["deps"]:
                print(f"  {name} -> {dep};")
        for name, p in sorted(plugins.items()):
            print(f'  "{name} (plugin)" [style=dashed];')
            for dep in p["deps"]:
                print(f'  "{name} (plugin)" -> {dep} [style=dashed];')
        print("}")
        return
    for name, m in sorted(modules.items()):
        print(f"{name:14} -> {' '.join(m['deps']) or '-'}" + (f"   [{' '.join(m['libs'])}]" if m["libs"] else ""))
    for name, p in sorted(plugins.items()):
        print(f"{name + ' plugin':14} -> {' '.join(p['deps'])}   [{' '.join(p['libs'])}]")


if __name__ == "__main__":
    main()
