"""Run the realizers' own parsers (``$MSE_SHARED/realizers``, see its README) and read their reports.

- AsapRealizer: ``asap/parse FILE...`` (saiba OpenBMLParser in AsapRealizer's strict mode).
- Greta: the two harness classes ``greta/parse`` runs (``GretaBmlHarness``: BMLFileReader,
  SignalFiller, Temporizer; ``GretaRealizerHarness``: the Realizer), and ``GretaNativeControl``
  (the signals of lexicon.xml built as Greta's own MSESelector builds them, no BML), each in one
  JVM for all files.  They run from a copy of Greta's run folder made of symbolic links, whose
  four MSE libraries point at a library folder (``../shared/greta`` by default): the checked-out
  run folder stores those four links as text files on file systems without symbolic links, and
  a separate folder lets tests play BML against any library folder.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mse.export import ExportOptions
from mse.ir import model as ir
from mse.timeline import Timeline, TimelineSignal

GRETA_LIBRARY_LINKS = ("facelibrary.xml", "HeadGestures.xml", "TorsoGestures.xml", "gestuary_poppy.xml")
_TIMEOUT = 600


def java_missing_reason(shared: Path) -> str | None:
    """Why the parsers cannot run here (None when they can)."""
    if shutil.which("java") is None:
        return "no Java runtime on PATH (CI installs openjdk-17-jre-headless: see .ci/run)"
    for part in ("greta/classes", "greta/run", "asap/parse"):
        if not (shared / "realizers" / part).exists():
            return f"realizer parsers not found: {shared / 'realizers' / part}"
    return None


# -- AsapRealizer --------------------------------------------------------------------------------
@dataclass
class AsapBehaviour:
    kind: str
    id: str
    start: float | None
    end: float | None
    line: str


@dataclass
class AsapFile:
    rejected: str | None = None
    behaviours: dict[str, AsapBehaviour] = field(default_factory=dict)


_SYNC = re.compile(r"sync (start|end)=\[([^\]]*)\]")


def _seconds(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def run_asap(shared: Path, files: Sequence[Path]) -> dict[Path, AsapFile]:
    """What AsapRealizer's parser makes of each file, keyed by the path given."""
    script = shared / "realizers" / "asap" / "parse"
    done = subprocess.run(
        ["bash", str(script), *map(str, files)], capture_output=True, text=True, timeout=_TIMEOUT, check=False
    )
    by_name = {str(f): f for f in files}
    results: dict[Path, AsapFile] = {}
    current: AsapFile | None = None
    for line in done.stdout.splitlines():
        if line.startswith("=== FILE "):
            name = line.removeprefix("=== FILE ").removesuffix(" (with BMLA extension)")
            current = results.setdefault(by_name.get(name, Path(name)), AsapFile())
        elif current is None:
            continue
        elif line.startswith("REJECTED"):
            current.rejected = line
        elif line.startswith("BEHAVIOUR "):
            kind, bid = line.split()[1], re.search(r" id=(\S+)", line).group(1)  # type: ignore[union-attr]
            syncs = {name: _seconds(value) for name, value in _SYNC.findall(line)}
            current.behaviours[bid] = AsapBehaviour(kind, bid, syncs.get("start"), syncs.get("end"), line)
    missing = [f for f in files if f not in results]
    assert not missing, f"asap/parse reported nothing for {missing[:3]}: {done.stderr[-2000:]}"
    return results


# -- Greta ---------------------------------------------------------------------------------------
@dataclass
class GretaSignal:
    kind: str
    id: str
    modality: str
    resolved: bool
    line: str

    def field(self, name: str) -> str | None:
        match = re.search(rf" {name}=(\S*)", self.line)
        return match.group(1).strip("'") if match else None


@dataclass
class GretaFile:
    signals: dict[str, GretaSignal] = field(default_factory=dict)
    timed: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)
    exception: str | None = None
    keyframes: dict[str, int] = field(default_factory=dict)
    realized: bool = False


def greta_run_folder(shared: Path, library_dir: Path, target: Path) -> Path:
    """A copy of Greta's run folder made of symbolic links, the four MSE libraries from ``library_dir``."""
    source = shared / "realizers" / "greta" / "run"
    lexicon = Path("BehaviorRealizer") / "BehaviorLexicon"
    for root, _dirs, files in os.walk(source):
        relative = Path(root).relative_to(source)
        (target / relative).mkdir(parents=True, exist_ok=True)
        for name in files:
            link = target / relative / name
            if relative == lexicon and name in GRETA_LIBRARY_LINKS:
                link.symlink_to((library_dir / name).resolve())
            else:
                link.symlink_to(Path(root, name).resolve())
    return target


