#!/usr/bin/env python3
"""Hostile-input acceptance run: nothing lost, nothing silently wrong.

Generates seeded hostile inputs, runs the real mesocap binary on each and
classifies every outcome:

  ok-rejected        refused: exit 1 (CLI usage errors: CLI11's code), one
                     error line naming the file and the field or flag, no
                     output or temporary left behind, inputs unchanged
  ok-accepted        a valid input (control, valid --replace) accepted
  ok-accepted-mut    a mutated JSON document that is still valid (or whose
                     changed value may legitimately be in range) accepted
  CRASH              signal, exit >= 128, sanitizer report, uncaught exception
  HANG               no exit within --timeout seconds
  SILENT-ACCEPT      corrupt or invalid input accepted (exit 0)
  BAD-MESSAGE        error not one line, library chatter on stderr, library
                     text in the error (LIBRARY_TEXT_RE), a line
                     longer than 400 characters, not naming the file and
                     field or flag, an exit code other than 0/1
  LEFTOVER           output, a temporary or a changed input left after the run
  REJECTED-VALID     a document that is still valid after the mutation refused

Everything except ok-* is a failure; the script exits 1 when any case fails.

Kinds of cases:
  session-data    1-byte flips / truncations of a capture session's data files
  package-data    the same for material packages (ground truth, compressed, MDF)
  json-mutation   flips / truncations of JSON documents (manifests, journal,
                  calibration, rig description, render scene, fault plan)
  field-edit      known-invalid values, unknown keys, wrong lengths, huge
                  strings, deep nesting, broken OBJ files
  cli-flag        flags out of range or malformed
  replace-misuse  --replace / --out aimed at user files or the command's input

Usage: scripts/hostile_inputs.py [--seed N] [--cases N] [--binary PATH] [--keep]
       [--only ID,ID...] [--timeout S]
Standard library only.
"""

import argparse
import copy
import hashlib
import json
import os
import random
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_BINARY = REPO / "build" / "release" / "apps" / "mesocap"
MAX_LINE = 400

OK_REJECTED = "ok-rejected"
OK_ACCEPTED = "ok-accepted"
OK_ACCEPTED_MUT = "ok-accepted-mut"
CRASH = "CRASH"
HANG = "HANG"
SILENT = "SILENT-ACCEPT"
BAD = "BAD-MESSAGE"
LEFTOVER = "LEFTOVER"
REJ_VALID = "REJECTED-VALID"
OUTCOMES = [OK_REJECTED, OK_ACCEPTED, OK_ACCEPTED_MUT, CRASH, HANG, SILENT, BAD, LEFTOVER, REJ_VALID]
KINDS = ["control", "session-data", "package-data", "json-mutation", "field-edit", "cli-flag", "replace-misuse"]

SPDLOG_RE = re.compile(r"^\[\d\d:\d\d:\d\d\.\d{3}\] \[(trace|debug|info|warning|error|critical)\] ")
TEMP_RE = re.compile(r"(^|/)\.[^/]*\.tmp-")
SANITIZER_MARKERS = ("AddressSanitizer", "LeakSanitizer", "UndefinedBehaviorSanitizer", "runtime error:",
                     "terminate called", "Segmentation fault", "Aborted", "stack smashing")

MB3 = 3 * 1024 * 1024

# Text of a library or the standard library reaching the user untranslated:
# codec messages (OpenEXR, libpng, zlib, libtiff, libjpeg), the C++ library's
# exception texts and a JSON value printed where a kind was meant.
LIBRARY_TEXT_RE = re.compile(
    r"OpenEXR|Iex::|[Ee]xception|IDAT|IHDR|zlib|libpng|libtiff|Failed to read directory|invalid (distance|code|block)|"
    r"Premature end|JPEG datastream|filesystem error|basic_string|std::|stoi|stod|vector::|bad_alloc|"
    r"got null null|\[json\.")


# ----------------------------------------------------------------------------
# The case and its classification


class Case:
    """One run of mesocap on one hostile input.

    expect: "reject" (corrupt / invalid input), "accept" (valid input), or
    "either" (a mutated document that may legitimately be valid).
    name_any: the error line must contain one of these (the file; for verify,
    any stderr line may name it). field_any: the error line must contain one
    of these (the field or the flag); None: not checked. outs: paths (relative
    to the case folder) the command may create or change when it succeeds.
    """

    def __init__(self, kind, what, args, setup, expect, name_any, field_any=None, outs=(), verify=False,
                 cli=False, note=""):
        self.id = ""
        self.kind = kind
        self.what = what
        self.args = args
        self.setup = setup
        self.expect = expect
        self.name_any = name_any
        self.field_any = field_any
        self.outs = list(outs)
        self.verify = verify
        self.cli = cli
        self.note = note
        # results
        self.outcome = None
        self.reasons = []
        self.rc = None
        self.stderr = ""
        self.seconds = 0.0


def snapshot(root):
    """relative path -> (kind, size, sha1) of everything under root."""
    snap = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for d in dirnames:
            p = os.path.join(dirpath, d)
            rel = os.path.relpath(p, root)
            snap[rel] = ("link", os.readlink(p), "") if os.path.islink(p) else ("dir", 0, "")
        for f in filenames:
            p = os.path.join(dirpath, f)
            rel = os.path.relpath(p, root)
            if os.path.islink(p):
                snap[rel] = ("link", os.readlink(p), "")
                continue
            h = hashlib.sha1()
            try:
                with open(p, "rb") as fh:
                    for chunk in iter(lambda: fh.read(1 << 20), b""):
                        h.update(chunk)
                snap[rel] = ("file", os.path.getsize(p), h.hexdigest())
            except OSError as e:
                snap[rel] = ("unreadable", 0, str(e))
    return snap


def under(rel, outs):
    for o in outs:
        o = os.path.normpath(o)
        if rel == o or rel.startswith(o + "/"):
            return True
    return False


def classify(case, rc, stderr, before, after, timed_out):
    reasons = []
    if timed_out:
        return HANG, ["no exit within the timeout"]
    lines = [l for l in stderr.splitlines() if l.strip() != ""]
    sanitizer = [m for m in SANITIZER_MARKERS if m in stderr]
    if rc < 0 or rc >= 128 or sanitizer:
        why = "signal %d" % -rc if rc < 0 else "exit %d" % rc
        return CRASH, [why] + (["stderr: " + ", ".join(sanitizer)] if sanitizer else [])

    progress, spd_err, errors, other = [], [], [], []
    for l in lines:
        if l.startswith("{"):
            try:
                obj = json.loads(l)
                if isinstance(obj, dict) and "task" in obj:
                    progress.append(l)
                    continue
            except ValueError:
                pass
        m = SPDLOG_RE.match(l)
        if m:
            if m.group(1) in ("error", "critical"):
                spd_err.append(l)
            continue
        if l.startswith("mesocap: error: ") or l.startswith("mesocap: internal error: "):
            errors.append(l)
        else:
            other.append(l)
    long_lines = [l for l in lines if len(l) > MAX_LINE]
    if long_lines:
        reasons.append("stderr line of %d characters" % max(len(l) for l in long_lines))
    internal = [l for l in errors if l.startswith("mesocap: internal error: ")]
    if internal:
        reasons.append("uncaught exception: " + internal[0][:160])
    library = [l for l in errors if LIBRARY_TEXT_RE.search(l)]
    if library:
        reasons.append("library text in the message: " + library[0][:160])

    # changes to the case folder
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    temps = sorted(k for k in after if TEMP_RE.search(k) and k not in before)

    if rc == 0:
        if other:
            reasons.append("chatter on stderr: " + other[0][:160])
        bad_changes = [k for k in changed if not under(k, case.outs)]
        left = []
        if temps:
            left.append("temporary left: " + temps[0])
        if bad_changes:
            left.append("changed outside the output: " + bad_changes[0])
        if case.expect == "reject":
            return SILENT, ["exit 0 on corrupt/invalid input"] + reasons + left
        if left:
            return LEFTOVER, left + reasons
        if reasons:
            return BAD, reasons
        return (OK_ACCEPTED if case.expect == "accept" else OK_ACCEPTED_MUT), []

    # rc in 1..127: refused
    if case.cli:
        # CLI11 prints its own messages (any line that is not a log line)
        errors = errors + other
        other = []
    elif rc != 1:
        reasons.append("exit code %d" % rc)
    if other:
        reasons.append("chatter on stderr: " + other[0][:160])
    if spd_err and not case.verify:
        reasons.append("%d [error] log line(s) besides the error" % len(spd_err))
    if len(errors) == 0:
        reasons.append("no error line")
    elif len(errors) > 1:
        reasons.append("%d error lines: %s" % (len(errors), " | ".join(e[:100] for e in errors[:3])))
    err = errors[-1] if errors else ""
    if errors:
        pool = "\n".join(lines) if case.verify else err
        if case.name_any and not any(n in pool for n in case.name_any):
            reasons.append("does not name %s" % " or ".join(repr(n) for n in case.name_any[:3]))
        if case.field_any and not any(f.lower() in pool.lower() for f in case.field_any):
            reasons.append("does not name the field/flag %s" % " or ".join(repr(f) for f in case.field_any[:3]))
    left = []
    if changed:
        left.append("after refusal changed: " + ", ".join(changed[:3]) + (" ..." if len(changed) > 3 else ""))
    if temps:
        left.append("temporary left: " + temps[0])
    if left:
        return LEFTOVER, left + reasons
    if reasons:
        return BAD, reasons
    if case.expect == "accept":
        return REJ_VALID, ["valid input refused: " + err[:200]]
    return OK_REJECTED, []


BINARY_CHANGES = []


def wait_for_binary(binary, patience=900):
    """Others rebuild the binary from time to time: wait until it exists, is
    executable and has not changed for 5 seconds."""
    deadline = time.monotonic() + patience
    while True:
        try:
            st = os.stat(binary)
            if os.access(binary, os.X_OK) and time.time() - st.st_mtime > 5:
                if not BINARY_CHANGES or BINARY_CHANGES[-1] != st.st_mtime:
                    BINARY_CHANGES.append(st.st_mtime)
                return
        except OSError:
            pass
        if time.monotonic() > deadline:
            sys.exit("hostile_inputs: %s did not become usable" % binary)
        time.sleep(2)


