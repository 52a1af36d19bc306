#!/usr/bin/env python3
"""Checks every #include of the tree against the module rules of src/DEPENDENCIES.md.

    check_dependencies.py [--plant FILE:HEADER ...] [ROOT]

ROOT is the repository (default: this script's parent folder). The rules are the two tables of
ROOT/src/DEPENDENCIES.md: "may include" per module, and the interface headers that examples,
bindings and the conformance runner may use. An include "m/x.h" names module m when src/m exists;
a public header (cadinterp/...), a system header or a file of the same folder is always allowed.

--plant FILE:HEADER adds a pretend '#include "HEADER"' to FILE before checking, so that a test can
show the check fails on an upward edge without touching the tree.

Prints each forbidden edge as 'FILE:LINE includes HEADER: WHY' and exits 1 when there is one,
0 otherwise; 2 when the rules cannot be read.
"""
import os
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')
SOURCE_EXT = ('.c', '.cc', '.cpp', '.h', '.hpp')
CONSUMERS = ('examples', 'bindings', 'conformance')


def table_rows(text, first_header):
    """Rows (lists of cells) of the markdown table whose header row starts with first_header."""
    rows, inside = [], False
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if not line.lstrip().startswith('|'):
            if inside:
                break
            continue
        if not inside:
            inside = cells[0] == first_header
            continue
        if set(cells[0]) <= set('-: '):
            continue
        rows.append(cells)
    return rows


def names(cell):
    return re.findall(r'`?([A-Za-z0-9_./]+)`?', cell.replace(',', ' '))


def read_rules(root):
    path = os.path.join(root, 'src', 'DEPENDENCIES.md')
    with open(path, encoding='utf-8') as f:
        text = f.read()
    allowed = {}
    for cells in table_rows(text, 'module'):
        if len(cells) == 3:  # module | owns | may include
            allowed[cells[0].strip('`')] = set(names(cells[2]))
    interfaces = set()
    for cells in table_rows(text.split('## Consumers', 1)[-1], 'module'):
        if len(cells) == 2:  # module | interface headers
            interfaces.update(names(cells[1]))
    if not allowed or not interfaces:
        raise ValueError(f'{path}: no module table or no interface table found')
    return allowed, interfaces


def tracked_sources(root):
    for top in ('src',) + CONSUMERS:
        for folder, dirs, files in os.walk(os.path.join(root, top)):
            dirs[:] = [d for d in dirs if d not in ('node_modules', 'build')]
            for name in sorted(files):
                if name.endswith(SOURCE_EXT):
                    yield os.path.relpath(os.path.join(folder, name), root)


def verdict(rel, header, allowed, interfaces, modules):
    """Why rel may not include header, or None when it may."""
    module = header.split('/', 1)[0] if '/' in header else None
    if module is None or module not in modules:
        return None  # same folder, public (cadinterp/...), system or third-party header
    parts = rel.split(os.sep)
    if parts[0] == 'src':
        own = parts[1]
        if own == module:
            return None
        if own not in allowed:
            return f'src/{own} is not in the module table'
        if module in allowed[own]:
            return None
        return f'{own} may not include {module} (src/DEPENDENCIES.md)'
    if header in interfaces:
        return None
    return f'{parts[0]} may include only public headers and declared interfaces'


def main(argv):
    planted = {}
    args = list(argv)
    while args and args[0] == '--plant':
        file, _, header = args[1].partition(':')
        planted.setdefault(os.path.normpath(file), []).append(header)
        del args[:2]
    root = os.path.abspath(args[0]) if args else os.path.dirname(
        os.path.dirname(os.path.abspath(__file__)))
    try:
        allowed, interfaces = read_rules(root)
    except (OSError, ValueError) as e:
        print(f'check_dependencies: {e}', file=sys.stderr)
        return 2
    modules = {d for d in os.listdir(os.path.join(root, 'src'))
               if os.path.isdir(os.path.join(root, 'src', d))}
    bad, files = 0, 0
    for rel in tracked_sources(root):
        files += 1
        with open(os.path.join(root, rel), encoding='utf-8', errors='replace') as f:
            lines = [(n, m.group(1)) for n, line in enumerate(f, 1)
                     if (m := INCLUDE.match(line))]
        lines += [(0, h) for h in planted.get(rel, [])]
        for n, header in lines:
            why = verdict(rel, header, allowed, interfaces, modules)
            if why:
                print(f'{rel}:{n} includes {header}: {why}')
                bad += 1
    print(f'{files} files checked, {bad} forbidden include(s)')
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
