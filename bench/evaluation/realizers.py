"""What real realizers make of mse's BML (issue 14): the table of docs/realizers.md.

    MSE_SHARED=../shared python -m bench.evaluation.realizers

Builds the corpus tests/test_realizers_parsers.py checks (8 bundled + 11 imported Greta sets x
seeds 1-3, 10 s, one file per realizer variant), runs AsapRealizer's parser and Greta's
reader, lexicon lookup, temporizer and realizer once over all of it, and prints, per variant,
rejected blocks, realizer exceptions, time mismatches over 1 ms and Greta's resolution per
modality, next to Greta's own MSE path (GretaNativeControl: lexicon.xml's signals built as
Greta's MSESelector builds them, no BML) for the same imported occurrences.  Asserts nothing.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

from tests.realizer_harness import (
    Corpus,
    Resolution,
    asap_variants,
    build_corpus,
    greta_resolution,
    greta_variants,
    java_missing_reason,
    native_resolution,
)

REPO = Path(__file__).resolve().parent.parent.parent
MODALITIES = ("face", "head", "gaze", "gesture", "torso")


def _mismatches(corpus: Corpus, variant: str, greta: bool) -> tuple[int, int]:
    """(behaviours read, of which at a time more than 1 ms off) for one variant."""
    read = off = 0
    for export in corpus.of(variant):
        for bid, (_tag, signal) in export.elements().items():
            if greta:
                start, end = corpus.greta[export.path].timed.get(bid, (None, None))
            else:
                behaviour = corpus.asap[export.path].behaviours.get(bid)
                start, end = (behaviour.start, behaviour.end) if behaviour else (None, None)
            if start is None or end is None:
                continue
            read += 1
            off += abs(start - signal.start) > 0.001 or abs(end - signal.stop) > 0.001
    return read, off


def _cell(resolution: Resolution, modality: str) -> str:
    total = resolution.total.get(modality, 0)
    return f"{resolution.resolved.get(modality, 0)}/{total}" if total else "-"


def _row(label: str, resolution: Resolution) -> str:
    resolved, total = resolution.count()
    cells = " | ".join(_cell(resolution, m) for m in MODALITIES)
    share = f"{100 * resolved / total:.1f} %" if total else "-"
    return f"| {label} | {cells} | **{resolved}/{total}** ({share}) |"


def main() -> int:
    shared = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
    reason = java_missing_reason(shared)
    if reason is not None:
        print(f"cannot run: {reason}", file=sys.stderr)
        return 1
    began = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        corpus = build_corpus(shared, Path(folder))
    print(f"corpus: {len(corpus.exports)} files built and parsed in {time.perf_counter() - began:.1f} s\n")

    print("| variant | files | rejected by ASAP / Greta exceptions | behaviours read | times off > 1 ms |")
    print("|---|---|---|---|---|")
    for variant in asap_variants(shared / "greta"):
        files = corpus.of(variant)
        rejected = sum(corpus.asap[e.path].rejected is not None for e in files)
        read, off = _mismatches(corpus, variant, greta=False)
        print(f"| ASAP `{variant}` | {len(files)} | {rejected} rejected | {read} | {off} |")
    for variant in greta_variants(shared / "greta"):
        files = corpus.of(variant)
        thrown = sum(corpus.greta[e.path].exception is not None for e in files)
        read, off = _mismatches(corpus, variant, greta=True)
        print(f"| Greta `{variant}` | {len(files)} | {thrown} exceptions | {read} | {off} |")

    print("\nGreta resolution per timeline occurrence (left-out torsos count as unresolved):\n")
    print("| variant, sets | " + " | ".join(MODALITIES) + " | all |")
    print("|---" * (len(MODALITIES) + 2) + "|")
    for variant in greta_variants(shared / "greta"):
        print(_row(f"`{variant}`, bundled", greta_resolution(corpus, variant, "bundled")))
        print(_row(f"`{variant}`, imported", greta_resolution(corpus, variant, "imported")))
    native, worse = native_resolution(corpus, "greta-bml")
    print(_row("Greta's own MSE path, imported", native))
    print(f"\nimported occurrences Greta's own path resolves and the greta-bml export does not: {len(worse)}")
    for kind in ("bundled", "imported"):
        directed, gazes = _gaze_directions(corpus, "greta-bml", kind)
        print(f"{kind} gaze occurrences Greta plays with a direction (the rest look at the target): {directed}/{gazes}")
    return 0


def _gaze_directions(corpus: Corpus, variant: str, kind: str) -> tuple[int, int]:
    directed = gazes = 0
    for export in corpus.of(variant):
        if export.kind != kind:
            continue
        for signal in corpus.greta[export.path].signals.values():
            if signal.kind == "GazeSignal":
                gazes += 1
                directed += signal.field("offsetDirection") not in (None, "FRONT")
    return directed, gazes


if __name__ == "__main__":
    raise SystemExit(main())
