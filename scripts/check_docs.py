#!/usr/bin/env python3
"""The docs check: what the docs and the code's comments name exists, the
architecture lists every library and pipeline, and nothing cites a file
outside the repository (docs/DEVELOPING.md, "Docs"). Prints one line per
failure and exits 1 if there is one.

Usage: scripts/check_docs.py [--root DIR]

Where it reads: docs/*.md and README.md (every line), the `//` comments of
*.cc and *.h, and the `#` comments of CMakeLists.txt, *.cmake, *.sh, *.py
and .ci/run (not `/* */` comments, not Python docstrings); every such file
git tracks under DIR, or every such file under DIR where DIR is not a git
checkout (the tests' planted trees).

(a) A repository path is a word of letters, digits and `_ . - + * ? /`
(`x.{h,cc}` expanded, each must exist; `*` and `?` glob) that
- holds a `/` and starts with a top-level folder of the repository
  (`core/mdf.h`, `drivers/tic/`, `render/scenes/*.json`), or holds a `/`
  and ends in a source extension (.h .cc .py .sh .cmake .md) whatever its
  first folder (a header under a folder that is gone: `processing/x.h`); or
- in a doc, is a file name with a source extension in backticks
  (`file_checksum.h`): a file of that name must exist somewhere; or
- in a doc, is a Markdown link's target (`images/plot.png`).
It exists if a tracked file or folder is at that path from the repository
root or from the folder of the file that names it; a glob must match one.
A placeholder (`<fuzzer>`, `{k:02d}`) stands for something that may not
exist yet: the path is checked up to the folder before it.

Not repository paths, so not checked (what programs write, or what lies
outside the checkout):
- anything under `build/` or `out/` (`build/release/apps/mesocap`,
  `out/demo/cylinder.png`), source extension or not;
- a word whose first folder the repository does not hold, unless it ends in
  a source extension (`STATE/control.sock`);
- a file under a top-level folder with an extension no tracked file in that
  folder has: a session's or package's own `btf/`, `mdf/` folders
  (`btf/view_0000.exr`, docs/FORMATS.md);
- absolute paths, `~/...`, `$VAR/...`, `${VAR}/...`, URLs, a word right after
  `<` (another project's header: `<sys/wait.h>`), and a word holding `...`.
Another project's files are named without their folder (Pololu's
tic_protocol.h) or by URL.

(b) Every library (a folder whose CMakeLists.txt calls mesocap_library) is a
row of docs/ARCHITECTURE.md's table, and every pipelines/*.h is named in its
part on pipelines/ (from the bold `pipelines/` to the next bold name or
heading).

(c) Nothing cites a file outside the repository: no relative path climbs
out of it (a path starting with `../`), and no comment or doc names DESIGN.md, the
design document that once lay beside it.
"""
import argparse
import fnmatch
import itertools
import pathlib
import re
import subprocess
import sys

SOURCE_EXTENSIONS = (".h", ".cc", ".py", ".sh", ".cmake", ".md")
GENERATED_FOLDERS = {"build", "out"}
OUTSIDE_FILE = re.compile(r"(?<![\w.])DESIGN\.md")
PLACEHOLDER = re.compile(r"<[\w:]+>|\{\w*:\w*\}")  # <fuzzer>, <v:04d>, {k:02d}
WORD = re.compile(r"(?:[\w.\-+*?/]|\{[\w.,\-]*\}|<[\w:]+>|\{\w*:\w*\})+")
BACKTICKED_NAME = re.compile(r"`([\w.\-+]+)`")
CPP_TOKEN = re.compile(r'R"([^()\\ ]{0,16})\(|"(?:\\.|[^"\\])*"?|\'(?:\\.|[^\'\\])*\'?|//')
RAW_PREFIX = re.compile(r"(?:^|\W)(?:u8|u|U|L)?$")  # what may come before a raw string's R
LINK = re.compile(r"\]\(([^)\s]+)\)")


def tracked_files(root):
    """The repository's files, relative to root."""
    if (root / ".git").exists():
        listed = subprocess.run(["git", "-C", str(root), "ls-files"], check=True, capture_output=True, text=True)
        return [name for name in listed.stdout.splitlines() if (root / name).exists()]
    found = (str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())
    return sorted(name for name in found if name.split("/")[0] not in GENERATED_FOLDERS | {".git"})


