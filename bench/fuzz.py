"""A longer Schemathesis run than the test suite's (500 cases per operation)."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from tests.service.fuzz import fuzz


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        count, failures = fuzz(Path(tmp) / "fuzz.db", examples_per_operation=500)
        print(
            f"{count} generated requests in {time.perf_counter() - t0:.0f} s: {len(failures)} failing operations"
        )
        for failure in failures:
            print(failure)


if __name__ == "__main__":
    main()