def _greta_java(shared: Path, run_folder: Path, main: str, arguments: Sequence[str]) -> str:
    home = shared / "realizers" / "greta"
    classpath = os.pathsep.join([str(home / "classes"), *sorted(str(j) for j in (home / "lib").glob("*.jar"))])
    done = subprocess.run(
        ["java", "-cp", classpath, main, *arguments],
        cwd=run_folder,
        capture_output=True,
        text=True,
        timeout=_TIMEOUT,
        check=False,
    )
    return done.stdout + done.stderr


def run_greta(shared: Path, run_folder: Path, files: Sequence[Path]) -> dict[Path, GretaFile]:
    """What Greta's reader, lexicon lookup, temporizer and realizer make of each file."""
    absolute = {str(f.resolve()): f for f in files}
    results: dict[Path, GretaFile] = {f: GretaFile() for f in files}
    current: GretaFile | None = None
    for line in _greta_java(shared, run_folder, "GretaBmlHarness", list(absolute)).splitlines():
        if line.startswith("=== FILE "):
            current = results[absolute[line.removeprefix("=== FILE ")]]
        elif current is None:
            continue
        elif line.startswith("SIGNAL "):
            words = line.split()
            bid = re.search(r" id=(\S+)", line).group(1)  # type: ignore[union-attr]
            modality = re.search(r" modality=(\S+)", line).group(1)  # type: ignore[union-attr]
            current.signals[bid] = GretaSignal(words[1], bid, modality, "resolvedInLexicon=true" in line, line)
        elif line.startswith("TIMED "):
            bid, start, end = re.match(r"TIMED (\S+) start=(\S+) end=(\S+)", line).groups()  # type: ignore[union-attr]
            current.timed[bid] = (_seconds(start), _seconds(end))
    current = None
    for line in _greta_java(shared, run_folder, "GretaRealizerHarness", list(absolute)).splitlines():
        if line.startswith("=== REALIZE "):
            current = results[absolute[line.removeprefix("=== REALIZE ")]]
            current.realized = True
        elif current is None:
            continue
        elif line.startswith("REALIZER-EXCEPTION") and current.exception is None:
            current.exception = line
        elif line.startswith("KEYFRAMES modality="):
            modality, count = re.match(r"KEYFRAMES modality=(\S+) n=(\d+)", line).groups()  # type: ignore[union-attr]
            current.keyframes[modality] = int(count)
    return results


def run_greta_native(shared: Path, run_folder: Path, lexicon: Path) -> dict[tuple[str, int], bool]:
    """Greta's own MSE path: ``(behaviour set, signal position) -> resolved`` for every signal
    of every ``type="mse"`` set of ``lexicon`` (GretaNativeControl prints them in file order)."""
    found: dict[tuple[str, int], bool] = {}
    counters: dict[str, int] = {}
    pattern = re.compile(r"NATIVE set=(\S+) modality=\S+ name=\S+ resolvedInLexicon=(true|false)")
    for line in _greta_java(shared, run_folder, "GretaNativeControl", [str(lexicon.resolve())]).splitlines():
        match = pattern.match(line)
        if match:
            name = match.group(1)
            counters[name] = counters.get(name, 0) + 1
            found[(name, counters[name])] = match.group(2) == "true"
    return found


# -- the corpus: bundled and imported Greta sets x seeds, exported for each realizer -------------
SEEDS = (1, 2, 3)
DURATION = 10.0


@dataclass
class Export:
    """One exported file and what it was made from."""

    path: Path
    timeline: Timeline
    kind: str  # "bundled" | "imported" | "synthetic"
    expression: str
    variant: str
    text: str

    def elements(self) -> dict[str, tuple[str, TimelineSignal]]:
        """Behaviour id written in the file -> (element tag, the timeline signal it plays)."""
        from lxml import etree

        from mse.export.behaviours import plan_behaviours

        by_id = {b.id: b.signal for b in plan_behaviours(self.timeline)}
        found = {}
        for node in etree.fromstring(self.text.encode("utf-8")).iter():
            bid = node.get("id") if isinstance(node.tag, str) else None
            if bid is None or node.get("start") is None:
                continue
            signal = by_id.get(bid) or by_id.get(re.sub(r"_au\d+$", "", bid))
            if signal is None and etree.QName(node).localname == "wait":
                continue  # the placeholder of a block with nothing this realizer can play
            assert signal is not None, f"{self.path.name}: {bid} plays no signal of the timeline"
            found[bid] = (etree.QName(node).localname, signal)
        return found