def run_case(case, binary, case_dir, timeout):
    before = snapshot(case_dir)
    timed_out = False
    for attempt in range(100):
        wait_for_binary(binary)
        try:
            start = time.monotonic()
            proc = subprocess.Popen([str(binary), "-q"] + case.args, cwd=case_dir, stdin=subprocess.DEVNULL,
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
            break
        except OSError:  # being relinked right now
            time.sleep(3)
    else:
        sys.exit("hostile_inputs: cannot run %s" % binary)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except OSError:
            pass
        out, err = proc.communicate()
    case.seconds = time.monotonic() - start
    rc = proc.returncode
    case.rc = rc
    case.stderr = err.decode("utf-8", "replace")
    after = snapshot(case_dir)
    case.outcome, case.reasons = classify(case, rc, case.stderr, before, after, timed_out)


# ----------------------------------------------------------------------------
# Helpers to build inputs


def copy_tree(src, dst):
    shutil.copytree(src, dst, symlinks=True)


def flip_byte(path, rng_state):
    """rng_state: (offset fraction, xor) drawn at generation time."""
    frac, x = rng_state
    data = bytearray(Path(path).read_bytes())
    off = min(int(frac * len(data)), len(data) - 1)
    data[off] ^= x
    Path(path).write_bytes(bytes(data))
    return off


def truncate(path, frac):
    size = os.path.getsize(path)
    new = min(int(frac * size), size - 1)
    with open(path, "r+b") as fh:
        fh.truncate(new)
    return new


def flag_names(flag):
    stem = flag.lstrip("-")
    names = {flag, stem, stem.replace("-", "_"), stem.replace("-", " ")}
    if stem.endswith("s"):
        names.add(stem[:-1])
    if stem.endswith("-mm"):
        names.add(stem[:-3])
        names.add(stem[:-3].replace("-", "_"))
    return sorted(names)


def strict_json_loads(text):
    """json.loads that rejects NaN/Infinity literals and numbers that overflow a
    double, and reports duplicate keys (returns (value, had_duplicates))."""
    dup = [False]

    def pairs(items):
        d = {}
        for k, v in items:
            if k in d:
                dup[0] = True
            d[k] = v
        return d

    def bad_constant(c):
        raise ValueError("constant " + c)

    def parse_float(s):
        v = float(s)
        if v != v or v in (float("inf"), float("-inf")):
            raise ValueError("overflow " + s)
        return v

    v = json.loads(text, object_pairs_hook=pairs, parse_constant=bad_constant, parse_float=parse_float)
    return v, dup[0]


def json_diffs(a, b, path=()):
    """Differences between two parsed JSON values: list of (path, what)."""
    if type(a) != type(b) and not (isinstance(a, (int, float)) and isinstance(b, (int, float))
                                   and not isinstance(a, bool) and not isinstance(b, bool)):
        return [(path, "type")]
    if isinstance(a, dict):
        out = []
        for k in set(a) | set(b):
            if k not in a or k not in b:
                out.append((path + (k,), "key"))
            else:
                out.extend(json_diffs(a[k], b[k], path + (k,)))
        return out
    if isinstance(a, list):
        if len(a) != len(b):
            return [(path, "length")]
        out = []
        for i, (x, y) in enumerate(zip(a, b)):
            out.extend(json_diffs(x, y, path + (i,)))
        return out
    if a != b or type(a) != type(b):
        return [(path, "value")]
    return []


def leaf_key(path):
    for p in reversed(path):
        if isinstance(p, str):
            return p
    return ""


def path_text(path):
    s = ""
    for p in path:
        s += "[%d]" % p if isinstance(p, int) else ("." if s else "") + str(p)
    return s


# Values whose change always breaks the document (enumerations, references,
# checksums, format identification).
MUST_REJECT_KEYS = {"format", "version", "length", "angle", "xxh3_64", "bytes", "file", "files", "row_files",
                    "column_file", "values", "singular_values", "layout", "color", "seq", "step", "kind", "path",
                    "parent", "child", "shape", "material", "camera", "units", "max_distance_code", "no_hit_code",
                    "unknown_code"}


CHECKSUM_FIELDS = ["field", "line", "checksum", "xxh3", "bytes", "missing", "path"]


def judge_json(doc_kind, orig_text, new_bytes, reads=lambda rel: True):
    """Whether a mutated JSON document must be refused by a command that
    reads the data files for which reads(rel) is true.

    Returns (expect, note, field_any): expect "reject", "either" or "accept"
    (for a journal also "incomplete")."""
    if doc_kind == "journal":
        return judge_journal(orig_text, new_bytes, reads)
    try:
        text = new_bytes.decode("utf-8")
    except UnicodeDecodeError:
        return "reject", "invalid UTF-8", None
    try:
        new, dup = strict_json_loads(text)
    except ValueError as e:
        return "reject", "no longer parses (%s)" % str(e)[:60], None
    orig, _ = strict_json_loads(orig_text)
    if dup:
        return "either", "duplicate key after the mutation", None
    diffs = json_diffs(orig, new)
    if not diffs:
        return "accept", "still parses to the same document (whitespace)", None
    verdict = "either"
    fields = []
    notes = []
    for path, what in diffs:
        k = leaf_key(path)
        free = doc_kind == "session" and (path[:1] == ("rig",) or (
            path[:2] == ("plan", "steps") and k not in ("id", "kind", "files", "camera", "path")))
        notes.append("%s %s" % (what, path_text(path)))
        if what == "key" and not free:
            verdict = "reject"
            fields.append(str(path[-1])[:40])
        elif what == "value" and (k in MUST_REJECT_KEYS or (doc_kind == "session" and k == "id")):
            if doc_kind == "package" and path[:1] == ("files",) and k in ("bytes", "xxh3_64"):
                # the checksum of one data file: only a command reading that file sees it
                if not reads(path[1]):
                    continue
                fields += CHECKSUM_FIELDS
            if doc_kind == "session" and path[:2] == ("plan", "steps") and k in ("camera", "path"):
                # a plan step's file: only a command reading that step's data sees it
                step = orig["plan"]["steps"][path[2]]
                rel = step["files"][path[4]]["path"]
                if not reads(rel) or reads("*verify*"):
                    continue
                fields += CHECKSUM_FIELDS
            if doc_kind == "session" and path[:1] == ("calibration",):
                fields += CHECKSUM_FIELDS + ["calibration"]
            verdict = "reject"
            fields.append(k)
    return verdict, "parses; " + "; ".join(notes)[:160], (["field", "line"] + fields) if verdict == "reject" else None


def judge_journal(orig_text, data, reads=lambda rel: True):
    """A journal is judged line by line: a last line without its newline, or
    one that is not valid JSON, is a torn tail that readers drop."""
    orig_lines = orig_text.split("\n")[:-1]
    parts = data.split(b"\n")
    complete, tail = parts[:-1], parts[-1]
    torn = tail != b""
    parsed = []
    for i, l in enumerate(complete):
        try:
            parsed.append(strict_json_loads(l.decode("utf-8")))
        except ValueError:  # UnicodeDecodeError included
            if i == len(complete) - 1 and not torn:
                torn = True  # an invalid last line is a torn tail: dropped
                complete = complete[:-1]
                break
            return "reject", "line %d no longer parses (mid-journal)" % (i + 1), ["line"]
    if len(complete) < len(orig_lines) or torn:
        return "incomplete", "journal loses its last record(s) (torn tail)", None
    verdict, notes, fields = "accept", [], []
    for i, ((new, dup), ol) in enumerate(zip(parsed, orig_lines)):
        old, _ = strict_json_loads(ol)
        if dup:
            return "either", "duplicate key in line %d" % (i + 1), None
        for path, what in json_diffs(old, new):
            k = leaf_key(path)
            notes.append("line %d: %s %s" % (i + 1, what, path_text(path)))
            if what == "value" and path[:1] == ("files",) and k in ("bytes", "xxh3_64", "path"):
                # a file's record: only a command reading that file sees the change
                if reads(old["files"][path[1]]["path"]):
                    verdict = "reject"
                    fields += CHECKSUM_FIELDS
                elif verdict != "reject":
                    verdict = "either"
            elif what == "key" or k in MUST_REJECT_KEYS:
                verdict = "reject"
                fields.append(str(path[-1]))
            elif verdict != "reject":
                verdict = "either"
    if verdict == "accept":
        return "accept", "same records", None
    return verdict, "; ".join(notes)[:160], (["field", "line"] + fields) if verdict == "reject" else None


# ----------------------------------------------------------------------------
# Base inputs

SCENE_TEMPLATE = {
    "format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -60, 30], "look_at": [0, 0, 0], "fov_y_deg": 40},
    "light": {"position": [40, -60, 80], "intensity": 20000},
    "objects": [
        {"name": "c", "shape": "cylinder", "radius": 10, "height": 30, "segments": 16, "rings": 3,
         "material": "C", "rotate_deg": [0, 90, 0], "translate": [-15, 0, 0]},
        {"shape": "box", "min": [-30, -30, -12], "max": [30, 30, -10], "albedo": [0.5, 0.5, 0.5]},
    ],
}

CUBE_OBJ = """v -4 -4 -2
v 4 -4 -2
v 4 4 -2
v -4 4 -2
v -4 -4 0
v 4 -4 0
v 4 4 0
v -4 4 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
f 5/1 6/2 7/3 8/4
f 1/1 4/2 3/3 2/4
f 1/1 2/2 6/3 5/4
f 2/1 3/2 7/3 6/4
f 3/1 4/2 8/3 7/4
f 4/1 1/2 5/3 8/4
"""

FAULTS = {"format": "mesocap.faults", "version": 1, "camera_drop_frame": {"rate": 0.01}}


def make_base(binary, base, timeout):
    base.mkdir(parents=True)
    steps = [
        ["simulate", "--rig", "tiny", "--out", "S"],
        ["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "T"],
        ["compress", "--in", "T", "--out", "C"],
        ["process", "mdf", "--session", "S", "--texture-size", "8", "--out", "M"],
        ["export", "bonn", "--in", "C", "--form", "dfmf", "--out", "c.dfmf"],
        ["export", "bonn", "--in", "C", "--form", "ubo2003", "--encoding", "exr", "--out", "U2"],
    ]
    for s in steps:
        r = subprocess.run([str(binary), "-q"] + s, cwd=base, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           timeout=timeout)
        if r.returncode != 0:
            sys.exit("hostile_inputs: building the base input failed: mesocap %s\n%s" %
                     (" ".join(s), r.stderr.decode(errors="replace")[-2000:]))
    shutil.copy(REPO / "sim" / "rigs" / "tiny.json", base / "rig.json")
    shutil.copy(base / "S" / "calibration.json", base / "calib.json")
    scene = copy.deepcopy(SCENE_TEMPLATE)
    (base / "scene.json").write_text(json.dumps(scene, indent=2) + "\n")
    (base / "cube.obj").write_text(CUBE_OBJ)
    (base / "faults.json").write_text(json.dumps(FAULTS, indent=2) + "\n")


class Base:
    """Paths and contents of the base inputs."""

    def __init__(self, root):
        self.root = root
        self.S = root / "S"
        self.T = root / "T"
        self.C = root / "C"
        self.M = root / "M"
        self.files = {}
        for name in ("S", "T", "C", "M"):
            self.files[name] = sorted(str(p.relative_to(root / name)) for p in (root / name).rglob("*")
                                      if p.is_file())
        self.session_data = [f for f in self.files["S"] if f.split("/")[0] in ("btf", "laser", "laser_calibration")]
        self.pkg_data = {n: sorted(json.loads((root / n / "manifest.json").read_text())["files"]) for n in "TCM"}
        self.steps = json.loads((root / "S" / "manifest.json").read_text())["plan"]["steps"]


# ----------------------------------------------------------------------------
# Command templates (paths relative to the case folder)


def a(path):
    return str(path)


def cmd_verify(p):
    return ["verify", p], [], True


def cmd_process_mdf(s, out="X", calib=None):
    args = ["process", "mdf", "--session", s, "--texture-size", "8", "--out", out]
    if calib:
        args += ["--calibration", calib]
    return args, [out], False


def cmd_process_btf(s, out="X", calib=None):
    args = ["process", "btf", "--session", s, "--texture-size", "8", "--out", out]
    if calib:
        args += ["--calibration", calib]
    return args, [out], False


def cmd_compress(p, out="X"):
    return ["compress", "--in", p, "--out", out], [out], False


def cmd_eval_btf(truth, est):
    return ["eval", "btf", "--truth", truth, "--estimate", est], [], False


def cmd_eval_mdf(truth, est):
    return ["eval", "mdf", "--truth", truth, "--estimate", est], [], False


def cmd_export(p, out="X.dfmf"):
    return ["export", "bonn", "--in", p, "--form", "dfmf", "--out", out], [out], False


def cmd_render(scene="scene.json", out="r.png"):
    return ["render", scene, "--out", out, "--size", "64x48"], [out], False


def cmd_groundtruth(rig="tiny", scene=None, out="X"):
    args = ["groundtruth", "--rig", rig, "--texture-size", "8", "--out", out]
    if scene:
        args += ["--scene", scene]
    return args, [out], False


def cmd_simulate(rig="tiny", faults=None, scene=None, out="X"):
    args = ["simulate", "--rig", rig, "--out", out]
    if faults:
        args += ["--faults", faults]
    if scene:
        args += ["--scene", scene]
    return args, [out], False


def write_scene(case_dir, material, doc=None):
    scene = copy.deepcopy(doc if doc is not None else SCENE_TEMPLATE)
    scene["objects"][0]["material"] = material
    (case_dir / "scene.json").write_text(json.dumps(scene, indent=2) + "\n")


# ----------------------------------------------------------------------------
# Generators


def gen_controls(base):
    B = base.root
    S, T, C, M = a(B / "S"), a(B / "T"), a(B / "C"), a(B / "M")
    cases = []

    def add(what, tmpl, setup=lambda d: None):
        args, outs, ver = tmpl

        def s(d):
            setup(d)
            return ""
        cases.append(Case("control", what, args, s, "accept", [], outs=outs, verify=ver))

    add("verify session", cmd_verify(S))
    for p in (T, C, M):
        add("verify package " + Path(p).name, cmd_verify(p))
    add("process mdf", cmd_process_mdf(S))
    add("process btf", cmd_process_btf(S))
    add("process mdf --calibration", cmd_process_mdf(S, calib=a(B / "calib.json")))
    add("process btf --calibration", cmd_process_btf(S, calib=a(B / "calib.json")))
    add("compress T", cmd_compress(T))
    add("eval btf T C", cmd_eval_btf(T, C))
    add("eval btf T T", cmd_eval_btf(T, T))
    add("eval mdf T M", cmd_eval_mdf(T, M))
    add("eval mdf T C", cmd_eval_mdf(T, C))
    add("export dfmf C", cmd_export(C))
    add("export dfmf T", cmd_export(T))
    add("render", cmd_render(), lambda d: write_scene(d, a(B / "C")))
    add("groundtruth rig file", cmd_groundtruth(rig="rig.json"), lambda d: shutil.copy(B / "rig.json", d))
    add("groundtruth obj", cmd_groundtruth(scene="cube.obj"), lambda d: shutil.copy(B / "cube.obj", d))
    add("simulate faults", cmd_simulate(faults="faults.json"), lambda d: shutil.copy(B / "faults.json", d))
    add("simulate rig file", cmd_simulate(rig="rig.json"), lambda d: shutil.copy(B / "rig.json", d))
    add("import dfmf", (["import", "bonn", "--in", a(B / "c.dfmf"), "--out", "X", "--d-max-mm", "1"], ["X"], False))
    return cases


def gen_session_data(base, rng, n):
    cases = []
    B = base.root
    for i in range(n):
        rel = rng.choice(base.session_data)
        trunc = rng.random() < 0.2
        state = rng.random() if trunc else (rng.random(), rng.randrange(1, 256))
        if rel.startswith("btf/"):
            choices = ["verify", "process btf"]
        else:
            choices = ["verify", "process mdf"]
        which = choices[i % 2] if rng.random() < 0.8 else rng.choice(choices)
        tmpl = {"verify": cmd_verify("Sx"), "process mdf": cmd_process_mdf("Sx"),
                "process btf": cmd_process_btf("Sx")}[which]

        def setup(d, rel=rel, trunc=trunc, state=state):
            copy_tree(B / "S", d / "Sx")
            if trunc:
                return "truncated Sx/%s to %d bytes" % (rel, truncate(d / "Sx" / rel, state))
            return "flipped byte %d of Sx/%s (xor 0x%02x)" % (flip_byte(d / "Sx" / rel, state), rel, state[1])

        args, outs, ver = tmpl
        cases.append(Case("session-data", "%s of Sx/%s" % ("truncation" if trunc else "byte flip", rel), args,
                          setup, "reject", [rel], outs=outs, verify=ver))
    return cases


def package_commands(pkg, rel, B):
    """Commands that read data file rel of package pkg (a copy named pkg+'x')."""
    x = pkg + "x"
    T, C, M = a(B / "T"), a(B / "C"), a(B / "M")
    cmds = [("verify", cmd_verify(x), None)]
    if pkg == "T":
        if rel.startswith("btf/"):
            cmds += [("compress", cmd_compress(x), None), ("eval btf", cmd_eval_btf(x, C), None),
                     ("export", cmd_export(x), None)]
        elif rel == "mdf.exr":
            cmds += [("compress", cmd_compress(x), None), ("eval mdf", cmd_eval_mdf(x, M), None)]
        elif rel == "ambient.exr":
            cmds += [("compress", cmd_compress(x), None), ("eval btf", cmd_eval_btf(x, C), None)]
        elif rel == "calibration.json":
            cmds += [("compress", cmd_compress(x), None)]
    elif pkg == "C":
        if rel.startswith("btf/"):
            cmds += [("eval btf", cmd_eval_btf(T, x), None), ("export", cmd_export(x), None),
                     ("render", cmd_render(), x)]
        elif rel == "mdf.exr":
            cmds += [("eval mdf", cmd_eval_mdf(T, x), None), ("render", cmd_render(), x)]
        elif rel == "ambient.exr":
            cmds += [("eval btf", cmd_eval_btf(T, x), None), ("render", cmd_render(), x)]
    elif pkg == "M":
        if rel == "mdf.exr":
            cmds += [("eval mdf", cmd_eval_mdf(T, x), None)]
    return cmds


def gen_package_data(base, rng, n):
    cases = []
    B = base.root
    for i in range(n):
        pkg = rng.choice(["T", "T", "C", "C", "M"])
        rel = rng.choice(base.pkg_data[pkg])
        trunc = rng.random() < 0.3
        state = rng.random() if trunc else (rng.random(), rng.randrange(1, 256))
        cmds = package_commands(pkg, rel, B)
        name, tmpl, scene_material = cmds[i % len(cmds)] if rng.random() < 0.7 else rng.choice(cmds)
        x = pkg + "x"

        def setup(d, pkg=pkg, rel=rel, trunc=trunc, state=state, scene_material=scene_material, x=x):
            copy_tree(B / pkg, d / x)
            if scene_material:
                write_scene(d, scene_material)
            if trunc:
                return "truncated %s/%s to %d bytes" % (x, rel, truncate(d / x / rel, state))
            return "flipped byte %d of %s/%s (xor 0x%02x)" % (flip_byte(d / x / rel, state), x, rel, state[1])

        args, outs, ver = tmpl
        cases.append(Case("package-data", "%s of %s/%s" % ("truncation" if trunc else "byte flip", x, rel), args,
                          setup, "reject", [x + "/" + rel], outs=outs, verify=ver))
    return cases


def command_reads(args, tree):
    """Predicate: does this command read data file rel of the mutated copy?"""
    cmd = " ".join(args[:2])
    x = tree[1] if tree else None

    def reads(rel):
        if args[0] == "verify":
            return True
        if rel == "*verify*":
            return False
        top = rel.split("/")[0]
        if cmd == "process mdf":
            return top in ("laser", "laser_calibration") or rel == "calibration.json"
        if cmd == "process btf":
            return top == "btf" or rel == "calibration.json"
        if args[0] == "compress":
            return top == "btf" or rel in ("mdf.exr", "ambient.exr", "calibration.json", "error_report.json")
        if cmd == "eval btf":
            return top == "btf" or rel == "ambient.exr"
        if cmd == "eval mdf":
            return rel == "mdf.exr" and x in args
        if cmd == "export bonn":
            return top == "btf"
        if args[0] == "render":
            return top == "btf" or rel in ("mdf.exr", "ambient.exr")
        return True

    return reads


def gen_json_mutation(base, rng, n):
    B = base.root
    T, C, M, S = a(B / "T"), a(B / "C"), a(B / "M"), a(B / "S")
    # (label, doc kind, source file, copy: (src tree, dst name) or None, file in case dir, commands)
    targets = [
        ("T manifest", "package", "T/manifest.json", ("T", "Tx"), "Tx/manifest.json",
         [cmd_verify("Tx"), cmd_compress("Tx"), cmd_eval_btf("Tx", C), cmd_eval_mdf("Tx", M)], None, 3),
        ("C manifest", "package", "C/manifest.json", ("C", "Cx"), "Cx/manifest.json",
         [cmd_verify("Cx"), cmd_eval_btf(T, "Cx"), cmd_export("Cx"), cmd_render()], "Cx", 3),
        ("M manifest", "package", "M/manifest.json", ("M", "Mx"), "Mx/manifest.json",
         [cmd_verify("Mx"), cmd_eval_mdf(T, "Mx")], None, 2),
        ("session manifest", "session", "S/manifest.json", ("S", "Sx"), "Sx/manifest.json",
         [cmd_verify("Sx"), cmd_process_mdf("Sx"), cmd_process_btf("Sx")], None, 3),
        ("journal", "journal", "S/journal.jsonl", ("S", "Sx"), "Sx/journal.jsonl",
         [cmd_verify("Sx"), cmd_process_mdf("Sx"), cmd_process_btf("Sx")], None, 3),
        ("calibration", "calibration", "calib.json", None, "calib.json",
         [cmd_process_mdf(S, calib="calib.json"), cmd_process_btf(S, calib="calib.json")], None, 2),
        ("rig description", "rig", "rig.json", None, "rig.json", [cmd_groundtruth(rig="rig.json")], None, 2),
        ("render scene", "scene", "scene.json", None, "scene.json", [cmd_render()], "C", 2),
        ("fault plan", "faults", "faults.json", None, "faults.json", [cmd_simulate(faults="faults.json")], None, 1),
    ]
    weighted = [t for t in targets for _ in range(t[7])]
    cases = []
    for i in range(n):
        label, doc_kind, src, tree, rel, cmds, scene_mat, _ = rng.choice(weighted)
        orig = (B / src).read_bytes()
        r = rng.random()
        trunc = r < 0.25
        digits = [k for k, c in enumerate(orig) if 0x30 <= c <= 0x39]
        if trunc:
            new_len = rng.randrange(0, len(orig))
            new = orig[:new_len]
            mdesc = "truncated %s to %d of %d bytes" % (rel, new_len, len(orig))
        elif r < 0.45 and digits:
            # a digit changed into another digit: often a document that is still valid
            off = rng.choice(digits)
            d = rng.choice([c for c in b"0123456789" if c != orig[off]])
            new = orig[:off] + bytes([d]) + orig[off + 1:]
            ctx = orig[max(0, off - 12):off + 12].decode("utf-8", "replace").replace("\n", "\\n")
            mdesc = "digit at byte %d of %s changed to '%s' in '%s'" % (off, rel, chr(d), ctx)
        else:
            off, x = rng.randrange(len(orig)), rng.randrange(1, 256)
            new = bytearray(orig)
            new[off] ^= x
            new = bytes(new)
            ctx = orig[max(0, off - 12):off + 12].decode("utf-8", "replace").replace("\n", "\\n")
            mdesc = "flipped byte %d of %s (xor 0x%02x) in '%s'" % (off, rel, x, ctx)
        tmpl = cmds[i % len(cmds)]
        args, outs, ver = tmpl
        expect, note, field_any = judge_json(doc_kind, orig.decode(), new, command_reads(args, tree))
        if expect == "incomplete":
            # a torn journal tail is dropped: the session lacks steps; processing
            # refuses it, verify may report it either way
            expect = "either" if args[0] == "verify" else "reject"
        if args[0] == "verify" and expect == "either":
            pass
        name_any = [tree[1]] if tree else [rel]

        def setup(d, tree=tree, rel=rel, new=new, src=src, scene_mat=scene_mat, mdesc=mdesc):
            if tree:
                copy_tree(B / tree[0], d / tree[1])
            if scene_mat:
                write_scene(d, scene_mat if scene_mat == "Cx" else a(B / "C"))
                if scene_mat == "Cx":
                    pass
            (d / rel).write_bytes(new)
            return mdesc

        if label == "render scene":
            # the mutated scene refers to the base compressed package by a relative
            # path: put a copy named C beside it
            def setup(d, new=new, mdesc=mdesc):  # noqa: F811
                copy_tree(B / "C", d / "C")
                (d / "scene.json").write_bytes(new)
                return mdesc
        cases.append(Case("json-mutation", "%s: %s [%s]" % (label, mdesc, note), args, setup, expect, name_any,
                          field_any=field_any, outs=outs, verify=ver, note=note))
    return cases


# --- field edits -------------------------------------------------------------

RAW = "\u0000RAW\u0000"


class Raw:
    """A JSON text inserted verbatim (NaN, 1e400, deep nesting, huge lists)."""

    def __init__(self, text):
        self.text = text


def dump_with_raw(doc):
    raws = []

    def walk(v):
        if isinstance(v, Raw):
            raws.append(v.text)
            return "@@RAW%d@@" % (len(raws) - 1)
        if isinstance(v, dict):
            return {(k.text if isinstance(k, Raw) else k): walk(x) for k, x in v.items()}
        if isinstance(v, list):
            return [walk(x) for x in v]
        return v

    text = json.dumps(walk(doc), indent=2)
    for i, r in enumerate(raws):
        text = text.replace('"@@RAW%d@@"' % i, r)
    return text + "\n"


def get_at(doc, path):
    for p in path:
        doc = doc[p]
    return doc


def edit_doc(doc, op, path, value=None):
    doc = copy.deepcopy(doc)
    parent = get_at(doc, path[:-1])
    key = path[-1]
    if op == "set":
        parent[key] = value
    elif op == "add":
        get_at(doc, path[:-1])[key] = value
    elif op == "del":
        del parent[key]
    elif op == "rename":
        items = list(parent.items())
        parent.clear()
        for k, v in items:
            parent[value if k == key else k] = v
    return doc


BIG_LIST = Raw("[" + ",".join(["1"] * 200000) + "]")
BIG_PAIRS = Raw("[" + ",".join(["[10,0]"] * 200000) + "]")
HUGE_STR = "x" * MB3


def deep(n, inner="1"):
    return Raw("[" * n + inner + "]" * n)


def invalid_number_values():
    return [(-1, "-1"), (0, "0"), ("12", "a string"), (None, "null"), (True, "true"), ("NaN", "\"NaN\""),
            ("Infinity", "\"Infinity\""), (1e300, "1e300"), (1e308, "1e308"), (Raw("1e400"), "1e400"),
            (Raw("NaN"), "bare NaN"), ([12], "a list"), ({}, "an object"), (deep(100), "nested 100 deep"),
            (deep(100000), "nested 100000 deep"), (HUGE_STR, "a 3 MB string")]


def rig_edits():
    E = []  # (op, path, value, description, fields)
    for v, d in invalid_number_values():
        E.append(("set", ("sample", "size_mm"), v, "size_mm " + d, ["size_mm"]))
    E += [
        ("set", ("sample", "backing", "albedo"), 1.5, "albedo 1.5", ["albedo"]),
        ("set", ("sample", "backing", "depth_mm"), 0, "depth_mm 0", ["depth_mm"]),
        ("set", ("cameras", 0, "elevation_deg"), 0, "elevation 0", ["elevation_deg"]),
        ("set", ("cameras", 0, "elevation_deg"), 91, "elevation 91", ["elevation_deg"]),
        ("set", ("cameras", 0, "elevation_deg"), 1e300, "elevation 1e300", ["elevation_deg"]),
        ("set", ("cameras", 0, "distance_mm"), 1e308, "distance 1e308", ["distance_mm"]),
        ("set", ("cameras", 0, "image_size"), [128], "image_size of 1 entry", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), [128, 96, 1], "image_size of 3 entries", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), [0, 96], "image_size [0, 96]", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), [128.5, 96], "image_size [128.5, 96]", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), [20000, 96], "image_size [20000, 96]", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), BIG_LIST, "image_size of 200000 entries", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), "128x96", "image_size a string", ["image_size"]),
        ("set", ("cameras", 0, "focal_px"), -700, "focal_px -700", ["focal_px"]),
        ("set", ("cameras", 0, "focal_px"), 1e308, "focal_px 1e308", ["focal_px"]),
        ("set", ("cameras", 0, "distortion"), [0, 0, 0], "distortion of 3 entries", ["distortion"]),
        ("set", ("cameras", 0, "distortion"), BIG_LIST, "distortion of 200000 entries", ["distortion"]),
        ("set", ("cameras", 0, "distortion"), [11, 0, 0, 0, 0], "distortion k1 11", ["distortion"]),
        ("set", ("cameras", 0, "distortion"), ["NaN", 0, 0, 0, 0], "distortion 'NaN'", ["distortion"]),
        ("set", ("cameras", 0, "bit_depth"), 7, "bit_depth 7", ["bit_depth"]),
        ("set", ("cameras", 0, "bit_depth"), 17, "bit_depth 17", ["bit_depth"]),
        ("set", ("cameras", 0, "bit_depth"), 12.5, "bit_depth 12.5", ["bit_depth"]),
        ("set", ("cameras", 0, "bit_depth"), "12", "bit_depth '12'", ["bit_depth"]),
        ("set", ("cameras", 0, "bit_depth"), 1e300, "bit_depth 1e300", ["bit_depth"]),
        ("set", ("cameras", 0, "exposure_us"), 1e300, "exposure_us 1e300", ["exposure_us"]),
        ("set", ("cameras", 0, "read_noise_electrons"), -1, "read_noise -1", ["read_noise_electrons"]),
        ("set", ("cameras", 0, "id"), "", "camera id empty", ["id"]),
        ("set", ("cameras", 0, "id"), HUGE_STR, "camera id of 3 MB", ["id"]),
        ("set", ("cameras", 1, "id"), "cam0", "duplicate camera id", ["id"]),
        ("set", ("cameras",), [], "no cameras", ["cameras"]),
        ("set", ("turntable", "angles_deg"), [], "no turntable angles", ["angles_deg"]),
        ("set", ("turntable", "angles_deg"), [400], "turntable angle 400", ["angles_deg"]),
        ("set", ("turntable", "angles_deg"), [-1], "turntable angle -1", ["angles_deg"]),
        ("set", ("turntable", "angles_deg"), BIG_LIST, "200000 turntable angles", ["angles_deg"]),
        ("set", ("turntable", "speed_deg_per_s"), 0, "turntable speed 0", ["speed_deg_per_s"]),
        ("set", ("light_arc", "angles_deg"), [], "no arc angles", ["angles_deg"]),
        ("set", ("lamps", "intensity"), [1, 1], "lamp intensity of 2 entries", ["intensity"]),
        ("set", ("lamps", "intensity"), [-1, 1, 1], "lamp intensity -1", ["intensity"]),
        ("set", ("lamps", "distance_mm"), 0, "lamp distance 0", ["distance_mm"]),
        ("set", ("laser", "frames_per_sweep"), 0, "frames_per_sweep 0", ["frames_per_sweep"]),
        ("set", ("laser", "frames_per_sweep"), 2.5, "frames_per_sweep 2.5", ["frames_per_sweep"]),
        ("set", ("laser", "frames_per_sweep"), 1e300, "frames_per_sweep 1e300", ["frames_per_sweep"]),
        ("set", ("laser", "sweep_mm"), [1], "sweep_mm of 1 entry", ["sweep_mm"]),
        ("set", ("laser", "sweep_mm"), [0, 1, 2], "sweep_mm of 3 entries", ["sweep_mm"]),
        ("set", ("laser", "stripe_sigma_mm"), 0, "stripe_sigma 0", ["stripe_sigma_mm"]),
        ("set", ("laser", "locations", 0, "mount"), 5, "location mount 5 (no such mount)", ["mount"]),
        ("set", ("laser", "locations", 0, "mount"), 0.5, "location mount 0.5", ["mount"]),
        ("add", ("laser", "sweep_storage"), "bogus", "sweep_storage 'bogus'", ["sweep_storage"]),
        ("add", ("laser", "sweep_storage"), HUGE_STR, "sweep_storage of 3 MB", ["sweep_storage"]),
        ("set", ("laser", "calibration_heights_mm"), [0, 10, 20], "calibration_heights of 3", ["calibration_heights_mm"]),
        ("set", ("format",), "mesocap.rgi", "format misspelt", ["format"]),
        ("set", ("format",), HUGE_STR, "format of 3 MB", ["format"]),
        ("set", ("version",), 2, "version 2", ["version"]),
        ("set", ("version",), 1.5, "version 1.5", ["version"]),
        ("add", ("nmae",), "x", "unknown key 'nmae'", ["nmae"]),
        ("add", ("sample", "size_nm"), 1, "unknown key 'sample.size_nm'", ["size_nm"]),
        ("add", ("sample", "backing", "albdo"), 0.5, "unknown key 'sample.backing.albdo'", ["albdo"]),
        ("rename", ("cameras", 0, "bit_depth"), "bit_depht", "misspelt key 'bit_depht'", ["bit_depht"]),
        ("add", ("turntable", "angels_deg"), [0], "unknown key 'angels_deg'", ["angels_deg"]),
        ("add", ("light_arc", "speeed"), 1, "unknown key 'light_arc.speeed'", ["speeed"]),
        ("add", ("lamps", "intensty"), [1, 1, 1], "unknown key 'lamps.intensty'", ["intensty"]),
        ("add", ("laser", "sweep_storge"), "analysis", "misspelt key 'sweep_storge'", ["sweep_storge"]),
        ("add", ("laser", "locations", 0, "mnt"), 0, "unknown key 'locations[0].mnt'", ["mnt"]),
        ("add", ("k" * MB3,), 1, "unknown key of 3 MB", ["unknown", "member", "key", "kkkk"]),
        ("del", ("sample", "size_mm"), None, "size_mm missing", ["size_mm"]),
        ("del", ("cameras", 0, "focal_px"), None, "focal_px missing", ["focal_px"]),
        ("del", ("laser", "frames_per_sweep"), None, "frames_per_sweep missing", ["frames_per_sweep"]),
        ("add", ("faults",), {"camera_drop_frame": {"rate": 2}}, "faults rate 2", ["rate"]),
    ]
    return E