def cpp_comments(text):
    """(line number, text) of each `//` comment; string and character
    literals are skipped, raw strings too."""
    in_raw = None  # the delimiter of a raw string left open on an earlier line
    for number, line in enumerate(text.splitlines(), 1):
        i = 0
        if in_raw is not None:
            end = line.find(")" + in_raw + '"')
            if end < 0:
                continue
            i, in_raw = end + len(in_raw) + 2, None
        while (token := CPP_TOKEN.search(line, i)) is not None:
            if token.group(0) == "//":
                yield number, line[token.start():]
                break
            if token.group(1) is None:
                i = token.end()
            elif not RAW_PREFIX.search(line, 0, token.start()):
                i = token.start() + 1  # an R ending a name: the string starts at the quote
            elif (end := line.find(")" + token.group(1) + '"', token.end())) >= 0:
                i = end + len(token.group(1)) + 2
            else:
                in_raw = token.group(1)
                break


def hash_comments(text):
    """(line number, text) of each `#` comment: a `#` at the start of a line
    or after a blank, outside quotes (not a shebang, `$#` or `${#x}`)."""
    for number, line in enumerate(text.splitlines(), 1):
        if number == 1 and line.startswith("#!"):
            continue
        quote = None
        for i, c in enumerate(line):
            if quote:
                quote = None if c == quote else quote
            elif c in "\"'":
                quote = c
            elif c == "#" and (i == 0 or line[i - 1] in " \t"):
                yield number, line[i:]
                break


def expand_braces(word):
    """`a.{h,cc}` as `a.h`, `a.cc`."""
    parts = re.split(r"(\{[^{}]*\})", word)
    choices = [p[1:-1].split(",") if p.startswith("{") else [p] for p in parts]
    return ["".join(c) for c in itertools.product(*choices)]


class Repository:
    def __init__(self, root):
        self.root = root
        self.files = tracked_files(root)
        self.paths = set(self.files)
        for name in self.files:
            parts = name.split("/")
            self.paths.update("/".join(parts[:k]) for k in range(1, len(parts)))
        self.top_folders = {name.split("/")[0] for name in self.files if "/" in name}
        self.file_names = {name.rsplit("/", 1)[-1] for name in self.files}
        self.extensions = {folder: set() for folder in self.top_folders}
        for name in self.files:
            if "/" in name and "." in name.rsplit("/", 1)[1].lstrip("."):
                self.extensions[name.split("/")[0]].add(name.rsplit(".", 1)[1])

    def is_repository_path(self, word):
        """Whether a word with a `/` names a repository path (the rules above)."""
        first, last = word.split("/")[0], word.rstrip("/").split("/")[-1]
        extension = last.rsplit(".", 1)[1] if "." in last.lstrip(".") else None
        if first in GENERATED_FOLDERS or first in (".", ""):
            return False
        if first in self.top_folders:
            return extension is None or extension in self.extensions[first]
        return word.endswith(SOURCE_EXTENSIONS)

    def exists(self, path, cited_from):
        """Whether `path` names a tracked file or folder from the root or from
        the folder of `cited_from`; a glob must match one."""
        here = str(pathlib.PurePosixPath(cited_from).parent)
        for base in ("", "" if here == "." else here + "/"):
            candidate = normalize(base + path.rstrip("/"))
            if candidate is None:
                continue
            if any(c in candidate for c in "*?"):
                if any(fnmatch.fnmatchcase(p, candidate) for p in self.paths):
                    return True
            elif candidate in self.paths:
                return True
        return False

    def leaves(self, path, cited_from):
        """Whether a relative path climbs out of the repository."""
        return path.startswith("../") and normalize(str(pathlib.PurePosixPath(cited_from).parent) + "/" + path) is None


def normalize(path):
    """`a/./b/../c` as `a/c`; None where it climbs above the root."""
    out = []
    for part in path.split("/"):
        if part in ("", "."):
            continue
        if part == "..":
            if not out:
                return None
            out.pop()
        else:
            out.append(part)
    return "/".join(out)


