#!/usr/bin/env python3
"""Writes docs/CLI.md from the mesocap binary's own --help, or checks it.

    python3 scripts/generate_cli_doc.py --binary build/release/apps/mesocap
    python3 scripts/generate_cli_doc.py --binary build/release/apps/mesocap --check

The page is a short head kept here, then `mesocap --help` and every
subcommand's --help (nested ones too, found in each help's "Subcommands:"
list), each under its own heading. With --check nothing is written: it exits
1 and names the first line where the page differs from what the binary
prints.
"""

import argparse
import concurrent.futures
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
REGENERATE = "python3 scripts/generate_cli_doc.py --binary build/release/apps/mesocap"

HEAD = f"""# The `mesocap` subcommands

This page is generated from the binary's own `--help`: do not edit it, edit
the help texts in `apps/mesocap/` and run

    {REGENERATE}

A test (`apps_cli_doc`) fails when this page and the binary differ.
`mesocapd`, the capture daemon, has its own page: `docs/DAEMON.md`.

What every subcommand shares:

- An incomplete or damaged capture session is refused by `process mdf` and
  `process btf` (`--allow-incomplete` names steps to leave out;
  `simulate --resume` completes a session and captures damaged steps again).
- Every file read is checked against its recorded checksum (`mesocap verify`
  checks them all).
- `--replace` replaces only what the same command writes, never its input
  (docs/FORMATS.md, "Rules common to every format").
"""


def run_help(binary, command):
    """The --help text of `command` (a list of words), as the binary prints it."""
    result = subprocess.run([binary, *command, "--help"], capture_output=True, text=True, check=False)
    if result.returncode != 0:
        words = " ".join(command + ["--help"])
        sys.exit(f"generate_cli_doc: `mesocap {words}` exited {result.returncode}: {result.stderr.strip()}")
    return result.stdout


def subcommands(help_text):
    """The names in a help text's "Subcommands:" list, in its order."""
    names = []
    listing = False
    for line in help_text.splitlines():
        if line == "Subcommands:":
            listing = True
        elif listing and line.startswith("   "):
            continue  # a description's next line
        elif listing and line.startswith("  "):
            names.append(line.split()[0])
        elif listing:
            listing = False
    return names


def sections(binary):
    """(command, help) for `mesocap` and every subcommand below it, depth first.

    The helps of one level are asked for at once: each run of the binary
    spends most of its time loading its libraries.
    """
    helps = {}
    level = [()]
    with concurrent.futures.ThreadPoolExecutor() as pool:
        while level:
            texts = list(pool.map(lambda command: run_help(binary, list(command)), level))
            helps.update(zip(level, texts))
            level = [(*command, name) for command, text in zip(level, texts) for name in subcommands(text)]

    def depth_first(command):
        yield list(command), helps[command]
        for name in subcommands(helps[command]):
            yield from depth_first((*command, name))

    return list(depth_first(()))


def page(binary):
    parts = [HEAD]
    for command, text in sections(binary):
        title = " ".join(["mesocap", *command])
        parts.append(f"\n## `{title}`\n\n```text\n{text.rstrip()}\n```\n")
    return "".join(parts)


def first_difference(expected, written):
    """(line number, expected line, written line) of the first difference, or None."""
    expected_lines = expected.splitlines()
    written_lines = written.splitlines()
    for number in range(max(len(expected_lines), len(written_lines))):
        want = expected_lines[number] if number < len(expected_lines) else "(end of page)"
        have = written_lines[number] if number < len(written_lines) else "(end of page)"
        if want != have:
            return number + 1, want, have
    if expected != written:  # only line endings or a final newline differ
        return len(expected_lines), expected_lines[-1] if expected_lines else "", "(line ending)"
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--binary", required=True, help="the mesocap executable")
    parser.add_argument("--doc", default=str(ROOT / "docs" / "CLI.md"), help="the page (default: docs/CLI.md)")
    parser.add_argument("--check", action="store_true", help="compare the page with the binary; write nothing")
    args = parser.parse_args()

    expected = page(args.binary)
    doc = pathlib.Path(args.doc)
    if not args.check:
        doc.write_text(expected)
        print(f"wrote {doc}")
        return 0
    written = doc.read_text() if doc.exists() else ""
    difference = first_difference(expected, written)
    if difference is None:
        print(f"{doc} is what the binary prints")
        return 0
    number, want, have = difference
    print(f"{doc}:{number}: differs from what the binary prints", file=sys.stderr)
    print(f"  page:   {have}", file=sys.stderr)
    print(f"  binary: {want}", file=sys.stderr)
    print(f"regenerate it: {REGENERATE}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
