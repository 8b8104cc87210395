#!/usr/bin/env python3
"""Size limits of the C++ sources in mesher/, fem/, needle/ and pipeline/ (run first by scripts/test.sh; docs/testing.md, "Running").

Reports every source file over 700 lines and every function over 150 lines, and fails if more than
3 functions exceed 100 lines. A function whose signature is directly preceded by a comment holding
`// long-function: <reason>` (a hot loop that is clearer in one piece) does not count toward the
100-line allowance; the 150-line limit holds for every function.

A function is a brace-matched body at namespace or class scope whose head ends like a function
declarator (`)`, optionally followed by qualifiers, a trailing return type or a constructor's
initialiser list); lambdas and blocks inside a function count as part of it. Its length runs from the
first line of its head (template line included) to its closing brace. Comments, string and character
literals and preprocessor lines are ignored.

Usage: scripts/check-size.py [--list N] [paths...]   (default: mesher fem needle pipeline under the repo)
Exit status 0 when within the limits, 1 otherwise.
"""
import argparse
import re
import sys
from pathlib import Path

MAX_FILE_LINES = 700
MAX_FUNCTION_LINES = 150
LONG_FUNCTION_LINES = 100
MAX_LONG_FUNCTIONS = 3
SOURCE_SUFFIXES = {".cpp", ".hpp", ".h", ".cc", ".hh", ".cxx", ".hxx", ".ipp", ".tpp"}
EXEMPT_MARK = re.compile(r"//\s*long-function:\s*\S")
DECLARATOR_END = re.compile(
    r"\)\s*(?:(?:const|volatile|noexcept(?:\s*\([^()]*\))?|override|final|mutable|&&|&)\s*)*"
    r"(?:->\s*[\w:<>,\s*&\[\]]+)?\s*$")
NOT_FUNCTION_HEAD = re.compile(r"^\s*(?:namespace|class|struct|union|enum|extern\s+\"C\")\b")


def strip_code(text):
    """Comments, literals and preprocessor lines replaced by blanks; newlines kept (line numbers)."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c in " \t":
            out.append(c)
            i += 1
            continue
        if at_line_start and c == "#":  # preprocessor line, with its continuations
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        at_line_start = False
        if c == "\n":
            out.append(c)
            at_line_start = True
            i += 1
        elif text.startswith("//", i):
            while i < n and text[i] != "\n":
                out.append(" ")
                i += 1
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            open_paren = text.find("(", i + 2)
            delim = text[i + 2:open_paren]
            end = text.find(")" + delim + '"', open_paren)
            end = n if end < 0 else end + len(delim) + 2
            out.append('""' + re.sub(r"[^\n]", " ", text[i + 2:end]))
            i = end
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching_brace(code, open_index):
    depth = 0
    for k in range(open_index, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(code) - 1


def is_function_head(head):
    if NOT_FUNCTION_HEAD.match(head) or "(" not in head:
        return False
    if DECLARATOR_END.search(head):
        return True
    # Constructor initialiser list: `) : member(...), member{...}`.
    return re.search(r"\)\s*:(?!:)", head) is not None


def function_name(head):
    before = head.split("(")[0]
    # operator() and friends keep their operator token.
    if "operator" in head:
        m = re.search(r"([\w:~<>]*operator\s*[^\s(]*\s*(?:\(\))?)", head)
        if m:
            return m.group(1).strip()
    tokens = re.findall(r"[\w:~<>,]+", before)
    return tokens[-1] if tokens else "?"


def functions(code):
    """Yields (head_start_offset, close_offset, head) for each function body at non-function scope."""
    head_start = 0
    k = 0
    n = len(code)
    while k < n:
        c = code[k]
        if c in ";}":
            head_start = k + 1
            k += 1
        elif c == "{":
            head = code[head_start:k]
            if is_function_head(head.strip()):
                close = matching_brace(code, k)
                rest = code[close + 1:].lstrip()
                if rest[:1] in (",", "{") and re.search(r"\)\s*:(?!:)", head):
                    k = close + 1  # a brace initialiser in a constructor's initialiser list
                    continue
                yield head_start, close, head.strip()
                k = close + 1
                head_start = k
            else:  # namespace, class, enum, initialiser: descend (functions can be inside)
                head_start = k + 1
                k += 1
        else:
            k += 1


def exempt_mark_above(raw_lines, first_line):
    """True if the comment lines directly above line first_line (1-based) hold the exemption mark."""
    k = first_line - 2
    while k >= 0 and raw_lines[k].lstrip().startswith("//"):
        if EXEMPT_MARK.search(raw_lines[k]):
            return True
        k -= 1
    return False


def line_of(code, offset):
    return code.count("\n", 0, offset) + 1


def scan(path):
    text = path.read_text(encoding="utf-8", errors="replace")
    raw_lines = text.split("\n")
    code = strip_code(text)
    result = []
    for start, close, head in functions(code):
        first = start + (len(code[start:]) - len(code[start:].lstrip()))
        first_line, last_line = line_of(code, first), line_of(code, close)
        exempt = exempt_mark_above(raw_lines, first_line)
        result.append((last_line - first_line + 1, first_line, function_name(head), exempt))
    n_lines = len(raw_lines) - (1 if text.endswith("\n") else 0)
    return n_lines, result


def main():
    root = Path(__file__).resolve().parent.parent
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="*", help="files or folders (default: mesher fem needle pipeline)")
    parser.add_argument("--list", type=int, default=0, metavar="N", help="also list functions over N lines")
    args = parser.parse_args()
    paths = [Path(p) for p in args.paths] or [root / d for d in ("mesher", "fem", "needle", "pipeline")]
    files = []
    for p in paths:
        if p.is_dir():
            files += sorted(f for f in p.rglob("*") if f.suffix in SOURCE_SUFFIXES and f.is_file())
        elif p.is_file():
            files.append(p)
        else:
            print(f"check-size: no such file or folder: {p}", file=sys.stderr)
            return 2
    problems = []
    long_functions = []
    for f in files:
        n_lines, funcs = scan(f)
        name = f.resolve().relative_to(root) if f.resolve().is_relative_to(root) else f
        if n_lines > MAX_FILE_LINES:
            problems.append(f"{name}: {n_lines} lines (limit {MAX_FILE_LINES})")
        for length, line, fname, exempt in funcs:
            where = f"{name}:{line}: {fname}: {length} lines"
            if length > MAX_FUNCTION_LINES:
                problems.append(f"{where} (limit {MAX_FUNCTION_LINES})")
            if length > LONG_FUNCTION_LINES and not exempt:
                long_functions.append(where)
            if args.list and length > args.list:
                print(f"  {where}{' (long-function)' if exempt else ''}")
    if len(long_functions) > MAX_LONG_FUNCTIONS:
        problems.append(f"{len(long_functions)} functions over {LONG_FUNCTION_LINES} lines "
                        f"(at most {MAX_LONG_FUNCTIONS} without a `// long-function: <reason>` line):")
        problems += [f"  {w}" for w in long_functions]
    for p in problems:
        print(f"check-size: {p}")
    if problems:
        return 1
    print(f"check-size: {len(files)} files within the limits ({len(long_functions)} of at most "
          f"{MAX_LONG_FUNCTIONS} functions over {LONG_FUNCTION_LINES} lines)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