@dataclass
class Corpus:
    exports: list[Export]
    asap: dict[Path, AsapFile]
    greta: dict[Path, GretaFile]
    native: dict[tuple[str, str], bool]  # (imported expression, signal id) -> Greta's own MSE path resolves it

    def of(self, variant: str) -> list[Export]:
        return [e for e in self.exports if e.variant == variant]


def asap_variants(greta: Path) -> dict[str, tuple[str, ExportOptions]]:
    face = greta / "facelibrary.xml"
    return {
        "generic": ("bml", ExportOptions()),
        "generic-constraints": ("bml", ExportOptions(bml_constraints=True)),
        "asap": ("bml", ExportOptions(realizer="asap")),
        "asap-facs": ("bml", ExportOptions(realizer="asap", face_library=face, bml_extensions=True)),
    }


def greta_variants(greta: Path) -> dict[str, tuple[str, ExportOptions]]:
    return {
        "greta-bml": ("greta-bml", ExportOptions()),
        "greta-in-bml": ("bml", ExportOptions(realizer="greta")),
        "greta-library-facs": ("greta-bml", ExportOptions(library_dir=greta, bml_extensions=True)),
    }


def synthetic_timeline() -> Timeline:
    """Every modality (speech and an unknown one included), for the structure checks."""
    signals = (
        TimelineSignal("smile-1", "face", "faceexp=smile", 0.0, 1.5),
        TimelineSignal("head down", "head", "head=head_down", 0.5, 2.0),
        TimelineSignal("gaze.down", "gaze", "gaze=look_down_left", 1.0, 2.25),
        TimelineSignal("9wave", "gesture", "beat=beat_right", 1.0, 1.8),
        TimelineSignal("lean", "torso", "torso=lean_forward", 2.0, 3.0),
        TimelineSignal("hello", "speech", "speech=hello there", 2.0, 3.0),
        TimelineSignal("blush", "", "skin=blush", 2.5, 3.0),
    )
    return Timeline("synthetic", 3.0, signals, solver="hand-made", seed=0)


def odd_lexemes_timeline() -> Timeline:
    """Empty, nested, markup and overlong lexemes on every modality: nothing may make a
    realizer reject the block or throw (an empty Greta reference once did)."""
    lexemes = ["", "=", "faceexp=", "a=b=c", "torso=<&>\"'", "gaze=ünïcode", "head=head_", "  spaced  ", "x" * 300]
    modalities = ["face", "head", "gaze", "gesture", "torso", "posture", "speech", "", "smell"]
    signals = tuple(
        TimelineSignal(f"odd{i}-{j}", modality, lexeme, 0.1 * i, 0.1 * i + 0.5)
        for i, lexeme in enumerate(lexemes)
        for j, modality in enumerate(modalities)
    )
    return Timeline("odd", 2.0, signals, solver="hand-made", seed=0)


def build_corpus(shared: Path, folder: Path) -> Corpus:
    """Sample every bundled and imported Greta set with :data:`SEEDS`, export each timeline in
    every variant, and run each parser once over all its files."""
    from mse.api import load, loads
    from mse.export import render
    from mse.resources import bundled_names
    from mse.sampling import sample
    from mse.syntax.greta import import_greta

    greta = shared / "greta"
    imported = import_greta(greta / "lexicon.xml", greta / "constraint.xml")
    sources = [("bundled", name, load(name)) for name in bundled_names()]
    sources += [("imported", e.name, loads(e.xml, path=f"<greta {e.name}>")) for e in imported]

    def playing(model: ir.Model, seed: int) -> Timeline:
        """A timeline of ``seed``, or of the next seeds when it is empty (a set whose signals
        all stayed absent plays nothing: not a case for the parsers)."""
        for attempt in range(10):
            timeline = sample(model, DURATION, seed=seed + 1000 * attempt)
            assert isinstance(timeline, Timeline)
            if timeline.signals:
                break
        return timeline

    timelines = [(kind, name, playing(model, seed)) for kind, name, model in sources for seed in SEEDS]
    timelines.append(("synthetic", "synthetic", synthetic_timeline()))
    timelines.append(("synthetic", "odd", odd_lexemes_timeline()))
    variants = {**asap_variants(greta), **greta_variants(greta)}
    exports: list[Export] = []
    for index, (kind, name, timeline) in enumerate(timelines):
        for variant, (fmt, options) in variants.items():
            text = render(timeline, fmt, options)
            path = folder / variant / f"{index:03d}-{kind}-{name}.xml"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
            exports.append(Export(path, timeline, kind, name, variant, text))
    asap_files = [e.path for e in exports if e.variant in asap_variants(greta)]
    greta_files = [e.path for e in exports if e.variant in greta_variants(greta)]
    run_folder = greta_run_folder(shared, greta, folder / "greta-run")
    native_rows = run_greta_native(shared, run_folder, greta / "lexicon.xml")
    return Corpus(
        exports,
        run_asap(shared, asap_files),
        run_greta(shared, run_folder, greta_files),
        _native_by_signal(greta / "lexicon.xml", native_rows, {e.name for e in imported}),
    )