def named_paths(text, repo, in_doc):
    """The repository paths a line of a doc or a comment names."""
    for match in WORD.finditer(text):
        word, start = match.group(0), match.start()
        before = text[start - 1] if start else " "
        word = word.rstrip(".,;:")
        if placeholder := PLACEHOLDER.search(word):
            # What a placeholder stands for may not exist yet: the folder before it must.
            word = word[: word.rfind("/", 0, placeholder.start()) + 1]
        if "/" not in word or "..." in word or word.startswith(("/", "../")) or before in "$~{}<@:":
            continue
        if any(repo.is_repository_path(variant) for variant in expand_braces(word)):
            yield word
    if in_doc:
        for match in BACKTICKED_NAME.finditer(text):
            if match.group(1).endswith(SOURCE_EXTENSIONS) and "/" not in match.group(1):
                yield match.group(1)


def places(repo):
    """(file, line number, text, in a doc) of every doc line and comment."""
    for name in repo.files:
        path = repo.root / name
        base = name.rsplit("/", 1)[-1]
        is_doc = name == "README.md" or re.fullmatch(r"docs/[^/]+\.md", name)
        if is_doc:
            lines = enumerate(path.read_text(errors="replace").splitlines(), 1)
        elif base.endswith((".cc", ".h")):
            lines = cpp_comments(path.read_text(errors="replace"))
        elif base == "CMakeLists.txt" or base.endswith((".cmake", ".sh", ".py")) or name == ".ci/run":
            lines = hash_comments(path.read_text(errors="replace"))
        else:
            continue
        for number, text in lines:
            yield name, number, text, bool(is_doc)


def check_paths(repo):
    failures = []
    for name, number, text, in_doc in places(repo):
        if OUTSIDE_FILE.search(text):
            failures.append(f"{name}:{number}: cites DESIGN.md, a file outside the repository")
        for match in re.finditer(r"(?<![\w./])(?:\.\./)+[\w.\-/]*", text):
            if repo.leaves(match.group(0), name):
                failures.append(f"{name}:{number}: cites {match.group(0)}, which is outside the repository")
        for word in named_paths(text, repo, in_doc):
            if OUTSIDE_FILE.fullmatch(word):
                continue  # reported above
            if "/" not in word:
                if word not in repo.file_names:
                    failures.append(f"{name}:{number}: names {word}, which does not exist")
            elif not all(repo.exists(p, name) for p in expand_braces(word)):
                failures.append(f"{name}:{number}: names {word}, which does not exist")
        if in_doc:
            for match in LINK.finditer(text):
                target = match.group(1).split("#")[0]
                if target and not re.match(r"[a-z]+:", target) and not repo.exists(target, name):
                    failures.append(f"{name}:{number}: links {target}, which does not exist")
    return failures


def check_architecture(repo):
    """Every library (a folder whose CMakeLists.txt calls mesocap_library)
    is a row of ARCHITECTURE's table, and every pipelines/*.h is named in its
    part on pipelines/ (up to the next bold folder name or heading)."""
    doc_name = "docs/ARCHITECTURE.md"
    if doc_name not in repo.paths:
        return [f"{doc_name}: missing, so it lists no library and no pipeline"]
    doc = (repo.root / doc_name).read_text()
    rows = set(re.findall(r"^\| `([\w/]+)/` \|", doc, re.M))
    failures = []
    for name in repo.files:
        if name.endswith("/CMakeLists.txt") and re.search(r"^\s*mesocap_library\(", (repo.root / name).read_text(), re.M):
            folder = name.rsplit("/", 1)[0]
            if folder not in rows:
                failures.append(f"{doc_name}: lists no library {folder}/ (its CMakeLists.txt defines one)")
    paragraph = re.search(r"^\*\*`pipelines/`\*\*.*?(?=^\*\*|^#|\Z)", doc, re.M | re.S)
    paragraph = paragraph.group(0) if paragraph else ""
    for name in repo.files:
        if re.fullmatch(r"pipelines/[^/]+\.h", name) and f"`{name.split('/')[1]}`" not in paragraph:
            failures.append(f"{doc_name}: its part on pipelines/ does not name {name}")
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", default=pathlib.Path(__file__).resolve().parent.parent)
    args = parser.parse_args()
    repo = Repository(pathlib.Path(args.root))
    failures = check_paths(repo) + check_architecture(repo)
    for failure in failures:
        print(failure)
    print(f"{len(failures)} failures" if failures else "the docs check passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
