"""Which format a command writes when ``-o`` names a file: the file's suffix decides when
``--format`` is not given, and a suffix that names another format than ``--format`` is
refused, so that ``-o a.mp4`` never holds JSON."""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

from mse.diagnostics import MseError, argument_error

#: Suffix -> format for the suffixes that name one format only.  ``.xml`` is left out of the
#: inference (a behaviour set is XML too) but refused for formats that are not XML.
_BY_SUFFIX: dict[str, str] = {
    ".json": "json",
    ".jsonl": "jsonl",
    ".bml": "bml",
    ".svg": "svg",
    ".html": "html",
    ".htm": "html",
    ".eaf": "eaf",
    ".mp4": "mp4",
    ".webm": "webm",
    ".gif": "gif",
    ".openface.csv": "openface",
    ".arkit.csv": "arkit",
    ".arkit.json": "arkit-json",
    ".vrma": "vrma",
}
_XML_FORMATS = ("greta-bml", "bml", "eaf")
#: ``.csv`` alone could be either track format (a double suffix such as ``.arkit.csv`` names one).
_CSV_FORMATS = ("openface", "arkit")


def _error(message: str) -> MseError:
    return argument_error(message)


def output_format(given: str | None, output: str | None, offered: Collection[str]) -> str | None:
    """The format to write: ``given``, or the one ``output``'s suffix names (None: neither
    says, the command's default applies).  MseError when they disagree, or when the suffix
    names a format this command does not offer (``offered``)."""
    if not output or output == "-" or output.endswith(("/", "\\")):
        return given
    suffix = Path(output).suffix.lower()
    named = _BY_SUFFIX.get("".join(Path(output).suffixes[-2:]).lower()) or _BY_SUFFIX.get(suffix)
    if suffix == ".csv" and named is None:
        if given is None:
            raise _error(f"-o {output}: a .csv file could hold several formats; give --format "
                         f"({', '.join(f for f in _CSV_FORMATS if f in offered)})")
        if given not in _CSV_FORMATS:
            raise _error(f"-o {output}: --format {given} is not CSV; name the file for what it holds")
        return given
    if suffix == ".xml":
        if given is None:
            raise _error(f"-o {output}: an .xml file could hold several formats; give --format "
                         f"({', '.join(f for f in _XML_FORMATS if f in offered)})")
        if given not in _XML_FORMATS:
            raise _error(f"-o {output}: --format {given} is not XML; name the file for what it holds")
        return given
    if named is None:
        return given
    if named not in offered:
        raise _error(f"-o {output}: this command does not write {named}")
    if given is not None and given != named and not (given == "json" and named == "jsonl"):
        raise _error(f"-o {output} names {named}, but --format is {given}: drop one, or make them agree")
    return given or named
