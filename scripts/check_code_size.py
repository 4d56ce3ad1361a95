#!/usr/bin/env python3
"""The project's size rules: no source file over 800 lines, no function over
120 lines (docs/DEVELOPING.md, "Style"). Prints the longest files and
functions, then each one over its limit, and exits 1 if there is one.

Usage: scripts/check_code_size.py [--root DIR] [--top N] [FILE...]
  (default: every .cc and .h that git tracks under DIR)

A function is a brace-enclosed body at namespace or class scope whose
statement holds a parameter list: free functions, methods, constructors,
GoogleTest's TEST bodies, lambdas bound at namespace scope. Its length runs
from its declaration's first line to its closing brace. Comments, string
and character literals and raw strings are skipped, so braces in them do
not count.
"""
import argparse
import pathlib
import re
import subprocess
import sys

MAX_FILE_LINES = 800
MAX_FUNCTION_LINES = 120
SCOPE_KEYWORDS = {"namespace", "class", "struct", "union", "enum", "extern"}
QUALIFIERS = {"const", "override", "final", "noexcept", "mutable", "try"}
RAW_STRING = re.compile(r'R"([^()\\ ]{0,16})\(')
TOKEN = re.compile(r"[A-Za-z_][A-Za-z_0-9]*|\S")


def tokens(text):
    """(line, token) for the code, without comments and literals (a literal
    becomes one token, '""')."""
    i, line, n = 0, 1, len(text)
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c.isspace():
            i += 1
        elif text.startswith("//", i):
            i = text.find("\n", i)
            i = n if i < 0 else i
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            line += text.count("\n", i, end)
            i = end
        elif c == "#" and text[text.rfind("\n", 0, i) + 1:i].strip() == "":
            # A preprocessor line, with its continuations.
            while i < n and text[i] != "\n":
                i += 2 if text[i] == "\\" else 1
        elif (raw := RAW_STRING.match(text, i)) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = text.find(")" + raw.group(1) + '"', raw.end())
            end = n if end < 0 else end + len(raw.group(1)) + 2
            line += text.count("\n", i, end)
            yield line, '""'
            i = end
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            yield line, '""'
            i = j + 1
        else:
            m = TOKEN.match(text, i)
            yield line, m.group(0)
            i = m.end()


def functions(text):
    """(first line, last line, name) of each function body."""
    scopes = []  # per open brace: [kind, first line, name]; kind scope, function, init or block
    statement = []  # (line, token) since the last ; { or } at this level
    found = []
    for line, tok in tokens(text):
        if tok == "{":
            words = [t for _, t in statement]
            previous = words[-1] if words else ""
            in_code = any(kind != "scope" for kind, _, _ in scopes)
            if in_code:
                kind = "block"
            elif "(" not in words:
                kind = "scope" if any(w in SCOPE_KEYWORDS for w in words) else "block"
            elif any(a == "-" and b == ">" for a, b in zip(words, words[1:])):
                kind = "function"  # a trailing return type
            elif (re.match(r"[A-Za-z_]", previous) and previous not in QUALIFIERS) or previous in ("(", ",", ">"):
                kind = "init"  # a member's brace initializer in a constructor's list, a braced argument
            else:
                kind = "function"
            head = words[: words.index("(")] if "(" in words else []
            name = next((w for w in reversed(head) if re.match(r"[A-Za-z_~]", w)), "?")
            scopes.append([kind, statement[0][0] if statement else line, name])
            if kind != "init":
                statement = []
        elif tok == "}":
            if scopes:
                kind, start, name = scopes.pop()
                if kind == "init":
                    continue  # the statement goes on
                if kind == "function":
                    found.append((start, line, name))
            statement = []
        elif tok == ";":
            statement = []
        else:
            statement.append((line, tok))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", default=pathlib.Path(__file__).resolve().parent.parent)
    parser.add_argument("--top", type=int, default=5)
    parser.add_argument("files", nargs="*")
    args = parser.parse_args()
    root = pathlib.Path(args.root)
    names = args.files or subprocess.run(["git", "-C", str(root), "ls-files", "*.cc", "*.h"], check=True,
                                         capture_output=True, text=True).stdout.split()
    sizes, lengths = [], []
    for name in names:
        path = root / name
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            print(f"{name}: cannot be read: {e}", file=sys.stderr)
            return 2
        sizes.append((text.count("\n"), name))
        for start, end, function in functions(text):
            lengths.append((end - start + 1, f"{name}:{start}", function))
    sizes.sort(reverse=True)
    lengths.sort(reverse=True)
    print(f"longest files (at most {MAX_FILE_LINES} lines):")
    for count, name in sizes[: args.top]:
        print(f"  {count:5d}  {name}")
    print(f"longest functions (at most {MAX_FUNCTION_LINES} lines):")
    for count, where, function in lengths[: args.top]:
        print(f"  {count:5d}  {where}  {function}")
    over = [f"{name}: {count} lines, more than {MAX_FILE_LINES}" for count, name in sizes if count > MAX_FILE_LINES]
    over += [f"{where}: function {function} is {count} lines, more than {MAX_FUNCTION_LINES}"
             for count, where, function in lengths if count > MAX_FUNCTION_LINES]
    for problem in over:
        print(problem)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
