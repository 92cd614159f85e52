"""The fuzz harness shared by ``tests/test_fuzz.py`` (hypothesis, in CI) and ``bench/robustness/fuzz.py``
(a longer run, atheris when it is installed).

Targets take raw input and drive mse the way a user does; each enforces the invariants of
issue 13 and raises :class:`FuzzFailure` when one breaks (any other exception is a
traceback, i.e. a bug):

* ``xml_document``: a behaviour-set file -> compile; every diagnostic has a known code and,
  unless the whole file is refused for its size, a line; a model that compiles round-trips
  through the IR JSON, lints, and every timeline the greedy sampler returns passes the one
  checker; exported BML and SVG are well-formed XML.
* ``expression``: constraint text inside a fixed set (same checks).
* ``timeline``: timeline JSON (one, an array or JSON lines) -> check, export, dump and re-read.
* ``bvh``: a motion clip -> ``mse lma`` (exit 0 with strict JSON, or exit 1 with an E-code).
* ``ir_json``: compiled IR JSON -> a model or an MseError.
* ``learn_input``: a CSV/TSV table or ELAN file -> ``mse learn`` (exit 0, or 1 with an E-code;
  the input never overwritten, not even by ``-o`` naming it).
* ``render_input``: timeline JSON and a hostile ``--size`` -> ``mse render`` one PNG (the
  timeline never overwritten).
* ``stdio``: a command writing to an unwritable stdout -> ``<stdout>: E105``, exit 1.

Generators (hypothesis strategies) mutate real documents at the token level and draw
expressions from the grammar, with a dictionary of hostile tokens.  :func:`bounded` runs one
case under a wall-clock alarm and reports its time and the process's peak RSS.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import resource
import signal
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hypothesis import strategies as st
from lxml import etree

from mse.api import compile_source, loads
from mse.diagnostics import CODES, MseError
from mse.ir.anchors import Speech, Word, resolve_anchors, uses_anchors
from mse.ir.canonical import model_dumps
from mse.ir.evaluate import check_schedule
from mse.ir.lint import STATIC_RULES, lint_model
from mse.resources import behaviour_sets_dir
from mse.sampling import sample
from mse.solve.protocol import GreedyOptions, NoSolution
from mse.timeline import Timeline, dumps_jsonl, loads_many

TESTS = Path(__file__).resolve().parent
NAME = "fuzz.xml"


class FuzzFailure(AssertionError):
    """An invariant of issue 13 does not hold for this input."""


class CaseTimeout(BaseException):
    """One case ran past its time bound (a BaseException: no ``except Exception`` eats it)."""


# -- bounds -----------------------------------------------------------------------------------
@dataclass
class Measure:
    seconds: float = 0.0
    peak_rss_kib: int = 0


def peak_rss_kib() -> int:
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


@contextlib.contextmanager
def bounded(seconds: float) -> Iterator[Measure]:
    """Run the body under a wall-clock alarm of ``seconds`` (CaseTimeout when it rings);
    the yielded Measure holds the body's time and the process's peak RSS afterwards."""
    measure = Measure()

    def ring(_signum: int, _frame: object) -> None:
        raise CaseTimeout(f"case ran longer than {seconds} s")

    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    began = time.perf_counter()
    try:
        yield measure
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous if previous is not None else signal.SIG_DFL)
        measure.seconds = time.perf_counter() - began
        measure.peak_rss_kib = peak_rss_kib()


# -- invariants ---------------------------------------------------------------------------------
def _require(condition: bool, message: str) -> None:
    if not condition:
        raise FuzzFailure(message)


def _well_formed(text: str, what: str) -> None:
    try:
        etree.fromstring(text.encode("utf-8"))
    except etree.XMLSyntaxError as error:
        raise FuzzFailure(f"{what} is not well-formed: {error}") from None


def _check_diagnostics(diagnostics: list[Any], path: str) -> None:
    for diagnostic in diagnostics:
        _require(diagnostic.code in CODES, f"unknown code {diagnostic.code}")
        _require(diagnostic.span.path == path, f"diagnostic about {diagnostic.span.path!r}, not {path!r}")
        if diagnostic.is_error and diagnostic.code != "E104":
            _require(diagnostic.span.line >= 1, f"no position: {diagnostic.render()}")


def _exercise_model(model: Any, seed: int) -> None:
    from mse.api import loads_ir

    _require(loads_ir(model_dumps(model), path=NAME) == model, "the IR JSON does not round-trip")
    lint_model(model, STATIC_RULES)
    if len(model.signals) > 12 or len(model.constraints) > 12:
        return  # a solver on a big random set is a performance question, not this one
    if uses_anchors(model):
        try:
            resolve_anchors(model, None)
        except MseError as error:
            _check_diagnostics(error.diagnostics, NAME)
        else:
            _require(False, "anchors without speech were accepted")
        model = resolve_anchors(model, FUZZ_SPEECH)
    try:
        timeline = sample(model, 4.0, seed=seed, greedy=GreedyOptions(max_restarts=3))
    except NoSolution:
        return
    assert isinstance(timeline, Timeline)
    violations = check_schedule(model, timeline.to_schedule())
    _require(not violations, f"the sampler returned an inconsistent timeline: {violations[:2]}")
    _export(timeline)


def _export(timeline: Timeline) -> None:
    from mse.export import ExportOptions, render

    for fmt in ("bml", "svg"):
        _well_formed(render(timeline, fmt, ExportOptions()), fmt)


# -- targets ------------------------------------------------------------------------------------
def xml_document(data: bytes, seed: int = 0) -> None:
    model, diagnostics = compile_source(NAME, data)
    _require(model is not None or any(d.is_error for d in diagnostics), "no model and no error")
    _check_diagnostics(diagnostics, NAME)
    if model is not None:
        _exercise_model(model, seed)


#: The speech anchored constraints are resolved with: two stressed words of three.
FUZZ_SPEECH = Speech(0.5, 3.0, (Word("so", 0.5, 1.0, True), Word("very", 1.0, 2.0), Word("true", 2.0, 3.0, True)))

SIGNALS = (
    '<signal id="a" modality="face" min_duration="0.5" max_duration="3"/>'
    '<signal id="b" modality="head" max_duration="2" probability_start="0.5"/>'
    '<signal id="c" modality="gaze" repetitivity="1" max_occurrences="2" max_duration="1"/>'
)


def wrap_expression(text: str) -> bytes:
    return (
        f'<expression name="fuzz"><signals>{SIGNALS}</signals><constraints>'
        f'<constraint id="k">{text}</constraint></constraints></expression>'
    ).encode("utf-8", errors="surrogatepass")


def expression(text: str, seed: int = 0) -> None:
    xml_document(wrap_expression(text), seed)


_CHECK_MODEL: list[Any] = []


def timeline(text: str, seed: int = 0) -> None:
    if not _CHECK_MODEL:
        _CHECK_MODEL.append(loads((behaviour_sets_dir() / "embarrassment.xml").read_bytes(), path="emb.xml"))
    model = _CHECK_MODEL[0]
    try:
        timelines = loads_many(text, path="t.json")
    except MseError as error:
        _check_diagnostics(list(error.diagnostics), "t.json")
        return
    for item in timelines:
        check_schedule(model, item.to_schedule())
        _export(item)
    # Times are written with 3 decimals (the 1 ms grid): what was written once reads back
    # exactly, whatever the strings hold.
    once = loads_many(dumps_jsonl(timelines), path="t.jsonl")
    _require(loads_many(dumps_jsonl(once), path="t.jsonl") == once, "JSON lines do not read back")


def bvh(data: bytes, seed: int = 0) -> None:
    from mse.cli import main

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "clip.bvh"
        path.write_bytes(data)
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["lma", str(path)])
    if code == 0:
        json.loads(out.getvalue(), parse_constant=lambda name: _require(False, f"{name} in lma JSON"))
    else:
        _require(code == 1 and re.search(r": E\d{3} ", err.getvalue()) is not None, f"exit {code}: {err.getvalue()}")


def ir_json(data: bytes, seed: int = 0) -> None:
    try:
        model = loads(data, path="ir.json")
    except MseError as error:
        for diagnostic in error.diagnostics:
            _require(diagnostic.code in CODES, f"unknown code {diagnostic.code}")
        return
    _exercise_model(model, seed)


def _cli(argv: list[str]) -> tuple[int, str, str]:
    """``mse ARGV`` in this process: exit code, stdout, stderr (argparse's exit is a code)."""
    from mse.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def _refused_with_a_code(code: int, err: str, usage: bool = False) -> None:
    """Exit 1 with an E-code diagnostic (exit 2 too for argument errors when ``usage``)."""
    _require("Traceback" not in err, f"traceback: {err}")
    if code == 2 and usage:
        return
    _require(code == 1 and re.search(r"E\d{3} ", err) is not None, f"exit {code}: {err[-2000:]}")


def learn_input(data: bytes, seed: int = 0) -> None:
    """Annotation files (the first byte picks CSV, TSV or ELAN) -> ``mse learn -o``: exit 0,
    or exit 1 with an E-code; the input is never overwritten, not even by ``-o`` naming it."""
    kind = (".csv", ".tsv", ".eaf")[data[0] % 3] if data else ".csv"
    with tempfile.TemporaryDirectory() as folder:
        source = Path(folder) / f"corpus{kind}"
        source.write_bytes(data[1:])
        target = source if seed % 5 == 0 else Path(folder) / "learned.xml"
        code, _, err = _cli(["learn", folder, "--no-calibrate", "-o", str(target), "-q"])
        _require(source.read_bytes() == data[1:], "the input file was changed")
    if code != 0:
        _refused_with_a_code(code, err)


RENDER_SIZES = ("320x180", "64x48", "16x16", "0320x180", "\uff13\uff12\uff10x180", "99999x99999", "320x")


def render_input(text: str, seed: int = 0) -> None:
    """Timeline JSON -> ``mse render`` one small PNG (the size drawn from hostile ones): a PNG,
    or exit 1 (2 for a bad --size) with an E-code; the timeline file is never overwritten."""
    with tempfile.TemporaryDirectory() as folder:
        source = Path(folder) / "t.json"
        source.write_text(text, encoding="utf-8", errors="surrogatepass")
        before = source.read_bytes()
        size = RENDER_SIZES[seed // 3 % len(RENDER_SIZES)] if seed % 3 == 0 else "320x180"
        target = Path(folder) / ("t.json.png" if seed % 7 else "t.png")
        if seed % 11 == 0:
            target = source.with_suffix(".png")
            source.rename(target)  # then render reads t.png and writes t.png: refused
            source = target
        code, _, err = _cli(["render", str(source), "--size", size, "--at", str(seed % 5), "-o", str(target)])
        if source != target:
            _require(source.read_bytes() == before, "the timeline file was changed")
            if code == 0:
                _require(target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG")
        else:
            _require(code != 0 and source.read_bytes() == before, "render wrote over its input")
    if code != 0:
        _refused_with_a_code(code, err, usage=True)


class _FullStream(io.TextIOBase):
    """A standard output that cannot be written (a full disk, a closed descriptor)."""

    def __init__(self, errno_value: int) -> None:
        self.errno_value = errno_value

    def write(self, text: str) -> int:
        raise OSError(self.errno_value, os.strerror(self.errno_value))

    def fileno(self) -> int:
        raise io.UnsupportedOperation("no descriptor")


STDIO_COMMANDS = (
    ["sample", "anger"], ["sample", "anger", "--stream"], ["sample", "anger", "--count", "3", "--format", "jsonl"],
    ["export", "TIMELINE", "--format", "bml"], ["list"], ["compile", "anger"],
)  # fmt: skip


def stdio(data: bytes, seed: int = 0) -> None:
    """A command writing to an unwritable stdout (ENOSPC, EBADF, EIO): exit 1 with
    ``<stdout>: E105``, never a traceback.  ``data`` picks the command and the error."""
    import errno

    argv = list(STDIO_COMMANDS[(data[0] if data else 0) % len(STDIO_COMMANDS)])
    error = (errno.ENOSPC, errno.EBADF, errno.EIO)[(data[1] if len(data) > 1 else 0) % 3]
    with tempfile.TemporaryDirectory() as folder:
        source = Path(folder) / "t.json"
        source.write_text(seed_timelines()[0], encoding="utf-8")
        argv = [str(source) if a == "TIMELINE" else a for a in argv] + ["--seed", str(seed)] * (argv[0] == "sample")
        err = io.StringIO()
        with contextlib.redirect_stdout(_FullStream(error)), contextlib.redirect_stderr(err):
            from mse.cli import main

            code = main(argv)
    _require(code == 1 and "<stdout>: E105 cannot write output" in err.getvalue(), f"exit {code}: {err.getvalue()}")


_MODEL_ARCHIVES: list[dict[str, bytes]] = []


def seed_model_archive() -> dict[str, bytes]:
    """The members of a real HSMM model file (the starter library's bow, trained once)."""
    if not _MODEL_ARCHIVES:
        import zipfile

        from mse.motion.base.starter import starter_library
        from mse.motion.hsmm import api
        from mse.motion.hsmm.io import save_model

        library = starter_library()
        clips = [(library.motion(c), c.style) for c in library.select(action="bow")][:3]
        with tempfile.TemporaryDirectory() as folder:
            target = Path(folder) / "bow.hsmm"
            save_model(target, api.train_average(clips, "bow", api.Options(states=3)))
            with zipfile.ZipFile(target) as archive:
                _MODEL_ARCHIVES.append({name: archive.read(name) for name in archive.namelist()})
    return _MODEL_ARCHIVES[0]


def model_file(data: bytes, seed: int = 0) -> None:
    """A model file for ``mse style synth``: a real archive with one member replaced by
    ``data`` (or ``data`` alone as the file, for every seventh seed): a clip, or exit 1 with an
    E-code; never a traceback, an allocation the header asks for, or code run from the file."""
    import zipfile

    members = dict(seed_model_archive())
    with tempfile.TemporaryDirectory() as folder:
        model = Path(folder) / "fuzzed.hsmm"
        if seed % 7 == 0:
            model.write_bytes(data)
        else:
            names = sorted(members)
            name = names[seed % len(names)]
            original = members[name]
            cut = seed % (len(original) + 1)
            # the member's head (an .npy header, JSON) or its body replaced by the fuzzed bytes
            if seed % 2:
                members[name] = original[:cut] + data + original[cut + len(data):]
            else:
                members[name] = data + original[len(data):]
            with zipfile.ZipFile(model, "w") as archive:
                for member, content in members.items():
                    archive.writestr(member, content)
        target = Path(folder) / "out.bvh"
        code, _, err = _cli(["style", "synth", str(model), "--duration", "1", "-o", str(target)])
        if code == 0:
            _require(target.read_bytes().startswith(b"HIERARCHY"), "synth wrote something that is not a BVH clip")
            return
        _require(not target.exists(), "a failed synth left its output")
    _refused_with_a_code(code, err, usage=True)


TARGETS: dict[str, Callable[..., None]] = {
    "xml": xml_document,
    "expression": expression,
    "timeline": timeline,
    "bvh": bvh,
    "ir": ir_json,
    "learn": learn_input,
    "render": render_input,
    "stdio": stdio,
    "model": model_file,
}


# -- seeds ----------------------------------------------------------------------------------------
def seed_documents() -> list[bytes]:
    paths = sorted(behaviour_sets_dir().glob("*.xml"))
    for folder in ("valid", "invalid", "lint", "solvers"):
        paths += sorted((TESTS / "fixtures" / folder).glob("*.xml"))
    return [p.read_bytes() for p in paths]


def seed_timelines() -> list[str]:
    return [p.read_text() for p in sorted((TESTS / "fixtures" / "export").glob("*.json"))]


SEED_BVH = (
    "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 95 0\n\tCHANNELS 6 Xposition Yposition Zposition "
    "Zrotation Xrotation Yrotation\n\tJOINT Spine\n\t{\n\t\tOFFSET 0 10 0\n\t\tCHANNELS 3 Zrotation "
    "Xrotation Yrotation\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 10 0\n\t\t}\n\t}\n}\nMOTION\nFrames: 3\n"
    "Frame Time: 0.0333333\n0 95 0 0 0 0 0 0 0\n0 95 1 5 0 0 2 0 0\n0 95 2 10 0 0 4 0 0\n"
)


def seed_ir() -> list[str]:
    return [model_dumps(loads(p.read_bytes(), path=p.name)) for p in sorted(behaviour_sets_dir().glob("*.xml"))[:3]]


# -- hostile tokens -------------------------------------------------------------------------------
HOSTILE_NUMBERS = (
    "1e306", "1e308", "-1e308", "1e400", "1e-400", "NaN", "nan", "inf", "-inf", "Infinity", "1_0", "\u0661",
    "\uff11", "0x10", "1e", ".", "-0", "+1", "1" + "0" * 400, "9" * 5000, "1e20", "1000001", "0.0005", "1e-9",
    "4294967296", "9223372036854775808", "-1", "", " 1 ", "1\u2003", "1e99999999999",
)  # fmt: skip
HOSTILE_TOKENS = (
    "<!--", "-->", "<?x?>", "<?", "<![CDATA[", "]]>", "&lt;", "&gt;", "&amp;", "&#13;", "&#0;", "&#x110000;",
    "&i;", "\r", "\r\n", "\t", "\x00", "\x01", "\ufeff", "\ud800", "\u2028", "\u0085", "\ufffe",
    '<!DOCTYPE x [<!ENTITY i "x">]>', "<!DOCTYPE x [<!-- ] --><!ENTITY i 'x'>]>", "<!DOCTYPE x SYSTEM 'x.dtd'>",
    "<!ENTITY", "[a]" * 30, "<!--" * 50, "(" * 300, ")" * 300, "not " * 300, " and exists(a)" * 200,
    "<", ">", "=", "'", '"', "/>", "</signal>", "<signal id='z' modality='face'/>", "<constraint>",
    "</constraints>", "<motion action='jig'/>", " exclusive='true'", " repetitivity='1'", " max_occurrences='3'",
    "exists(", "includes(a,", "start(a)", "stop(b)", "duration", "implies", "or", "and", "not", "<=", ">=",
    "equal(start(a), stop(b), ", "lessthan(", "morethan(", "-", "+", ",",
    "speech.start", "speech.stop", "stressed", "stressed.stop", "speech.", "stressed.",
)  # fmt: skip
_TOKEN = re.compile(r"<[^<>]{0,200}>|&[#\w]{1,12};|[0-9][0-9.eE+-]*|\w+|\s+|.", re.DOTALL)


def tokens(text: str) -> list[str]:
    return _TOKEN.findall(text)


@st.composite
def mutated(draw: st.DrawFn, seeds: list[str], extra: tuple[str, ...] = ()) -> str:
    """A seed text with 1-8 token-level mutations (delete, duplicate, swap, insert or replace
    with a hostile token or number)."""
    parts = tokens(draw(st.sampled_from(seeds)))
    pool = HOSTILE_TOKENS + HOSTILE_NUMBERS + extra
    for _ in range(draw(st.integers(1, 8))):
        if not parts:
            parts.append(draw(st.sampled_from(pool)))
            continue
        index = draw(st.integers(0, len(parts) - 1))
        action = draw(st.sampled_from(("delete", "duplicate", "swap", "insert", "replace", "number")))
        if action == "delete":
            del parts[index]
        elif action == "duplicate":
            parts.insert(index, parts[index] * draw(st.sampled_from((1, 2, 50))))
        elif action == "swap":
            other = draw(st.integers(0, len(parts) - 1))
            parts[index], parts[other] = parts[other], parts[index]
        elif action == "insert":
            parts.insert(index, draw(st.sampled_from(pool)))
        elif action == "replace":
            parts[index] = draw(st.sampled_from(pool))
        else:
            numbers = [i for i, part in enumerate(parts) if part[:1].isdigit()]
            target = numbers[index % len(numbers)] if numbers else index
            parts[target] = draw(st.sampled_from(HOSTILE_NUMBERS))
    return "".join(parts)


@st.composite
def documents(draw: st.DrawFn) -> bytes:
    text = draw(mutated([d.decode("utf-8", errors="replace") for d in seed_documents()]))
    encoding = draw(st.sampled_from(("utf-8", "utf-8", "utf-8", "utf-16", "latin-1")))
    if encoding == "utf-16" and draw(st.booleans()):
        text = text.replace('encoding="UTF-8"', 'encoding="UTF-16"')
    return text.encode(encoding, errors="surrogatepass" if encoding == "utf-8" else "replace")


_NAMES = st.sampled_from(("a", "b", "c", "a", "b", "zz", "A", "_"))
_NUMBERS = st.one_of(
    st.integers(0, 20).map(str),
    st.floats(0, 100, allow_nan=False).map(lambda v: f"{v:.3f}"),
    st.sampled_from(HOSTILE_NUMBERS),
)


def _term() -> st.SearchStrategy[str]:
    offset = st.tuples(st.sampled_from(("+", "-")), _NUMBERS).map(lambda p: f" {p[0]} {p[1]}")
    edge = st.tuples(st.sampled_from(("start", "stop")), _NAMES, st.lists(offset, max_size=2))
    anchor = st.sampled_from(("speech.start", "speech.stop", "stressed", "stressed.start", "stressed.stop"))
    return st.one_of(
        edge.map(lambda e: f"{e[0]}({e[1]}){''.join(e[2])}"),
        st.lists(offset, max_size=2).map(lambda o: "duration" + "".join(o)),
        st.tuples(anchor, st.lists(offset, max_size=2)).map(lambda a: a[0] + "".join(a[1])),
        _NUMBERS,
    )


def _atom() -> st.SearchStrategy[str]:
    relation = st.sampled_from(("includes", "excludes", "precedes", "rightincludes"))
    compare = st.sampled_from(("&lt;", "&gt;", "=", "&lt;=", "&gt;=", "<![CDATA[<]]>"))
    return st.one_of(
        _NAMES.map(lambda n: f"exists({n})"),
        st.tuples(relation, _NAMES, _NAMES).map(lambda r: f"{r[0]}({r[1]}, {r[2]})"),
        st.tuples(_term(), compare, _term()).map(lambda c: f"{c[0]} {c[1]} {c[2]}"),
        st.tuples(st.sampled_from(("lessthan", "morethan")), _term(), _term()).map(lambda c: f"{c[0]}({c[1]}, {c[2]})"),
        st.tuples(_term(), _term(), st.one_of(st.just(""), _NUMBERS.map(lambda n: f", {n}"))).map(
            lambda e: f"equal({e[0]}, {e[1]}{e[2]})"
        ),
    )


_GAPS = st.sampled_from((" ", " ", " ", "\n", "\r\n", "\r", "\t", " <!-- c --> ", " <?pi x?> ", "&#32;"))


def expressions() -> st.SearchStrategy[str]:
    """Constraint text drawn from the grammar, with XML-level noise between tokens."""

    def extend(inner: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
        return st.one_of(
            st.tuples(inner, st.sampled_from(("and", "or", "implies")), inner, _GAPS).map(
                lambda p: f"{p[0]}{p[3]}{p[1]}{p[3]}{p[2]}"
            ),
            inner.map(lambda e: f"not {e}"),
            inner.map(lambda e: f"({e})"),
        )

    grammar = st.recursive(_atom(), extend, max_leaves=12)
    return st.one_of(grammar, st.tuples(grammar, st.sampled_from(HOSTILE_TOKENS)).map(lambda p: p[0] + p[1]))


_JSON_HOSTILE: tuple[Any, ...] = (
    1e308, -1e308, 0, -1, 0.0004, 1e6, 1e6 + 1, None, True, "", [], {}, "x" * 1000, "\u0001", "\u2028",
    "a\u0085b", 10**30, [[[[[]]]]], {"file": "/dev/zero"}, {"file": "a\u0000b"},
)  # fmt: skip


@st.composite
def timelines(draw: st.DrawFn) -> str:
    """Valid timelines with hostile values put in, as one object, an array or JSON lines
    (with blank lines), or their text mutated at the token level."""
    obj = json.loads(draw(st.sampled_from(seed_timelines())))
    for _ in range(draw(st.integers(0, 4))):
        key = draw(st.sampled_from(("duration", "expression", "signals", "format", "seed", "extra")))
        signals = obj.get("signals") if isinstance(obj.get("signals"), list) else []
        if signals and draw(st.booleans()):
            entry = signals[draw(st.integers(0, len(signals) - 1))]
            if isinstance(entry, dict):
                field = draw(st.sampled_from(("id", "start", "stop", "lexeme", "modality", "motion")))
                entry[field] = draw(st.sampled_from(_JSON_HOSTILE))
        else:
            obj[key] = draw(st.sampled_from(_JSON_HOSTILE))
    shape = draw(st.sampled_from(("one", "array", "lines", "text", "deep")))
    if shape == "array":
        return json.dumps([obj, obj])
    if shape == "lines":
        return "\n" + json.dumps(obj, ensure_ascii=False) + "\n\n" + json.dumps(obj) + "\n"
    if shape == "text":
        return draw(mutated([json.dumps(obj, indent=1)], extra=("[" * 2000, "1" * 5000, "NaN", "\\ud800")))
    if shape == "deep":
        return "[" * draw(st.sampled_from((10, 499, 501, 5000, 100_000)))
    return json.dumps(obj, ensure_ascii=draw(st.booleans()))


@st.composite
def bvh_texts(draw: st.DrawFn) -> bytes:
    text = draw(mutated([SEED_BVH], extra=("Frames:", "Frame Time:", "JOINT", "End Site", "{", "}", "CHANNELS 3")))
    return text.encode("utf-8", errors="surrogatepass")


@st.composite
def ir_texts(draw: st.DrawFn) -> bytes:
    text = draw(mutated(seed_ir(), extra=('"signals": 1.5', '"text": "', '"format": "mse-ir/1"', "[" * 1000)))
    return text.encode("utf-8", errors="surrogatepass")


SEED_TABLE = "sequence,tier,start,stop,label\n" + "".join(
    f"s{i},face,{i % 3}.5,{i % 3 + 2},smile\ns{i},gaze,0,1.25,look down\n" for i in range(12)
)
SEED_EAF = (
    '<?xml version="1.0" encoding="UTF-8"?>\n<ANNOTATION_DOCUMENT AUTHOR="f" FORMAT="2.7" VERSION="2.7">\n'
    '<HEADER MEDIA_FILE="" TIME_UNITS="milliseconds"><PROPERTY NAME="mse:duration">4000</PROPERTY></HEADER>\n'
    '<TIME_ORDER><TIME_SLOT TIME_SLOT_ID="ts1" TIME_VALUE="200"/><TIME_SLOT TIME_SLOT_ID="ts2" TIME_VALUE="1500"/>'
    "</TIME_ORDER>\n"
    '<TIER LINGUISTIC_TYPE_REF="lt" TIER_ID="Face"><ANNOTATION><ALIGNABLE_ANNOTATION ANNOTATION_ID="a1" '
    'TIME_SLOT_REF1="ts1" TIME_SLOT_REF2="ts2"><ANNOTATION_VALUE>smile</ANNOTATION_VALUE>'
    "</ALIGNABLE_ANNOTATION></ANNOTATION></TIER>\n</ANNOTATION_DOCUMENT>\n"
)


@st.composite
def learn_texts(draw: st.DrawFn) -> bytes:
    """A CSV/TSV table or an ELAN file mutated at the token level; the first byte picks the kind."""
    kind = draw(st.integers(0, 2))
    seed = SEED_EAF if kind == 2 else SEED_TABLE.replace(",", "\t") if kind == 1 else SEED_TABLE
    extra = ("9" * 19, "7200", "7200000", "\u00b2", "x" * 5000, ",", "\t", "\n", '"', "s1", "TIME_VALUE")
    text = draw(mutated([seed], extra=extra))
    return bytes([kind]) + text.encode("utf-8", errors="surrogatepass")


@st.composite
def stdio_cases(draw: st.DrawFn) -> bytes:
    return bytes([draw(st.integers(0, len(STDIO_COMMANDS) - 1)), draw(st.integers(0, 2))])


def model_bytes() -> st.SearchStrategy[bytes]:
    """Bytes for a model archive's member: random, or the headers that broke numpy's reader."""
    crafted = st.sampled_from([
        b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, 'shape': (1099511627776,), }",
        b"\x93NUMPY\x01\x00v\x00{'descr': " + b"(" * 3000,
        b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, 'shape': (1, ",
        b"[" * 100_000, b"{}", b"\x80\x04\x95",  # the last: a pickle's opening bytes
    ])
    return st.one_of(crafted, st.binary(max_size=2048))


STRATEGIES: dict[str, st.SearchStrategy[Any]] = {
    "xml": documents(),
    "expression": expressions(),
    "timeline": timelines(),
    "bvh": bvh_texts(),
    "ir": ir_texts(),
    "learn": learn_texts(),
    "render": timelines(),
    "stdio": stdio_cases(),
    "model": model_bytes(),
}