def _native_by_signal(
    lexicon: Path, rows: dict[tuple[str, int], bool], expressions: set[str]
) -> dict[tuple[str, str], bool]:
    """(imported expression, ``sN``) -> resolved, from GretaNativeControl's rows in file order."""
    from lxml import etree

    found = {}
    for behaviour_set in etree.parse(str(lexicon)).getroot().iter("behaviorset"):
        if behaviour_set.get("type") != "mse":
            continue
        set_name = behaviour_set.get("name") or ""
        emotion = set_name.removeprefix("emotion-")
        if emotion not in expressions:
            emotion = emotion.removesuffix("S")  # emotion-rejoiceS is imported as rejoice (docs/greta.md)
        signals = [s for s in behaviour_set.iter("signal")]
        for position, signal in enumerate(signals, start=1):
            found[(emotion, f"s{int(signal.get('id') or 0)}")] = rows[(set_name, position)]
    return found


# -- measures -----------------------------------------------------------------------------------
@dataclass
class Resolution:
    """Occurrences of one group and how many Greta resolves, per modality."""

    resolved: dict[str, int] = field(default_factory=dict)
    total: dict[str, int] = field(default_factory=dict)

    def add(self, modality: str, ok: bool) -> None:
        self.total[modality] = self.total.get(modality, 0) + 1
        self.resolved[modality] = self.resolved.get(modality, 0) + int(ok)

    def count(self, *, without: tuple[str, ...] = ()) -> tuple[int, int]:
        keys = [m for m in self.total if m not in without]
        return sum(self.resolved[m] for m in keys), sum(self.total[m] for m in keys)


def greta_resolution(corpus: Corpus, variant: str, kind: str) -> Resolution:
    """Per timeline occurrence: does Greta resolve the behaviour written for it?  An occurrence
    left out of the file (a torso Greta lacks) counts as unresolved; a face written as several
    ext:faceFacs counts once, resolved when all of them are."""
    from mse.export.behaviours import plan_behaviours

    result = Resolution()
    for export in corpus.of(variant):
        if export.kind != kind:
            continue
        parsed = corpus.greta[export.path]
        for b in plan_behaviours(export.timeline):
            result.add(b.modality, occurrence_resolved(parsed, b.id))
    return result


def occurrence_resolved(parsed: GretaFile, behaviour_id: str) -> bool:
    """Greta resolves the behaviour (or every ``_auN`` ext:faceFacs) written for one occurrence."""
    pattern = re.compile(rf"{re.escape(behaviour_id)}(_au\d+)?")
    ids = [bid for bid in parsed.signals if pattern.fullmatch(bid)]
    return bool(ids) and all(parsed.signals[bid].resolved for bid in ids)


def native_resolution(corpus: Corpus, variant: str) -> tuple[Resolution, list[str]]:
    """Greta's own MSE path over the same imported occurrences, and every occurrence it resolves
    that the exported BML does not."""
    from mse.export.behaviours import plan_behaviours

    native, worse = Resolution(), []
    for export in corpus.of(variant):
        if export.kind != "imported":
            continue
        parsed = corpus.greta[export.path]
        for b in plan_behaviours(export.timeline):
            ok = corpus.native[(export.expression, b.signal.id)]
            native.add(b.modality, ok)
            if ok and not occurrence_resolved(parsed, b.id):
                worse.append(f"{export.path.name}: {b.signal.id} {b.signal.lexeme}")
    return native, worse
