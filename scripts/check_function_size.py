#!/usr/bin/env python3
"""Checks that no function of src/, tools/ or bench/ is longer than the repository allows.

clang-tidy's readability-function-size, configured by the repository's .clang-tidy (LineThreshold
100), runs over every C++ source of src/, tools/ and bench/ in the build's compile database
(compile_commands.json, which CMakeLists.txt asks CMake to write: the workspace's build folder
with catkin_make, the build folder with plain cmake), one clang-tidy per file, --jobs at a time,
the main files only (no header filter: the headers are not part of the rule).

Prints each function over the threshold as `file:line name (N lines)` and exits 1 when there is
one, when clang-tidy fails on a file, or when clang-tidy is not installed (it is a test
dependency: scripts/install_deps.sh installs Debian's clang-tidy). Sources of those folders that
the compile database lacks (not built in this configuration) are listed, not checked. With --junit, writes the verdict as one
JUnit test case, which scripts/run_tests.sh counts with the other tests.

Usage: scripts/check_function_size.py --build-dir DIR [--source-dir DIR] [--jobs N] [--junit FILE]
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from xml.sax.saxutils import escape, quoteattr

FOLDERS = ("src", "tools", "bench")
WARNING = re.compile(r"^(?P<file>.+?):(?P<line>\d+):\d+: warning: function '(?P<name>.+)' "
                     r"exceeds recommended size/complexity thresholds \[readability-function-size\]$")
NOTE = re.compile(r"^.+?:\d+:\d+: note: (?P<lines>\d+) lines including whitespace and comments "
                  r"\(threshold (?P<threshold>\d+)\)$")
ERROR = re.compile(r"^.+?:\d+:\d+: (fatal )?error: |^error: ")


class Failure(Exception):
    """The check could not run (no clang-tidy, no compile database)."""


def find_clang_tidy():
    for name in ("clang-tidy", "clang-tidy-14"):
        path = shutil.which(name)
        if path:
            return path
    raise Failure("clang-tidy is not installed, so the function-size rule cannot be checked: install "
                  "Debian's clang-tidy (scripts/install_deps.sh installs it; it is a test dependency)")


def line_threshold(config):
    """The LineThreshold of the .clang-tidy file `config` (for the messages only)."""
    with open(config) as text:
        match = re.search(r"LineThreshold\s*\n\s*value:\s*(\d+)", text.read())
    return int(match.group(1)) if match else None


def sources(build_dir, source_dir):
    """{repository path: the path the compile database names} of the C++ sources of FOLDERS."""
    database = os.path.join(build_dir, "compile_commands.json")
    if not os.path.isfile(database):
        raise Failure("no %s: configure the build with CMAKE_EXPORT_COMPILE_COMMANDS=ON "
                      "(CMakeLists.txt sets it; reconfigure an older build folder)" % database)
    with open(database) as text:
        entries = json.load(text)
    root = os.path.realpath(source_dir)
    found = {}
    for entry in entries:
        path = os.path.join(entry["directory"], entry["file"])
        relative = os.path.relpath(os.path.realpath(path), root)
        if relative.split(os.sep)[0] in FOLDERS and relative.endswith(".cpp"):
            found.setdefault(relative, path)
    return found


def sources_on_disk(source_dir):
    paths = []
    for folder in FOLDERS:
        for directory, _, files in os.walk(os.path.join(source_dir, folder)):
            paths += [os.path.relpath(os.path.join(directory, f), source_dir) for f in files if f.endswith(".cpp")]
    return sorted(paths)


def lint(clang_tidy, config, build_dir, relative, path):
    """(offenders as `file:line name (N lines)`, errors) of one source file."""
    # -Wno-unknown-warning-option: clang parses the file with the build's gcc flags, and a
    # gcc-only warning option (-Wno-maybe-uninitialized) would be an error under -Werror.
    command = [clang_tidy, "--quiet", "--config-file=" + config, "--extra-arg=-Wno-unknown-warning-option",
               "-p", build_dir, path]
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    lines = result.stdout.splitlines()
    offenders, errors = [], []
    for i, line in enumerate(lines):
        warning = WARNING.match(line)
        if warning and os.path.realpath(warning.group("file")) == os.path.realpath(path):
            note = next((NOTE.match(n) for n in lines[i + 1:i + 4] if NOTE.match(n)), None)
            size = note.group("lines") if note else "?"
            offenders.append("%s:%s %s (%s lines)" % (relative, warning.group("line"), warning.group("name"), size))
        elif ERROR.match(line):
            errors.append("%s: %s" % (relative, line))
    if result.returncode != 0 and not errors:
        errors.append("%s: clang-tidy exited with %d:\n%s" % (relative, result.returncode, result.stdout[-2000:]))
    return offenders, errors


def junit(name, message, output, seconds):
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name="function_size" tests="1" failures="%d" errors="0" time="%.1f">'
             % (1 if message else 0, seconds),
             '  <testcase classname="RepositoryRules" name="%s" time="%.1f">' % (name, seconds)]
    if message:
        lines.append("    <failure message=%s>%s</failure>" % (quoteattr(message), escape(output or message)))
    lines += ["  </testcase>", "  <system-out>%s</system-out>" % escape(output), "</testsuite>", ""]
    return "\n".join(lines)


def check(args, config):
    """(failure message or "", report) of the whole check."""
    clang_tidy = find_clang_tidy()
    files = sources(args.build_dir, args.source_dir)
    missing = [p for p in sources_on_disk(args.source_dir) if p not in files]
    if len(files) < 30:
        raise Failure("only %d sources of %s in %s/compile_commands.json: is it the package's build folder?"
                      % (len(files), ", ".join(FOLDERS), args.build_dir))
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        results = list(pool.map(lambda item: lint(clang_tidy, config, args.build_dir, *item), sorted(files.items())))
    offenders = [o for found, _ in results for o in found]
    errors = [e for _, found in results for e in found]
    threshold = line_threshold(config)
    report = ["%d files of %s checked by %s (readability-function-size, LineThreshold %s of %s)"
              % (len(files), ", ".join(f + "/" for f in FOLDERS), clang_tidy, threshold, config)]
    problems = []
    if offenders:
        problems.append("%d function(s) longer than %s lines: split each into named steps" % (len(offenders), threshold))
        report += ["functions longer than %s lines (split each into named steps, each a function with a name "
                   "that says what it does):" % threshold] + ["  " + o for o in offenders]
    if missing:  # not built in this configuration (bench/ without Google Benchmark), or not yet
        report += ["not in the compile database, so not checked (not built in this configuration, or "
                   "the build folder needs configuring again):"] + ["  " + m for m in missing]
    if errors:
        problems.append("clang-tidy failed on %d file(s)" % len({e.split(":")[0] for e in errors}))
        report += ["clang-tidy errors:"] + ["  " + e for e in errors]
    return "; ".join(problems), "\n".join(report)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build-dir", required=True, help="the folder that holds compile_commands.json")
    parser.add_argument("--source-dir", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."),
                        help="the repository (default: this script's parent folder)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="clang-tidy processes at a time")
    parser.add_argument("--junit", metavar="FILE", help="also write the verdict as a JUnit XML file")
    args = parser.parse_args()
    config = os.path.join(os.path.realpath(args.source_dir), ".clang-tidy")
    # Below the tests that scripts/run_tests.sh runs at the same time, some of which time their
    # nodes: the lint takes what the CPUs have left.
    os.nice(10)
    start = time.monotonic()
    try:
        message, report = check(args, config)
    except Failure as failure:
        message, report = str(failure), ""
    seconds = time.monotonic() - start
    threshold = line_threshold(config) if os.path.isfile(config) else None
    if report:
        print(report)
    print("[check_function_size] %s in %.0f s" % ("FAILED: " + message if message else "passed", seconds))
    if args.junit:
        name = "NoFunctionIsLongerThan%sLines" % threshold if threshold else "FunctionSize"
        with open(args.junit + ".tmp", "w") as out:
            out.write(junit(name, message, report, seconds))
        os.replace(args.junit + ".tmp", args.junit)
    sys.exit(1 if message else 0)


if __name__ == "__main__":
    main()