def calib_edits():
    E = []
    fx = ("cameras", 0, "intrinsics", "fx")
    for v, d in [(0, "0"), (-1, "-1"), (1e308, "1e308"), (1e300, "1e300"), ("NaN", "'NaN'"), (None, "null"),
                 (Raw("1e400"), "1e400"), (deep(40), "nested 40 deep"), (deep(100000), "nested 100000 deep"),
                 (HUGE_STR, "a 3 MB string")]:
        E.append(("set", fx, v, "fx " + d, ["fx"]))
    E += [
        ("set", ("cameras", 0, "intrinsics", "cx"), 1e8, "cx 1e8", ["cx"]),
        ("set", ("cameras", 0, "image_size"), [0, 96], "image_size [0, 96]", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), [128], "image_size of 1", ["image_size"]),
        ("set", ("cameras", 0, "image_size"), [70000, 96], "image_size 70000", ["image_size"]),
        ("set", ("cameras", 0, "distortion", "k1"), 1e7, "k1 1e7", ["k1"]),
        ("add", ("cameras", 0, "distortion", "k4"), 0.0, "unknown key 'k4'", ["k4"]),
        ("del", ("cameras", 0, "distortion", "k3"), None, "k3 missing", ["k3"]),
        ("set", ("cameras", 0, "pose", "rotation"), [1, 0, 0, 0, 1, 0, 0, 0], "rotation of 8", ["rotation"]),
        ("set", ("cameras", 0, "pose", "rotation"), [2, 0, 0, 0, 1, 0, 0, 0, 1], "rotation not orthonormal",
         ["rotation"]),
        ("set", ("cameras", 0, "pose", "rotation"), BIG_LIST, "rotation of 200000", ["rotation"]),
        ("set", ("cameras", 0, "pose", "translation_mm"), [1, 2], "translation of 2", ["translation_mm"]),
        ("set", ("cameras", 0, "pose", "translation_mm"), [1e300, 0, 0], "translation 1e300", ["translation_mm"]),
        ("set", ("cameras", 0, "pose", "parent"), "turntable", "pose parent turntable", ["parent"]),
        ("set", ("cameras", 0, "pose", "child"), "camera:cam9", "pose child camera:cam9", ["child"]),
        ("set", ("cameras", 0, "radiometry", "signal_per_radiance_second"), 0, "gain 0",
         ["signal_per_radiance_second"]),
        ("set", ("cameras", 0, "radiometry", "signal_per_radiance_second"), 1e31, "gain 1e31",
         ["signal_per_radiance_second"]),
        ("set", ("cameras", 0, "radiometry", "signal_per_radiance_second"), 1e308, "gain 1e308",
         ["signal_per_radiance_second"]),
        ("add", ("cameras", 0, "radiometry", "std"), {"signal_per_radiance_second": -1}, "gain std -1",
         ["signal_per_radiance_second"]),
        ("add", ("cameras", 0, "intrinsics", "std"), {"fx": -0.4}, "fx std -0.4", ["fx"]),
        ("add", ("cameras", 0, "intrinsics", "std"), {"fz": 0.4}, "std of unknown 'fz'", ["fz"]),
        ("set", ("cameras", 1, "id"), "cam0", "duplicate camera id", ["id"]),
        ("set", ("cameras", 0, "id"), "cam 0!", "camera id with bad characters", ["id"]),
        ("set", ("cameras", 0, "id"), HUGE_STR, "camera id of 3 MB", ["id"]),
        ("set", ("turntable", "axis_direction"), [0, 0, 0], "axis_direction zero", ["axis_direction"]),
        ("set", ("turntable", "axis_direction"), [0, 0], "axis_direction of 2", ["axis_direction"]),
        ("set", ("turntable", "axis_point_mm"), [1e7, 0, 0], "axis_point 1e7", ["axis_point_mm"]),
        ("set", ("turntable", "sample_pose", "parent"), "world", "sample_pose parent world", ["parent"]),
        ("set", ("lamps", 0, "intensity"), [-1, 1, 1], "lamp intensity -1", ["intensity"]),
        ("set", ("lamps", 0, "intensity"), [1e13, 1, 1], "lamp intensity 1e13", ["intensity"]),
        ("set", ("laser_mounts", 0, "tilt_range_deg"), [5, -5], "tilt_range min > max", ["tilt_range_deg"]),
        ("set", ("laser_mounts", 0, "tilt_range_deg"), [-200, 0], "tilt_range -200", ["tilt_range_deg"]),
        ("set", ("version",), 3, "version 3", ["version"]),
        ("set", ("units", "length"), "cm", "units.length cm", ["length"]),
        ("set", ("format",), "mesocap.rig", "format mesocap.rig", ["format"]),
        ("add", ("camras",), [], "unknown key 'camras'", ["camras"]),
        ("add", ("cameras", 0, "distorsion"), {}, "unknown key 'distorsion'", ["distorsion"]),
        ("add", ("turntable", "axis_pont_mm"), [0, 0, 0], "unknown key 'axis_pont_mm'", ["axis_pont_mm"]),
        ("add", ("lamps", 0, "positon_mm"), [0, 0, 0], "unknown key 'positon_mm'", ["positon_mm"]),
        ("set", ("cameras",), [], "no cameras", ["cameras"]),
    ]
    return E


