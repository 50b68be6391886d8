"""No 5xx, no undeclared status code and no response that breaks its own schema, over 900+
generated requests (positive and negative)."""

from __future__ import annotations

from pathlib import Path

from tests.service.fuzz import fuzz


def test_schemathesis_finds_no_server_errors_or_schema_violations(tmp_path: Path) -> None:
    count, failures = fuzz(tmp_path / "fuzz.db", examples_per_operation=30)
    assert not failures, "\n\n".join(failures)
    assert count >= 900
