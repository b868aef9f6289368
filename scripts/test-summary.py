#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Summarizes one build's ctest run from the JUnit file ctest wrote (--output-junit).

    scripts/test-summary.py BUILD_DIR [--slowest N] [--strict] [--allowlist FILE]

Prints the build's test count (passed, failed, skipped, disabled) and its N slowest tests. With
--strict (the default when CI=true, which .ci/run sets) a skipped test is a failure unless
it matches an entry of .ci/skip-allowlist: a test that cannot run in CI is a test that cannot
fail. Exit 0 when the counts are clean, 1 when a test failed or skipped outside the list, 2 when
the results file is missing or unreadable.
"""

import argparse
import fnmatch
import os
import sys
import xml.etree.ElementTree as ElementTree

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ALLOWLIST = os.path.join(ROOT, ".ci", "skip-allowlist")


def read_allowlist(path):
    """(build glob, test glob) pairs; '#' starts a comment, blank lines are ignored."""
    entries = []
    if not os.path.exists(path):
        return entries
    with open(path, encoding="utf-8") as lines:
        for number, line in enumerate(lines, 1):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            fields = text.split()
            if len(fields) != 2:
                sys.exit(f"{path}:{number}: expected '<build> <test>', got {text!r}")
            entries.append((fields[0], fields[1]))
    return entries


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("build_dir")
    parser.add_argument("--slowest", type=int, default=10)
    parser.add_argument("--strict", action="store_true", default=os.environ.get("CI") == "true")
    parser.add_argument("--allowlist", default=ALLOWLIST, help="default: .ci/skip-allowlist")
    arguments = parser.parse_args()

    build = os.path.basename(os.path.normpath(arguments.build_dir))
    results = os.path.join(arguments.build_dir, "ctest-results.xml")
    try:
        suite = ElementTree.parse(results).getroot()
    except (OSError, ElementTree.ParseError) as error:
        print(f"test-summary: {results}: {error}", file=sys.stderr)
        return 2

    cases = []
    for case in suite.iter("testcase"):
        if case.find("failure") is not None or case.get("status") == "fail":
            outcome = "failed"
        elif case.find("skipped") is not None or case.get("status") == "notrun":
            # ctest marks a test whose output matched SKIP_REGULAR_EXPRESSION or that returned its
            # SKIP_RETURN_CODE as not run, with a <skipped> element.
            outcome = "skipped"
        elif case.get("status") == "disabled":
            outcome = "disabled"
        else:
            outcome = "passed"
        # gtest_discover_tests appends "  # GetParam() = ..." to a parameterized test's name.
        name = case.get("name", "").split("  # GetParam()")[0]
        cases.append((name, float(case.get("time", "0") or 0), outcome))

    counts = {key: sum(1 for _, _, o in cases if o == key)
              for key in ("passed", "failed", "skipped", "disabled")}
    total_seconds = sum(t for _, t, _ in cases)
    print(f"{build}: {len(cases)} tests: {counts['passed']} passed, {counts['failed']} failed, "
          f"{counts['skipped']} skipped, {counts['disabled']} disabled "
          f"({total_seconds:.0f} s of test time)")
    print(f"{build}: the {min(arguments.slowest, len(cases))} slowest")
    for name, seconds, outcome in sorted(cases, key=lambda c: -c[1])[:arguments.slowest]:
        print(f"  {seconds:8.2f} s  {name}" + ("" if outcome == "passed" else f"  ({outcome})"))

    status = 1 if counts["failed"] or counts["disabled"] else 0
    skipped = [name for name, _, outcome in cases if outcome == "skipped"]
    if skipped:
        allowed = read_allowlist(arguments.allowlist)
        for name in skipped:
            listed = any(fnmatch.fnmatchcase(build, b) and fnmatch.fnmatchcase(name, t)
                         for b, t in allowed)
            if listed:
                print(f"{build}: skipped, allowed by .ci/skip-allowlist: {name}")
            elif arguments.strict:
                print(f"{build}: skipped in CI and not on .ci/skip-allowlist: {name}",
                      file=sys.stderr)
                status = 1
            else:
                print(f"{build}: skipped: {name}")
    return status


if __name__ == "__main__":
    sys.exit(main())