def scene_edits():
    E = []
    for v, d in [(0, "0"), (171, "171"), (1e308, "1e308"), ("40", "'40'"), (Raw("NaN"), "bare NaN"),
                 (deep(100), "nested 100 deep"), (deep(100000), "nested 100000 deep")]:
        E.append(("set", ("camera", "fov_y_deg"), v, "fov_y_deg " + d, ["fov_y_deg"]))
    E += [
        ("set", ("camera", "position"), [0, -60], "camera position of 2", ["position"]),
        ("set", ("camera", "position"), [0, -60, 30, 1], "camera position of 4", ["position"]),
        ("set", ("camera", "position"), BIG_LIST, "camera position of 200000", ["position"]),
        ("add", ("camera", "up"), [0, 2, -1], "up parallel to the view", ["up"]),
        ("set", ("light", "intensity"), -1, "light intensity -1", ["intensity"]),
        ("set", ("light", "intensity"), 1e13, "light intensity 1e13", ["intensity"]),
        ("add", ("light", "ambient"), -0.1, "ambient -0.1", ["ambient"]),
        ("add", ("exposure",), 0, "exposure 0", ["exposure"]),
        ("add", ("exposure",), -1, "exposure -1", ["exposure"]),
        ("set", ("objects",), [], "no objects", ["objects"]),
        ("set", ("objects",), [SCENE_TEMPLATE["objects"][1]] * 65, "65 objects", ["objects"]),
        ("set", ("objects", 0, "shape"), "cube", "shape 'cube'", ["shape"]),
        ("set", ("objects", 0, "shape"), HUGE_STR, "shape of 3 MB", ["shape"]),
        ("set", ("objects", 0, "radius"), -1, "radius -1", ["radius"]),
        ("set", ("objects", 0, "radius"), 1e308, "radius 1e308", ["radius"]),
        ("set", ("objects", 0, "segments"), 2, "segments 2", ["segments"]),
        ("set", ("objects", 0, "segments"), 1000000000, "segments 1e9", ["segments"]),
        ("set", ("objects", 0, "segments"), 16.5, "segments 16.5", ["segments"]),
        ("add", ("objects", 0, "tiles"), [0, 1], "tiles [0, 1]", ["tiles"]),
        ("add", ("objects", 0, "tiles"), [1], "tiles of 1", ["tiles"]),
        ("set", ("objects", 0, "material"), "nonexistent_package", "material missing package",
         ["material", "nonexistent_package"]),
        ("set", ("objects", 0, "material"), "sim:nosuchscene", "material sim:nosuchscene", ["material", "nosuch"]),
        ("set", ("objects", 0, "material"), HUGE_STR, "material of 3 MB", ["material"]),
        ("set", ("objects", 1, "albedo"), [1.5, 0, 0], "albedo 1.5", ["albedo"]),
        ("set", ("objects", 1, "albedo"), [0.5, 0.5], "albedo of 2", ["albedo"]),
        ("set", ("objects", 0, "rotate_deg"), [0, 90], "rotate_deg of 2", ["rotate_deg"]),
        ("set", ("objects", 0, "rotate_deg"), ["NaN", 0, 0], "rotate_deg 'NaN'", ["rotate_deg"]),
        ("add", ("objects", 0, "colour"), [1, 0, 0], "unknown key 'colour'", ["colour"]),
        ("add", ("camera", "fov_y_dge"), 40, "unknown key 'fov_y_dge'", ["fov_y_dge"]),
        ("add", ("light", "intensty"), 1, "unknown key 'intensty'", ["intensty"]),
        ("add", ("objetcs",), [], "unknown key 'objetcs'", ["objetcs"]),
        ("set", ("version",), 2, "version 2", ["version"]),
        ("set", ("format",), "mesocap.scen", "format misspelt", ["format"]),
    ]
    return E


