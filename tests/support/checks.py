"""What the Python system tests share: the verdicts they print and count, and
where the benches' helpers live (bench/reliability: scenes, runs, series)."""
import os
import shutil
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench", "reliability"))

SKIP = 77  # CTest's SKIP_RETURN_CODE for these tests: the machine cannot host them


class Checks:
    """Prints each check as `<name>: ok: ...` or `<name>: FAILED: ...` and keeps the failures."""

    def __init__(self, name):
        self.name = name
        self.failures = []

    def log(self, message):
        print("%s: %s" % (self.name, message), flush=True)

    def __call__(self, ok, what):
        self.log(("ok: " if ok else "FAILED: ") + what)
        if not ok:
            self.failures.append(what)

    def fail(self, what):
        self(False, what)

    def verdict(self):
        self.log("%d check(s) failed" % len(self.failures) if self.failures else "passed")
        return 1 if self.failures else 0


def in_scratch(checks, prefix, make, scenario, keep=False):
    """A scratch directory; `make(work)` gives what the test stands up there
    (its up() and down()), `scenario(environment, work)` runs the checks.
    down() runs whatever happened; the directory is kept when asked or when
    a check failed. Returns the exit status."""
    work = tempfile.mkdtemp(prefix=prefix)
    environment = make(work)
    try:
        environment.up()
        scenario(environment, work)
    except Exception as e:  # what could not start or run: a failure, with the logs kept
        checks.fail(str(e))
    finally:
        environment.down()
        if keep or checks.failures:
            checks.log("kept %s" % work)
        else:
            shutil.rmtree(work, ignore_errors=True)
    return checks.verdict()
