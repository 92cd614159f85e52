"""Timelines as ELAN annotation files (EAF 3.0), one tier per modality.

The document follows ELAN's EAF 3.0 schema (``EAFv3.0.xsd``) in its element order:
``HEADER`` (time units in milliseconds, no media; properties ``mse:expression``,
``mse:duration`` in ms, ``mse:seed``, ``lastUsedAnnotationId``), ``TIME_ORDER`` (one time
slot per distinct time, in time order), one ``TIER`` per modality holding
``ALIGNABLE_ANNOTATION`` elements whose value is the signal id, one ``LINGUISTIC_TYPE``
(time-alignable, no constraints) and ELAN's four standard ``CONSTRAINT`` stereotypes.  The
``DATE`` is ``SOURCE_DATE_EPOCH`` when set (reproducible files), else now.

``mse learn`` reads such a file back with the same signal ids and the timeline's duration.
"""

from __future__ import annotations

import datetime
import os

from mse.export.options import ExportOptions
from mse.export.xmltext import Element, document, element
from mse.ir.schedule import to_ticks
from mse.timeline import Timeline

LINGUISTIC_TYPE = "mse-signal"
#: ELAN's standard stereotypes, written by ELAN itself in every file.
_STEREOTYPES = (
    ("Time_Subdivision", "Time subdivision of parent annotation's time interval, no time gaps allowed within "
                         "this interval"),
    ("Symbolic_Subdivision", "Symbolic subdivision of a parent annotation. Annotations refering to the same "
                             "parent are ordered"),
    ("Symbolic_Association", "1-1 association with a parent annotation"),
    ("Included_In", "Time alignable annotations within the parent annotation's time interval, gaps are allowed"),
)


def _date() -> str:
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    moment = (datetime.datetime.fromtimestamp(int(epoch), tz=datetime.UTC) if epoch and epoch.isdigit()
              else datetime.datetime.now(tz=datetime.UTC).replace(microsecond=0))
    return moment.isoformat()


def render_eaf(timeline: Timeline, options: ExportOptions) -> str:
    del options  # nothing to choose: ELAN files have one layout
    times = sorted({to_ticks(s.start) for s in timeline.signals} | {to_ticks(s.stop) for s in timeline.signals})
    slot_of = {time: f"ts{number}" for number, time in enumerate(times, 1)}
    tiers: dict[str, list[Element]] = {}
    for number, signal in enumerate(timeline.signals, 1):
        annotation = element(
            "ANNOTATION", {},
            element("ALIGNABLE_ANNOTATION", {
                "ANNOTATION_ID": f"a{number}",
                "TIME_SLOT_REF1": slot_of[to_ticks(signal.start)],
                "TIME_SLOT_REF2": slot_of[to_ticks(signal.stop)],
            }, element("ANNOTATION_VALUE", {}, signal.id)),
        )
        tiers.setdefault(signal.modality or "signals", []).append(annotation)
    properties = [
        element("PROPERTY", {"NAME": "mse:expression"}, timeline.expression),
        element("PROPERTY", {"NAME": "mse:duration"}, str(to_ticks(timeline.duration))),
    ]
    if timeline.seed is not None:
        properties.append(element("PROPERTY", {"NAME": "mse:seed"}, str(timeline.seed)))
    properties.append(element("PROPERTY", {"NAME": "lastUsedAnnotationId"}, str(len(timeline.signals))))
    children: list[Element] = [
        element("HEADER", {"MEDIA_FILE": "", "TIME_UNITS": "milliseconds"}, *properties),
        element("TIME_ORDER", {}, *(element("TIME_SLOT", {"TIME_SLOT_ID": slot_of[t], "TIME_VALUE": str(t)})
                                    for t in times)),
    ]
    for modality in sorted(tiers):
        children.append(element("TIER", {"LINGUISTIC_TYPE_REF": LINGUISTIC_TYPE, "TIER_ID": modality},
                                *tiers[modality]))
    children.append(element("LINGUISTIC_TYPE", {"GRAPHIC_REFERENCES": "false",
                                                "LINGUISTIC_TYPE_ID": LINGUISTIC_TYPE, "TIME_ALIGNABLE": "true"}))
    children.extend(element("CONSTRAINT", {"DESCRIPTION": text, "STEREOTYPE": name}) for name, text in _STEREOTYPES)
    root = element("ANNOTATION_DOCUMENT", {
        "AUTHOR": "mse",
        "DATE": _date(),
        "FORMAT": "3.0",
        "VERSION": "3.0",
        "xmlns:xsi": "http://www.w3.org/2001/XMLSchema-instance",
        "xsi:noNamespaceSchemaLocation": "http://www.mpi.nl/tools/elan/EAFv3.0.xsd",
    }, *children)
    return document(root)