def faults_edits():
    E = []
    r = ("camera_drop_frame", "rate")
    for v, d in [(1.5, "1.5"), (-0.1, "-0.1"), ("NaN", "'NaN'"), (1e300, "1e300"), (None, "null"),
                 (Raw("NaN"), "bare NaN"), (deep(100), "nested 100 deep"), (HUGE_STR, "a 3 MB string")]:
        E.append(("set", r, v, "rate " + d, ["rate"]))
    k = ("camera_timeout",)
    E += [
        ("add", k, {"at": [0]}, "at [0]", ["at"]),
        ("add", k, {"at": [-1]}, "at [-1]", ["at"]),
        ("add", k, {"at": [1.5]}, "at [1.5]", ["at"]),
        ("add", k, {"at": []}, "at []", ["at"]),
        ("add", k, {"at": [1e300]}, "at [1e300]", ["at"]),
        ("add", k, {"at": BIG_LIST}, "at of 200000 entries", ["at"]),
        ("add", k, {"rate": 0.1, "at": [1]}, "both rate and at", ["rate", "at"]),
        ("add", k, {}, "neither rate nor at", ["rate", "at"]),
        ("add", k, {"rate": 0.1, "device": "cam9"}, "device cam9 (the rig lacks it)", ["device", "cam9"]),
        ("add", k, {"rate": 0.1, "device": HUGE_STR}, "device of 3 MB", ["device"]),
        ("add", ("lamp_failure",), {"rate": 0.1, "device": "99"}, "lamp 99 (the rig lacks it)", ["device", "99"]),
        ("add", k, {"rate": 0.1, "rte": 1}, "unknown rule key 'rte'", ["rte"]),
        ("add", ("lamp_failure",), [{"rate": 0.1}, 5], "a rule that is a number", ["lamp_failure"]),
        ("add", ("camera_drop_frames",), {"rate": 0.1}, "unknown fault kind 'camera_drop_frames'",
         ["camera_drop_frames"]),
        ("set", ("version",), 2, "version 2", ["version"]),
        ("set", ("format",), "mesocap.fault", "format misspelt", ["format"]),
    ]
    return E


def manifest_edits():
    E = []
    for v, d in [(0, "0"), (-1, "-1"), (1e308, "1e308"), ("NaN", "'NaN'"), (Raw("1e400"), "1e400"),
                 (deep(100), "nested 100 deep"), (deep(100000), "nested 100000 deep"), (HUGE_STR, "a 3 MB string")]:
        E.append(("set", ("d_max_mm",), v, "d_max_mm " + d, ["d_max_mm"]))
    E += [
        ("set", ("texture_size",), [0, 8], "texture_size [0, 8]", ["texture_size"]),
        ("set", ("texture_size",), [8], "texture_size of 1", ["texture_size"]),
        ("set", ("texture_size",), [Raw("8.0"), 8], "texture_size [8.0, 8]", ["texture_size"]),
        ("set", ("texture_size",), [8, 8, 8], "texture_size of 3", ["texture_size"]),
        ("set", ("texture_size",), [20000, 8], "texture_size 20000", ["texture_size"]),
        ("set", ("texture_size",), BIG_LIST, "texture_size of 200000", ["texture_size"]),
        ("set", ("physical_size_mm",), [-12, 12], "physical_size -12", ["physical_size_mm"]),
        ("set", ("physical_size_mm",), ["NaN", 12], "physical_size 'NaN'", ["physical_size_mm"]),
        ("set", ("view_directions", "directions_deg", 0), [95, 0], "view theta 95", ["directions_deg"]),
        ("set", ("view_directions", "directions_deg", 0), [30], "view direction of 1 number", ["directions_deg"]),
        ("set", ("view_directions", "directions_deg", 0), [30, 0, 0], "view direction of 3 numbers",
         ["directions_deg"]),
        ("set", ("view_directions", "directions_deg"), BIG_PAIRS, "200000 view directions", ["directions_deg"]),
        ("set", ("light_directions", "directions_deg", 1), "@dup0", "duplicate light direction", ["directions_deg"]),
        ("set", ("units", "length"), "cm", "units.length cm", ["length"]),
        ("set", ("version",), 3, "version 3", ["version"]),
        ("set", ("format",), "mesocap.materia", "format misspelt", ["format"]),
        ("set", ("format",), HUGE_STR, "format of 3 MB", ["format"]),
        ("del", ("provenance", "created_utc"), None, "provenance.created_utc missing", ["created_utc"]),
        ("set", ("mdf", "uint8", "no_hit_code"), 253, "no_hit_code 253", ["no_hit_code"]),
        ("set", ("mdf", "uint8", "scale_mm"), 0, "scale_mm 0", ["scale_mm"]),
        ("set", ("mdf", "float32", "file"), "../S/manifest.json", "mdf file outside the package", ["file"]),
        ("set", ("btf", "values"), "srgb", "btf.values srgb", ["values"]),
        ("set", ("btf", "full", "files"), "btf/view_{view:03d}.exr", "btf.full.files pattern", ["files"]),
        ("del", ("files", "mdf.exr"), None, "files entry of mdf.exr missing", ["files", "mdf.exr"]),
        ("add", ("files", "extra.exr"), {"bytes": 1, "xxh3_64": "0000000000000000"}, "extra files entry",
         ["files", "extra.exr"]),
        ("set", ("files", "mdf.exr", "bytes"), -1, "files bytes -1", ["bytes"]),
        ("set", ("files", "mdf.exr", "bytes"), 1e300, "files bytes 1e300", ["bytes"]),
        ("set", ("files", "mdf.exr", "xxh3_64"), "zz", "xxh3_64 'zz'", ["xxh3_64"]),
        ("set", ("files", "mdf.exr", "xxh3_64"), "@upper", "xxh3_64 in upper case", ["xxh3_64"]),
        ("set", ("files", "mdf.exr", "xxh3_64"), HUGE_STR, "xxh3_64 of 3 MB", ["xxh3_64"]),
        ("add", ("textur_size",), [8, 8], "unknown key 'textur_size'", ["textur_size"]),
        ("add", ("mdf", "float23"), {}, "unknown key 'mdf.float23'", ["float23"]),
        ("add", ("units", "tme"), "s", "unknown key 'units.tme'", ["tme"]),
        ("add", ("provenance", "sorce"), "", "unknown key 'provenance.sorce'", ["sorce"]),
        ("add", ("files", "mdf.exr", "byte"), 1, "unknown key 'files.mdf.exr.byte'", ["byte"]),
    ]
    return E


