"""Small synthetic campaigns for the campaign tests (tests/test_campaign*.py)."""

from __future__ import annotations

import csv
from pathlib import Path

FREQUENCIES_HZ = (1.0, 3.0, 10.0, 30.0, 100.0)


def small_campaign(directory: Path, temperatures=(10.0, 20.0, 30.0), amplitudes=(2e-5, 6e-5), specimens=("S1",),
                   extra: bool = True) -> Path:
    """A few-test campaign (``synthesize_campaign``, 5 lines per test, short records); returns the manifest.

    With ``extra`` a free column ``batch`` (text, e.g. ``"007"``) is added to the manifest.
    """
    from jointid.measurement.campaign_synth import synthesize_campaign

    manifest = synthesize_campaign(directory, temperatures_c=temperatures, amplitudes_m=amplitudes,
                                   frequencies_hz=FREQUENCIES_HZ, specimens=specimens, cycles=6.37, seed=1)
    if extra:
        rows = list(csv.reader(manifest.open(newline="")))
        rows[0].append("batch")
        for i, r in enumerate(rows[1:]):
            r.append(f"{i:03d}")
        with manifest.open("w", newline="") as fh:
            csv.writer(fh, lineterminator="\n").writerows(rows)
    return manifest


def manifest_rows(manifest: Path) -> list[dict]:
    """The manifest's rows as dicts."""
    with manifest.open(newline="") as fh:
        return list(csv.DictReader(fh))


def write_manifest(manifest: Path, rows: list[dict]) -> Path:
    """Write ``rows`` (dicts with the same keys) as the manifest."""
    with manifest.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return manifest
