"""Model files: one ``.npz`` archive (no pickle) with a JSON header under the key ``meta``.

Format ``mse-hsmm/1``: ``meta`` holds the action, style, unit names, skeleton layout and
template scalars; arrays hold the skeleton offsets, template translations and reference
rotations, global variance statistics, variance floor and, per unit, ``unit:{name}:means``,
``:variances``, ``:duration_means``, ``:duration_variances``.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
from typing import Any

import numpy as np

from mse.diagnostics import Diagnostic, MseError, Span
from mse.fileio import write_atomic
from mse.motion.base.bvh import Skeleton
from mse.motion.hsmm.model import HsmmModel, UnitModel
from mse.motion.hsmm.prep import Template

FORMAT = "mse-hsmm/1"
_UNIT_FIELDS = ("means", "variances", "duration_means", "duration_variances")


def model_bytes(model: HsmmModel) -> bytes:
    """The archive bytes of ``model``."""
    template = model.template
    skeleton = template.skeleton
    meta: dict[str, Any] = {
        "format": FORMAT,
        "action": model.action,
        "style": model.style,
        "cyclic": model.cyclic,
        "first_leg": model.first_leg,
        "units": sorted(model.units),
        "info": dict(model.info),
        "skeleton": {
            "names": list(skeleton.names),
            "parents": list(skeleton.parents),
            "channels": [list(c) for c in skeleton.channels],
            "end_sites": [list(e) if e is not None else None for e in skeleton.end_sites],
        },
        "template": {
            "frame_time": template.frame_time,
            "root_joint": template.root_joint,
            "rotated": list(template.rotated),
            "legs": list(template.legs),
            "contacts": [list(c) for c in template.contacts],
            "contact_height": template.contact_height,
        },
    }
    arrays: dict[str, Any] = {
        "meta": np.array(json.dumps(meta, sort_keys=True)),
        "skeleton_offsets": skeleton.offsets,
        "template_translations": template.translations,
        "template_references": template.references,
        "gv_mean": model.gv_mean,
        "gv_var": model.gv_var,
        "variance_floor": model.variance_floor,
    }
    for name, unit in model.units.items():
        for field_name in _UNIT_FIELDS:
            arrays[f"unit:{name}:{field_name}"] = getattr(unit, field_name)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def save_model(path: str | os.PathLike[str], model: HsmmModel) -> None:
    """Write ``model`` atomically to ``path`` (the name is kept as given)."""
    write_atomic(path, model_bytes(model))


def _error(path: str, message: str) -> MseError:
    return MseError([Diagnostic("E100", message, Span(path))])


def load_model(path: str | os.PathLike[str]) -> HsmmModel:
    """Read a model file; missing or malformed files raise MseError (E100)."""
    name = os.fspath(path)
    try:
        with np.load(name, allow_pickle=False) as archive:
            arrays = {key: archive[key] for key in archive.files}
    except FileNotFoundError:
        raise _error(name, "cannot read HSMM model: no such file") from None
    except (OSError, ValueError, zipfile.BadZipFile):
        raise _error(name, "cannot read HSMM model: not an mse-hsmm/1 archive") from None
    try:
        meta = json.loads(str(arrays["meta"]))
        if meta.get("format") != FORMAT:
            raise _error(name, f"not an HSMM model (format {meta.get('format')!r})")
        sk = meta["skeleton"]
        skeleton = Skeleton(
            names=tuple(sk["names"]),
            parents=tuple(int(p) for p in sk["parents"]),
            offsets=np.asarray(arrays["skeleton_offsets"], dtype=np.float64),
            channels=tuple(tuple(c) for c in sk["channels"]),
            end_sites=tuple(
                (float(e[0]), float(e[1]), float(e[2])) if e is not None else None
                for e in sk["end_sites"]
            ),
        )
        tp = meta["template"]
        legs = tuple(int(x) for x in tp["legs"])
        contacts = tuple(tuple(int(x) for x in c) for c in tp["contacts"])
        template = Template(
            skeleton=skeleton,
            frame_time=float(tp["frame_time"]),
            translations=np.asarray(arrays["template_translations"], dtype=np.float64),
            root_joint=int(tp["root_joint"]),
            rotated=tuple(int(x) for x in tp["rotated"]),
            references=np.asarray(arrays["template_references"], dtype=np.float64),
            legs=(legs[0], legs[1]),
            contacts=(contacts[0], contacts[1]),
            contact_height=float(tp["contact_height"]),
        )
        units = {
            unit: UnitModel(
                *(np.asarray(arrays[f"unit:{unit}:{f}"], dtype=np.float64) for f in _UNIT_FIELDS)
            )
            for unit in meta["units"]
        }
        return HsmmModel(
            action=str(meta["action"]),
            style=str(meta["style"]),
            cyclic=bool(meta["cyclic"]),
            units=units,
            template=template,
            gv_mean=np.asarray(arrays["gv_mean"], dtype=np.float64),
            gv_var=np.asarray(arrays["gv_var"], dtype=np.float64),
            variance_floor=np.asarray(arrays["variance_floor"], dtype=np.float64),
            first_leg=str(meta["first_leg"]),
            info=dict(meta.get("info", {})),
        )
    except (KeyError, IndexError, TypeError, ValueError) as error:
        raise _error(name, f"malformed HSMM model: {error!r}") from None