def session_edits(base):
    steps = base.steps
    sweep = next(i for i, s in enumerate(steps) if s["kind"] == "laser_sweep")
    btf = next(i for i, s in enumerate(steps) if s["kind"] == "btf_image")
    cal = next(i for i, s in enumerate(steps) if s["kind"] == "laser_calibration")
    P = ("plan", "steps")
    E = []  # (op, path, value, description, fields, command: "mdf", "btf", "verify" or "any")
    for v, d in [(1e300, "1e300"), ("NaN", "'NaN'"), (None, "null"), (Raw("1e400"), "1e400")]:
        E.append(("set", P + (sweep, "tilt_deg", 3), v, "sweep tilt_deg[3] " + d, ["tilt_deg"], "mdf"))
    E += [
        ("set", P + (sweep, "tilt_deg"), [0, 0, 0], "sweep tilt_deg of 3 entries", ["tilt_deg"], "mdf"),
        ("set", P + (sweep, "offset_mm"), [0, 0, 0], "sweep offset_mm of 3 entries", ["offset_mm"], "mdf"),
        ("set", P + (sweep, "offset_mm"), BIG_LIST, "sweep offset_mm of 200000", ["offset_mm"], "mdf"),
        ("set", P + (sweep, "offset_mm", 0), "NaN", "sweep offset_mm[0] 'NaN'", ["offset_mm"], "mdf"),
        ("set", P + (sweep, "location"), 99, "sweep location 99", ["location"], "mdf"),
        ("set", P + (sweep, "turntable_deg"), 1e300, "sweep turntable_deg 1e300", ["turntable_deg"], "mdf"),
        ("set", P + (cal, "height_mm"), 1e300, "calibration height_mm 1e300", ["height_mm"], "mdf"),
        ("set", P + (cal, "height_mm"), "NaN", "calibration height_mm 'NaN'", ["height_mm"], "mdf"),
        ("set", P + (btf, "turntable_deg"), "NaN", "btf turntable_deg 'NaN'", ["turntable_deg"], "btf"),
        ("set", P + (btf, "turntable_deg"), 1e300, "btf turntable_deg 1e300", ["turntable_deg"], "btf"),
        ("set", P + (btf, "lamp"), 99, "btf lamp 99", ["lamp"], "btf"),
        ("set", P + (btf, "lamp"), -1, "btf lamp -1", ["lamp"], "btf"),
        ("set", P + (btf, "arc_index"), 99, "btf arc_index 99", ["arc_index"], "btf"),
        ("set", P + (btf, "lamp_elevation_deg"), 1e300, "btf lamp_elevation 1e300", ["lamp_elevation_deg"], "btf"),
        ("set", P + (btf, "kind"), "bogus", "step kind 'bogus'", ["kind"], "any"),
        ("set", P + (btf, "id"), steps[btf + 1]["id"], "duplicate step id", ["id"], "any"),
        ("set", P + (btf, "id"), "bad id!", "step id with bad characters", ["id"], "any"),
        ("set", P + (btf, "files"), [], "step files []", ["files"], "btf"),
        ("set", P + (btf, "files", 0, "camera"), "cam9", "step file camera cam9", ["camera"], "btf"),
        ("set", P + (btf, "files", 0, "path"), "../x.png", "step file path '../x.png'", ["path"], "any"),
        ("add", ("calibraton",), {}, "unknown key 'calibraton'", ["calibraton"], "any"),
        ("add", ("plan", "stpes"), [], "unknown key 'plan.stpes'", ["stpes"], "any"),
        ("set", ("version",), 3, "version 3", ["version"], "any"),
        ("set", ("format",), "mesocap.sesion", "format misspelt", ["format"], "any"),
        ("set", ("created_utc",), "2025-13-01T00:00:00Z", "created_utc month 13", ["created_utc"], "any"),
        ("set", ("software_version",), "", "software_version empty", ["software_version"], "any"),
        ("set", ("software_version",), HUGE_STR, "software_version of 3 MB", ["software_version"], "any"),
        ("set", ("calibration", "bytes"), -1, "calibration.bytes -1", ["bytes", "calibration"], "any"),
        ("set", ("calibration", "bytes"), 1e300, "calibration.bytes 1e300", ["bytes", "calibration"], "any"),
        ("set", ("calibration", "xxh3_64"), "zz", "calibration.xxh3_64 'zz'", ["xxh3_64", "calibration"], "any"),
        ("set", ("calibration", "path"), "../calibration.json", "calibration.path outside", ["path"], "any"),
        ("set", ("calibration", "path"), "/etc/hostname", "calibration.path absolute", ["path"], "any"),
        ("set", ("rig", "name"), "", "rig.name empty", ["name"], "any"),
        ("set", ("rig", "name"), HUGE_STR, "rig.name of 3 MB", ["name"], "any"),
        ("del", ("rig", "name"), None, "rig.name missing", ["name"], "any"),
        ("set", ("plan", "steps"), deep(100000, "{}"), "steps nested 100000 deep", ["steps", "nest", "depth"], "any"),
    ]
    return E


def journal_edits():
    # (line index, function(record) -> record or raw line, description, fields)
    def setk(k, v):
        def f(r):
            r = copy.deepcopy(r)
            r[k] = v
            return r
        return f

    def setfile(k, v):
        def f(r):
            r = copy.deepcopy(r)
            r["files"][0][k] = v
            return r
        return f

    return [
        (3, setk("seq", 7), "record seq 7 (a gap)", ["seq"]),
        (3, setk("seq", -1), "record seq -1", ["seq"]),
        (3, setk("step", "no-such-step"), "record of a step outside the plan", ["step"]),
        (3, setk("step", "laser-calibration-loc0_h0"), "a step recorded twice", ["step"]),
        (3, setk("replaces", 99), "replaces 99 (no such record)", ["replaces"]),
        (3, setk("sq", 1), "unknown member 'sq'", ["sq"]),
        (3, setk("time_utc", "2025-02-30T00:00:00Z"), "time_utc Feb 30", ["time_utc"]),
        (3, setfile("bytes", -1), "file bytes -1", ["bytes"]),
        (3, setfile("bytes", 1e300), "file bytes 1e300", ["bytes"]),
        (3, setfile("xxh3_64", "@upper"), "xxh3_64 in upper case", ["xxh3_64"]),
        (3, setfile("xxh3_64", "x" * MB3), "xxh3_64 of 3 MB", ["xxh3_64"]),
        (3, setfile("path", "../x.png"), "file path '../x.png'", ["path"]),
        (3, setfile("path", "/etc/hostname"), "file path absolute", ["path"]),
        (3, setfile("pth", "x"), "unknown file member 'pth'", ["pth"]),
    ]


FIELD_POOL = [0]


def gen_field_edits(base, rng, n):
    B = base.root
    S, T, C, M = a(B / "S"), a(B / "T"), a(B / "C"), a(B / "M")
    pool = []
    rig = json.loads((B / "rig.json").read_text())
    cal = json.loads((B / "calib.json").read_text())
    scene = copy.deepcopy(SCENE_TEMPLATE)
    faults = copy.deepcopy(FAULTS)
    man = json.loads((B / "T" / "manifest.json").read_text())
    sman = json.loads((B / "S" / "manifest.json").read_text())

    for j, (op, path, v, d, f) in enumerate(rig_edits()):
        tmpl = cmd_simulate(rig="rig.json") if j % 6 == 5 else cmd_groundtruth(rig="rig.json")
        pool.append(("rig.json: " + d, tmpl, ("json", "rig.json", rig, op, path, v), ["rig.json"], f, None))
    for j, (op, path, v, d, f) in enumerate(calib_edits()):
        tmpl = cmd_process_mdf(S, calib="calib.json") if j % 2 == 0 else cmd_process_btf(S, calib="calib.json")
        pool.append(("calib.json: " + d, tmpl, ("json", "calib.json", cal, op, path, v), ["calib.json"], f, None))
    for op, path, v, d, f in scene_edits():
        pool.append(("scene.json: " + d, cmd_render(), ("json", "scene.json", scene, op, path, v),
                     ["scene.json"], f, "C"))
    for op, path, v, d, f in faults_edits():
        pool.append(("faults.json: " + d, cmd_simulate(faults="faults.json"),
                     ("json", "faults.json", faults, op, path, v), ["faults.json"], f, None))
    mcmds = [cmd_verify("Tx"), cmd_compress("Tx"), cmd_eval_btf("Tx", C)]
    for j, (op, path, v, d, f) in enumerate(manifest_edits()):
        if v == "@dup0":
            v = man["light_directions"]["directions_deg"][0]
        if v == "@upper":
            v = man["files"]["mdf.exr"]["xxh3_64"].upper()
            if v == man["files"]["mdf.exr"]["xxh3_64"]:
                v = "ABCDEF0123456789"
        pool.append(("Tx/manifest.json: " + d, mcmds[j % 3], ("json", "Tx/manifest.json", man, op, path, v, "T"),
                     ["Tx"], f, None))
    for j, (op, path, v, d, f, which) in enumerate(session_edits(base)):
        if which == "mdf":
            tmpl = cmd_process_mdf("Sx")
        elif which == "btf":
            tmpl = cmd_process_btf("Sx")
        else:
            tmpl = [cmd_verify("Sx"), cmd_process_mdf("Sx"), cmd_process_btf("Sx")][j % 3]
        pool.append(("Sx/manifest.json: " + d, tmpl, ("json", "Sx/manifest.json", sman, op, path, v, "S"),
                     ["Sx"], f, None))
    for j, (line, fn, d, f) in enumerate(journal_edits()):
        tmpl = [cmd_verify("Sx"), cmd_process_mdf("Sx"), cmd_process_btf("Sx")][j % 3]
        pool.append(("Sx/journal.jsonl: " + d, tmpl, ("journal", line, fn), ["Sx"], f, None))
    for d, text, f in obj_edits():
        for tmpl in (cmd_groundtruth(scene="bad.obj"),):
            pool.append(("bad.obj: " + d, tmpl, ("obj", text), ["bad.obj"], f, None))
    # the same OBJ edits through a render scene's obj shape
    for d, text, f in obj_edits()[::2]:
        sc = copy.deepcopy(SCENE_TEMPLATE)
        sc["objects"].append({"shape": "obj", "file": "bad.obj", "albedo": [0.5, 0.5, 0.5]})
        pool.append(("bad.obj (render scene obj shape): " + d, cmd_render(), ("objscene", text, sc), ["bad.obj"], f,
                     None))

    order = list(range(len(pool)))
    rng.shuffle(order)
    FIELD_POOL[0] = len(pool)
    cases = []
    for i in range(n):
        what, tmpl, spec, name_any, fields, mat = pool[order[i % len(pool)]]
        args, outs, ver = tmpl

        def setup(d, spec=spec, mat=mat):
            if spec[0] == "json":
                _, rel, doc, op, path, v = spec[:6]
                if len(spec) > 6:
                    copy_tree(B / spec[6], d / (spec[6] + "x"))
                if mat:
                    copy_tree(B / "C", d / "C")
                (d / rel).write_text(dump_with_raw(edit_doc(doc, op, path, v)))
            elif spec[0] == "journal":
                _, line, fn = spec
                copy_tree(B / "S", d / "Sx")
                lines = (d / "Sx" / "journal.jsonl").read_text().split("\n")
                rec = json.loads(lines[line])
                new = fn(rec)
                if new.get("files") and new["files"][0].get("xxh3_64") == "@upper":
                    new["files"][0]["xxh3_64"] = rec["files"][0]["xxh3_64"].upper()
                lines[line] = json.dumps(new, separators=(",", ":"))
                (d / "Sx" / "journal.jsonl").write_text("\n".join(lines))
            elif spec[0] == "obj":
                (d / "bad.obj").write_bytes(spec[1])
            elif spec[0] == "objscene":
                copy_tree(B / "C", d / "C")
                (d / "bad.obj").write_bytes(spec[1])
                (d / "scene.json").write_text(json.dumps(spec[2], indent=2) + "\n")
            return ""

        if any(t in what for t in ("bare NaN", "1e400")):
            # not valid JSON: refused while parsing (the field cannot be named; the place can)
            fields = list(fields) + ["json"]
        if "3 MB" in what:
            # a file or journal line over its format's size limit is refused before
            # parsing: the size is what it names
            fields = list(fields) + ["at most", "longer than"]
        if "nested" in what:
            # refused while parsing, before any field is read: the depth is the field
            fields = list(fields) + ["nest", "deep", "depth"]
        cases.append(Case("field-edit", what, args, setup, "reject", name_any, field_any=fields, outs=outs,
                          verify=ver))
    return cases


