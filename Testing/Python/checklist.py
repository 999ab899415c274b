"""Named checks for the test scripts here: each prints "ok" or "FAIL" with what it checked, and
finish() exits with an error if any failed, or else prints the line that the ctest's
PASS_REGULAR_EXPRESSION looks for."""

import sys


class Checklist:
    def __init__(self):
        self.failures = []

    def expect(self, what, condition):
        print(("ok    " if condition else "FAIL  ") + what)
        if not condition:
            self.failures.append(what)
        return condition

    def finish(self, passed_line):
        if self.failures:
            sys.exit(f"{len(self.failures)} check(s) failed")
        print(passed_line)
