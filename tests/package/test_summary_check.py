#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""scripts/test-summary.py against hand-written ctest JUnit files: the counts it prints, and its
exit code for a clean run, a failure, a skip outside and inside the allow-list, strict or not."""

import os
import subprocess
import sys
import tempfile

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts",
                      "test-summary.py")


def junit(cases):
    rows = []
    for name, status in cases:
        inner = '<skipped message="Skipped"/>' if status == "notrun" else (
            '<failure message="Failed"/>' if status == "fail" else "")
        rows.append(f'<testcase name="{name}" time="0.25" status="{status}">{inner}</testcase>')
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<testsuite name="t">\n' + "\n".join(rows)
            + "\n</testsuite>\n")


def run(folder, cases, strict, allowlist_text=""):
    build = os.path.join(folder, "build-x")
    os.makedirs(build, exist_ok=True)
    with open(os.path.join(build, "ctest-results.xml"), "w", encoding="utf-8") as out:
        out.write(junit(cases))
    allowlist = os.path.join(folder, "allowlist")
    with open(allowlist, "w", encoding="utf-8") as out:
        out.write(allowlist_text)
    arguments = [sys.executable, SCRIPT, build, "--allowlist", allowlist]
    if strict:
        arguments.append("--strict")
    environment = dict(os.environ)
    environment.pop("CI", None)
    result = subprocess.run(arguments, capture_output=True, text=True, env=environment, check=False)
    return result.returncode, result.stdout + result.stderr


def expect(condition, message):
    if not condition:
        print("FAILED: " + message)
        sys.exit(1)


with tempfile.TemporaryDirectory() as folder:
    code, text = run(folder, [("A.One", "run"), ("A.Two", "run")], strict=True)
    expect(code == 0, "a clean run passes: " + text)
    expect("2 tests: 2 passed, 0 failed, 0 skipped, 0 disabled" in text, "counts: " + text)

    code, text = run(folder, [("A.One", "run"), ("A.Two", "fail")], strict=False)
    expect(code == 1, "a failed test fails: " + text)

    skipping = [("A.One", "run"), ("B.Skips", "notrun")]
    code, text = run(folder, skipping, strict=True)
    expect(code == 1 and "not on .ci/skip-allowlist: B.Skips" in text, "strict skip: " + text)
    code, text = run(folder, skipping, strict=False)
    expect(code == 0 and "skipped: B.Skips" in text, "a skip outside CI only says so: " + text)
    code, text = run(folder, skipping, strict=True,
                     allowlist_text="# why\nbuild-* B.*   # the reason\n")
    expect(code == 0 and "allowed by .ci/skip-allowlist: B.Skips" in text, "allowed: " + text)
    code, text = run(folder, skipping, strict=True, allowlist_text="build-sanitize B.*\n")
    expect(code == 1, "an entry for another build does not allow it: " + text)
print("test-summary.py: every case as expected")