def obj_edits():
    good = CUBE_OBJ.splitlines()

    def with_line(i, new):
        lines = list(good)
        lines[i] = new
        return ("\n".join(lines) + "\n").encode()

    E = [
        ("vertex 1e308", with_line(0, "v 1e308 -4 -2"), ["line 1", "line"]),
        ("vertex -1e308 and 1e308", ("v -1e308 -1e308 -1e308\n" + "\n".join(good[1:]) + "\n").encode(), ["line"]),
        ("vertex nan", with_line(0, "v nan -4 -2"), ["line 1"]),
        ("vertex inf", with_line(0, "v inf -4 -2"), ["line 1"]),
        ("vertex 1e400", with_line(0, "v 1e400 -4 -2"), ["line 1"]),
        ("vertex 'abc'", with_line(0, "v abc -4 -2"), ["line 1"]),
        ("vertex of 2 numbers", with_line(0, "v 1 2"), ["line 1"]),
        ("no faces", ("\n".join(good[:12]) + "\n").encode(), ["face"]),
        ("face index 999999999", with_line(12, "f 5/1 6/2 999999999/3 8/4"), ["line 13"]),
        ("face index 0", with_line(12, "f 0/1 6/2 7/3 8/4"), ["line 13"]),
        ("face index -999", with_line(12, "f -999/1 6/2 7/3 8/4"), ["line 13"]),
        ("face index 2147483648", with_line(12, "f 2147483648/1 6/2 7/3 8/4"), ["line 13"]),
        ("face index 99999999999999999999", with_line(12, "f 99999999999999999999 6 7"), ["line 13"]),
        ("face of 2 corners", with_line(12, "f 5/1 6/2"), ["line 13"]),
        ("face texcoord 'x'", with_line(12, "f 5/x 6/2 7/3 8/4"), ["line 13"]),
        ("texcoord index 99", with_line(12, "f 5/99 6/2 7/3 8/4"), ["line 13"]),
        ("empty file", b"", ["face", "empty"]),
        ("binary garbage", bytes(random.Random(7).randrange(256) for _ in range(4096)), ["line", "face"]),
        ("a 3 MB vertex token", with_line(0, "v " + "1" * MB3 + " 0 0"), ["line 1"]),
    ]
    return E


CLI_CASES = [
    # (args, flag, needs) ; needs: files copied into the case folder
    (["groundtruth", "--rig", "tiny", "--out", "X", "--texture-size", "0"], "--texture-size"),
    (["groundtruth", "--rig", "tiny", "--out", "X", "--texture-size", "-5"], "--texture-size"),
    (["groundtruth", "--rig", "tiny", "--out", "X", "--texture-size", "abc"], "--texture-size"),
    (["groundtruth", "--rig", "tiny", "--out", "X", "--texture-size", "99999"], "--texture-size"),
    (["groundtruth", "--rig", "tiny", "--out", "X", "--texture-size", "1.5"], "--texture-size"),
    (["groundtruth", "--rig", "tiny", "--out", "X", "--texture-size", ""], "--texture-size"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--views", "grid0x5"], "--views"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--views", "grid100001x1"], "--views"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--views", "bogus"], "--views"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--lights", "grid-1x2"], "--lights"),
    (["groundtruth", "--rig", "nosuchrig", "--texture-size", "8", "--out", "X"], "--rig"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--scene", "nosuchscene"], "--scene"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--scene", "cube.obj", "--scale", "0"],
     "--scale"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--scene", "cube.obj", "--scale", "-1"],
     "--scale"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--scene", "cube.obj", "--scale", "nan"],
     "--scale"),
    (["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "X", "--scene", "cube.obj", "--scale", "inf"],
     "--scale"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--d-max-mm", "-1"], "--d-max-mm"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--d-max-mm", "0"], "--d-max-mm"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--d-max-mm", "nan"], "--d-max-mm"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--d-max-mm", "inf"], "--d-max-mm"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--d-max-mm", "abc"], "--d-max-mm"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--d-max-mm", "1e308"], "--d-max-mm"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--threshold", "2"], "--threshold"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--threshold", "0"], "--threshold"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--threshold", "-1"], "--threshold"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--threshold", "nan"], "--threshold"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--texture-size", "0"], "--texture-size"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--locations", "7"], "--locations"),
    (["process", "mdf", "--session", "@S", "--out", "X", "--locations", "-1"], "--locations"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--rank", "0"], "--rank"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--rank", "101"], "--rank"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--max-error", "0"], "--max-error"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--max-error", "2"], "--max-error"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--max-error", "nan"], "--max-error"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--gain", "0"], "--gain"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--gain", "-1"], "--gain"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--gain", "nan"], "--gain"),
    (["process", "btf", "--session", "@S", "--texture-size", "8", "--out", "X", "--gain", "inf"], "--gain"),
    (["compress", "--in", "@T", "--out", "X", "--rank", "0"], "--rank"),
    (["compress", "--in", "@T", "--out", "X", "--rank", "-3"], "--rank"),
    (["compress", "--in", "@T", "--out", "X", "--max-error", "2"], "--max-error"),
    (["compress", "--in", "@T", "--out", "X", "--max-error", "nan"], "--max-error"),
    (["compress", "--in", "@T", "--out", "X", "--layout", "foo"], "--layout"),
    (["compress", "--in", "@T", "--out", "X", "--color", "cmyk"], "--color"),
    (["simulate", "--out", "X", "--seed", "-1"], "--seed"),
    (["simulate", "--out", "X", "--seed", "abc"], "--seed"),
    (["simulate", "--out", "X", "--seed", "99999999999999999999999"], "--seed"),
    (["simulate", "--out", "X", "--samples-per-pixel-side", "99"], "--samples-per-pixel-side"),
    (["simulate", "--out", "X", "--samples-per-pixel-side", "0"], "--samples-per-pixel-side"),
    (["simulate", "--out", "X", "--interreflection-rays", "999"], "--interreflection-rays"),
    (["simulate", "--out", "X", "--interreflection-rays", "-1"], "--interreflection-rays"),
    (["simulate", "--out", "X", "--rig", "nosuchrig"], "--rig"),
    (["render", "scene.json", "--out", "r.png", "--size", "0x0"], "--size"),
    (["render", "scene.json", "--out", "r.png", "--size", "99999x99999"], "--size"),
    (["render", "scene.json", "--out", "r.png", "--size", "abc"], "--size"),
    (["render", "scene.json", "--out", "r.png", "--size", "64x"], "--size"),
    (["render", "scene.json", "--out", "r.png", "--size", "-64x48"], "--size"),
    (["render", "scene.json", "--out", "r.png", "--size", "64x48", "--passes", "0"], "--passes"),
    (["render", "scene.json", "--out", "r.png", "--size", "64x48", "--passes", "-1"], "--passes"),
    (["render", "scene.json", "--out", "r.png", "--size", "64x48", "--passes", "abc"], "--passes"),
    (["render", "scene.json", "--out", "r.png", "--size", "64x48", "--shadow-map", "8"], "--shadow-map"),
    (["render", "scene.json", "--out", "r.bmp", "--size", "64x48"], "--out"),
    (["compare", "scene.json", "--size", "64x48", "--repeat", "0"], "--repeat"),
    (["export", "bonn", "--in", "@C", "--out", "X.dfmf", "--form", "xyz"], "--form"),
    (["export", "bonn", "--in", "@C", "--out", "X", "--form", "ubo2003", "--scale", "0"], "--scale"),
    (["export", "bonn", "--in", "@C", "--out", "X", "--form", "ubo2003", "--scale", "-1"], "--scale"),
    (["export", "bonn", "--in", "@C", "--out", "X", "--form", "ubo2003", "--scale", "nan"], "--scale"),
    (["export", "bonn", "--in", "@C", "--out", "X.dfmf", "--form", "dfmf", "--rank", "0"], "--rank"),
    (["export", "bonn", "--in", "@T", "--out", "X.dfmf", "--form", "dfmf", "--max-error", "nan"], "--max-error"),
    (["import", "bonn", "--in", "@c.dfmf", "--out", "X", "--d-max-mm", "0"], "--d-max-mm"),
    (["import", "bonn", "--in", "@c.dfmf", "--out", "X", "--d-max-mm", "-1"], "--d-max-mm"),
    (["import", "bonn", "--in", "@c.dfmf", "--out", "X", "--d-max-mm", "nan"], "--d-max-mm"),
    (["import", "bonn", "--in", "@c.dfmf", "--out", "X", "--d-max-mm", "inf"], "--d-max-mm"),
    (["import", "bonn", "--in", "@c.dfmf", "--out", "X", "--d-max-mm", "1", "--size-mm", "-1"], "--size-mm"),
    (["import", "bonn", "--in", "@c.dfmf", "--out", "X", "--d-max-mm", "1", "--size-mm", "nan"], "--size-mm"),
    (["import", "bonn", "--in", "@U2", "--out", "X", "--d-max-mm", "1", "--scale", "nan"], "--scale"),
    (["import", "bonn", "--in", "@U2", "--out", "X", "--d-max-mm", "1"], "--size-mm"),
]


def gen_cli(base, rng, n):
    B = base.root
    order = list(range(len(CLI_CASES)))
    rng.shuffle(order)
    cases = []
    for i in range(n):
        raw, flag = CLI_CASES[order[i % len(CLI_CASES)]]
        args = [a(B / x[1:]) if x.startswith("@") else x for x in raw]
        outs = []
        for k, x in enumerate(args[:-1]):
            if x == "--out":
                outs.append(args[k + 1])

        def setup(d):
            shutil.copy(B / "cube.obj", d)
            write_scene(d, a(B / "C"))
            return ""

        shown = " ".join(shlex.quote(x) for x in raw)
        cases.append(Case("cli-flag", "%s %s" % (flag, shown[:120]), args, setup, "reject", [], cli=True,
                          field_any=flag_names(flag), outs=outs))
    return cases


REPLACE_SPECS = 29  # the number of specs in gen_replace


