"""Speech sync through real realizers' parsers (issue 28, item 4): the numbers of docs/realizers.md.

    MSE_SHARED=../shared python -m bench.evaluation.speech_sync [COUNT]

Generates COUNT dialogues (default 100: 4 episodes of 2-6 s from the bundled sets, utterances
with word timings starting where the emotion changes, occurrences within 0.25 s of a word boundary
anchored to it), writes each in the four BML profiles (generic and asap BML 1.0 for AsapRealizer,
greta-bml and bml --realizer greta for Greta), runs AsapRealizer's parser and Greta's reader and
temporizer once over all of them, and prints rejections, sync references written and resolved to
the planned time, and time mismatches.  Asserts nothing.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

from tests.realizer_harness import java_missing_reason
from tests.speech_sync_harness import ASAP_PROFILES, PROFILES, generated_dialogues, verify, write_all

REPO = Path(__file__).resolve().parents[2]


def main() -> int:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    shared = Path(os.environ.get("MSE_SHARED", REPO.parent / "shared"))
    reason = java_missing_reason(shared)
    if reason is not None:
        print(f"skipped: {reason}")
        return 0
    started = time.perf_counter()
    timelines = generated_dialogues(count, seed=28)
    planned = time.perf_counter() - started
    with tempfile.TemporaryDirectory() as folder:
        written = write_all(timelines, Path(folder))
        started = time.perf_counter()
        rows = []
        for group, profiles in (
            ("AsapRealizer", ASAP_PROFILES),
            ("Greta", tuple(p for p in PROFILES if p not in ASAP_PROFILES)),
        ):
            part = [w for w in written if w.profile in profiles]
            verdict = verify(part, shared, Path(folder) / group)
            rows.append((group, ", ".join(profiles), verdict))
        parsed = time.perf_counter() - started
    words = sum(len(u.get("words", [])) for t in timelines for u in t.utterances)
    occurrences = sum(len(t.signals) for t in timelines)
    print(
        f"{count} dialogues, {sum(len(t.utterances) for t in timelines)} utterances, {words} words, "
        f"{occurrences} occurrences (planned in {planned:.1f} s; parsers {parsed:.1f} s)"
    )
    print(
        f"{'parser':<13} {'profiles':<26} {'files':>5} {'rejected':>8} {'sync refs':>9} {'resolved':>8} "
        f"{'mismatches':>10}"
    )
    for group, profiles, verdict in rows:
        assert verdict.rejected is not None and verdict.problems is not None
        print(
            f"{group:<13} {profiles:<26} {verdict.files:>5} {len(verdict.rejected):>8} {verdict.references:>9} "
            f"{verdict.resolved:>8} {len(verdict.problems):>10}"
        )
        for line in (verdict.rejected + verdict.problems)[:5]:
            print(f"  {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