def gen_replace(base, rng, n):
    B = base.root
    T, C, S = a(B / "T"), a(B / "C"), a(B / "S")
    specs = []

    def user_folder(d):
        (d / "U").mkdir()
        (d / "U" / "notes.txt").write_text("my notes\n")

    def user_file(d):
        (d / "notes.txt").write_text("my notes\n")

    def tree(src, dst):
        return lambda d: copy_tree(B / src, d / dst)

    def both(*fs):
        def f(d):
            for g in fs:
                g(d)
        return f

    def in_w(src, dst):
        def f(d):
            (d / "W").mkdir()
            copy_tree(B / src, d / "W" / dst)
        return f

    def ubo_with_note(d):
        copy_tree(B / "U2", d / "U2x")
        (d / "U2x" / "notes.txt").write_text("mine\n")

    def pkg_with_file(d):
        copy_tree(B / "T", d / "P")
        shutil.copy(B / "c.dfmf", d / "P" / "x.dfmf")

    def link_to_input(d):
        copy_tree(B / "T", d / "Tx")
        os.symlink("Tx", d / "L")

    R = "reject"
    specs += [
        ("--out a folder holding a user's file (groundtruth)",
         ["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "U", "--replace"], user_folder, R, ["U"]),
        ("--out a folder holding a user's file (compress)", ["compress", "--in", T, "--out", "U", "--replace"],
         user_folder, R, ["U"]),
        ("--out a folder holding a user's file (process mdf)",
         ["process", "mdf", "--session", S, "--texture-size", "8", "--out", "U", "--replace"], user_folder, R, ["U"]),
        ("--out a folder holding a user's file (process btf)",
         ["process", "btf", "--session", S, "--texture-size", "8", "--out", "U", "--replace"], user_folder, R, ["U"]),
        ("--out a folder holding a user's file (import bonn)",
         ["import", "bonn", "--in", a(B / "c.dfmf"), "--out", "U", "--d-max-mm", "1", "--replace"], user_folder, R,
         ["U"]),
        ("--out a folder holding a user's file (export ubo2003)",
         ["export", "bonn", "--in", C, "--form", "ubo2003", "--out", "U", "--replace"], user_folder, R, ["U"]),
        ("--out a user's file (export dfmf)",
         ["export", "bonn", "--in", C, "--form", "dfmf", "--out", "notes.txt", "--replace"], user_file, R,
         ["notes.txt"]),
        ("--out a user's file (groundtruth)",
         ["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "notes.txt", "--replace"], user_file, R,
         ["notes.txt"]),
        ("--out the command's own input (compress)", ["compress", "--in", "Tx", "--out", "Tx", "--replace"],
         tree("T", "Tx"), R, ["Tx"]),
        ("--out the command's own input (export ubo2003)",
         ["export", "bonn", "--in", "Cx", "--form", "ubo2003", "--out", "Cx", "--replace"], tree("C", "Cx"), R,
         ["Cx"]),
        ("--out the command's own input (process mdf)",
         ["process", "mdf", "--session", "Sx", "--texture-size", "8", "--out", "Sx", "--replace"], tree("S", "Sx"), R,
         ["Sx"]),
        ("--out the command's own input (process btf)",
         ["process", "btf", "--session", "Sx", "--texture-size", "8", "--out", "Sx", "--replace"], tree("S", "Sx"), R,
         ["Sx"]),
        ("--out the command's own input (import ubo2003)",
         ["import", "bonn", "--in", "U2x", "--out", "U2x", "--d-max-mm", "1", "--size-mm", "12", "--replace"],
         tree("U2", "U2x"), R, ["U2x"]),
        ("--out the command's own input file (export dfmf over its input's data file)",
         ["export", "bonn", "--in", "Cx", "--form", "dfmf", "--out", "Cx/mdf.exr", "--replace"], tree("C", "Cx"), R,
         ["Cx"]),
        ("--out a folder holding the input (compress)", ["compress", "--in", "W/Tx", "--out", "W", "--replace"],
         in_w("T", "Tx"), R, ["W"]),
        ("--out a folder holding the input (process mdf)",
         ["process", "mdf", "--session", "W/Sx", "--texture-size", "8", "--out", "W", "--replace"], in_w("S", "Sx"),
         R, ["W"]),
        ("--out a package holding the input file (import dfmf)",
         ["import", "bonn", "--in", "P/x.dfmf", "--out", "P", "--d-max-mm", "1", "--replace"], pkg_with_file, R,
         ["P"]),
        ("--out a symlink to the input (compress)", ["compress", "--in", "Tx", "--out", "L", "--replace"],
         link_to_input, R, ["L", "Tx"]),
        ("--out a UBO2003 folder holding a user's file",
         ["export", "bonn", "--in", C, "--form", "ubo2003", "--out", "U2x", "--replace"], ubo_with_note, R, ["U2x"]),
        ("--out an existing package without --replace", ["compress", "--in", T, "--out", "Cx"], tree("C", "Cx"), R,
         ["Cx"]),
        ("--out an existing session without --replace", ["simulate", "--out", "Sx"], tree("S", "Sx"), R, ["Sx"]),
        ("--out an existing DFMF without --replace",
         ["export", "bonn", "--in", C, "--form", "dfmf", "--out", "c.dfmf"],
         lambda d: shutil.copy(B / "c.dfmf", d), R, ["c.dfmf"]),
        ("eval mdf --out over the truth's manifest (its own input)",
         ["eval", "mdf", "--truth", "Tx", "--estimate", a(B / "M"), "--out", "Tx/manifest.json"], tree("T", "Tx"), R,
         ["Tx"]),
        ("render --out over its material's mdf.exr (its own input)",
         ["render", "scene.json", "--out", "Cx/mdf.exr", "--size", "64x48"],
         both(tree("C", "Cx"), lambda d: write_scene(d, "Cx")), R, ["Cx"]),
        ("eval mdf --out over the truth's manifest with --replace",
         ["eval", "mdf", "--truth", "Tx", "--estimate", a(B / "M"), "--out", "Tx/manifest.json", "--replace"],
         tree("T", "Tx"), R, ["Tx"]),
        ("render --out over its material's mdf.exr with --replace",
         ["render", "scene.json", "--out", "Cx/mdf.exr", "--size", "64x48", "--replace"],
         both(tree("C", "Cx"), lambda d: write_scene(d, "Cx")), R, ["Cx"]),
        # valid replacements: must succeed
        ("--replace a package this command wrote (groundtruth)",
         ["groundtruth", "--rig", "tiny", "--texture-size", "8", "--out", "Tx", "--replace"], tree("T", "Tx"),
         "accept", ["Tx"]),
        ("--replace another package (compress)", ["compress", "--in", T, "--out", "Cx", "--replace"],
         tree("C", "Cx"), "accept", ["Cx"]),
        ("--replace an existing DFMF", ["export", "bonn", "--in", C, "--form", "dfmf", "--out", "c.dfmf", "--replace"],
         lambda d: shutil.copy(B / "c.dfmf", d), "accept", ["c.dfmf"]),
    ]
    assert len(specs) == REPLACE_SPECS
    order = list(range(len(specs)))
    rng.shuffle(order)
    cases = []
    for i in range(n):
        what, args, setup, expect, name_any = specs[order[i % len(specs)]]
        outs = []
        for k, x in enumerate(args[:-1]):
            if x == "--out":
                outs.append(args[k + 1])
        if expect == "accept":
            outs = [o for o in outs]
        else:
            outs = []

        def s(d, setup=setup):
            setup(d)
            return ""

        cases.append(Case("replace-misuse", what, args, s, expect, name_any, outs=outs))
    return cases


# ----------------------------------------------------------------------------


def make_cases(base, seed, total):
    rng = random.Random(seed)
    # every CLI and --replace case once where the total allows it; field edits
    # (the largest pool of distinct known-invalid inputs) take the rest
    counts = {"session-data": int(total * 0.125), "package-data": int(total * 0.125),
              "json-mutation": int(total * 0.125), "cli-flag": min(len(CLI_CASES), int(total * 0.13)),
              "replace-misuse": min(REPLACE_SPECS, int(total * 0.05))}
    counts["field-edit"] = total - sum(counts.values())
    cases = gen_controls(base)
    cases += gen_session_data(base, random.Random(rng.random()), counts["session-data"])
    cases += gen_package_data(base, random.Random(rng.random()), counts["package-data"])
    cases += gen_json_mutation(base, random.Random(rng.random()), counts["json-mutation"])
    cases += gen_field_edits(base, random.Random(rng.random()), counts["field-edit"])
    cases += gen_cli(base, random.Random(rng.random()), counts["cli-flag"])
    cases += gen_replace(base, random.Random(rng.random()), counts["replace-misuse"])
    for i, c in enumerate(cases):
        c.id = ("k%03d" % i) if c.kind == "control" else ("c%04d" % i)
    return cases


def reproducer(case, binary, case_dir, seed, keep):
    cmd = "cd %s && %s -q %s" % (shlex.quote(str(case_dir)), shlex.quote(str(binary)),
                                 " ".join(shlex.quote(x if len(x) < 200 else x[:40] + "...") for x in case.args))
    again = "" if keep else "  (recreate: scripts/hostile_inputs.py --seed %d --only %s --keep)" % (seed, case.id)
    return cmd + again


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cases", type=int, default=600)
    ap.add_argument("--binary", default=str(DEFAULT_BINARY))
    ap.add_argument("--keep", action="store_true", help="keep the temporary working folder")
    ap.add_argument("--only", default="", help="comma-separated case ids to run (controls always run)")
    ap.add_argument("--kinds", default="", help="comma-separated kinds to run (default: all)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per mesocap call")
    ap.add_argument("--verbose", action="store_true", help="print every case as it finishes")
    o = ap.parse_args()
    binary = Path(o.binary).resolve()
    if not binary.is_file():
        sys.exit("hostile_inputs: no binary at %s" % binary)

    t0 = time.monotonic()
    wait_for_binary(binary)
    work = Path(tempfile.mkdtemp(prefix="mesocap-hostile-"))
    failed = []
    try:
        base_root = work / "base"
        make_base(binary, base_root, o.timeout)
        base = Base(base_root)
        base_snap = snapshot(base_root)
        cases = make_cases(base, o.seed, o.cases)
        if o.only:
            wanted = set(o.only.split(","))
            cases = [c for c in cases if c.kind == "control" or c.id in wanted]
        if o.kinds:
            kinds = set(o.kinds.split(","))
            cases = [c for c in cases if c.kind == "control" or c.kind in kinds]
        print("hostile_inputs: %d cases (+ controls), seed %d, binary %s, work %s" %
              (sum(c.kind != "control" for c in cases), o.seed, binary, work), flush=True)
        print("hostile_inputs: field edits drawn from %d distinct edits, CLI cases from %d, --replace cases from %d"
              % (FIELD_POOL[0], len(CLI_CASES), REPLACE_SPECS), flush=True)
        controls_ok = True
        for n, case in enumerate(cases):
            d = work / "cases" / case.id
            d.mkdir(parents=True)
            mut = case.setup(d)
            if mut:
                case.what = case.what + " {" + mut + "}" if mut not in case.what else case.what
            run_case(case, binary, d, o.timeout)
            if case.kind == "control" and case.outcome != OK_ACCEPTED:
                controls_ok = False
            if not o.keep:
                shutil.rmtree(d, ignore_errors=True)
            if o.verbose and case.stderr.strip():
                print("      stderr: " + [l for l in case.stderr.splitlines() if l.strip()][-1][:200])
            if o.verbose or not case.outcome.startswith("ok"):
                print("  %s %-14s %-15s rc=%s %.1fs %s%s" % (case.id, case.kind, case.outcome, case.rc, case.seconds,
                                                            case.what[:150],
                                                            (" -- " + "; ".join(case.reasons))[:300]
                                                            if case.reasons else ""), flush=True)
            elif (n + 1) % 50 == 0:
                print("  ... %d/%d (%.0f s)" % (n + 1, len(cases), time.monotonic() - t0), flush=True)
            if case.kind == "control" and n + 1 < len(cases) and cases[n + 1].kind != "control" and not controls_ok:
                print("hostile_inputs: a control (valid input) failed: the classification below is not reliable",
                      flush=True)
        if len(BINARY_CHANGES) > 1:
            print("hostile_inputs: note: the binary was rebuilt during the run (%d versions used)" %
                  len(BINARY_CHANGES), flush=True)
        if snapshot(base_root) != base_snap:
            print("hostile_inputs: WARNING: the base inputs changed during the run", flush=True)
            failed.append(None)

        # summary
        print()
        print("Summary (cases by kind and outcome; runtime %.0f s)" % (time.monotonic() - t0))
        present = [k for k in OUTCOMES if any(c.outcome == k for c in cases)]
        w = max(len(k) for k in present) if present else 10
        print("%-15s %6s " % ("kind", "total") + " ".join("%*s" % (w, k) for k in present))
        for kind in KINDS + ["all"]:
            sel = [c for c in cases if (kind == "all" and c.kind != "control") or c.kind == kind]
            if not sel:
                continue
            print("%-15s %6d " % (kind, len(sel)) + " ".join("%*d" % (w, sum(c.outcome == k for c in sel))
                                                              for k in present))
        bad = [c for c in cases if not c.outcome.startswith("ok")]
        failed += bad
        if bad:
            print()
            print("Failing cases (%d):" % len(bad))
            for c in bad:
                print("%s [%s] %s: %s" % (c.id, c.kind, c.outcome, c.what[:300]))
                print("    why: %s" % "; ".join(c.reasons)[:500])
                last = [l for l in c.stderr.splitlines() if l.strip() and '"task"' not in l]
                if last:
                    print("    stderr: %s" % last[-1][:300])
                print("    repro: %s" % reproducer(c, binary, work / "cases" / c.id, o.seed, o.keep))
        print()
        print("hostile_inputs: %d of %d cases failed; runtime %.0f s" %
              (len([c for c in failed if c is not None]), len(cases), time.monotonic() - t0))
    finally:
        if o.keep:
            print("hostile_inputs: kept %s" % work)
        else:
            shutil.rmtree(work, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
