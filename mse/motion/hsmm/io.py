"""Model files: one ``.npz`` archive (no pickle) with a JSON header under the key ``meta``.

Format ``mse-hsmm/10`` (``info`` lists ``last_units``, the units the clips end on, which a plan
for a length ends on; ``/9`` files plan as before). ``/9``: the template says whether the action is turning locomotion,
``turning``, aligned to its path frame by frame, and ``info`` holds its ``turn_rate``; ``/8``
files load as not turning). ``/8``: ``meta`` names which limbs carry the cycle, ``cycle``: steps, hands or
none, measured from the clips; ``/7`` and before held ``cyclic`` only, and their cyclic models
with flight profiles are steps, the others hands). ``/7``: the layout of ``/4``; wave models have a ``second`` unit, the
return from the rise, whose adapted duration has a tempo of its own; ``/6`` adapted waves
had regression classes by context, the rise and fall with per-joint static blocks; ``/5`` models have up to 500
states per unit, and adapted locomotion models have the root joint's static rotation in a
CMLLR block of its own). ``/4``'s template scalars added the training clips' ``feet_lift`` (``/3``
files load with their standing legs stilled; ``/2`` files load, without flight profiles or
swing-twist roots either; ``/1`` models were
trained with the parity-linked Δ² window and are refused): ``meta`` holds the action,
style, unit names, skeleton layout and
template scalars; arrays hold the skeleton offsets, template translations and reference
rotations, global variance statistics, variance floor and, per unit, ``unit:{name}:means``,
``:variances``, ``:duration_means``, ``:duration_variances`` and, for cyclic actions,
``:carried`` (per state: root velocity, foot lift, support; :mod:`mse.motion.hsmm.carried`).
"""

from __future__ import annotations

import io
import json
import os
import tokenize
import zipfile
import zlib
from typing import Any, cast

import numpy as np

from mse.diagnostics import Diagnostic, MseError, Span
from mse.fileio import write_atomic
from mse.input_files import read_input
from mse.limits import MAX_FRAME_TIME, MAX_MODEL_BYTES, MAX_MOTION_SECONDS, MIN_FRAME_TIME
from mse.motion.base.bvh import Skeleton
from mse.motion.base.cycles import CycleKind
from mse.motion.hsmm.model import HsmmModel, UnitModel
from mse.motion.hsmm.prep import Template

FORMAT = "mse-hsmm/10"
#: formats this version reads (``/2``: no flight profiles, feet always pinned; ``/2`` and
#: ``/3``: no feet lift of the training clips, standing legs always stilled; ``/4`` and
#: ``/5``: the same layout as ``/6``; ``/4`` trained with at most 60 states per unit and
#: adapted with the root joint inside the stream-wide CMLLR blocks; ``/5`` adapted waves
#: with leg classes; ``/6`` waves have no ``second`` unit and play ``inner`` there; ``/8``: no
#: turning locomotion; ``/9``: no ``last_units``, a plan for a length ends where it falls)
READABLE_FORMATS = (
    "mse-hsmm/2", "mse-hsmm/3", "mse-hsmm/4", "mse-hsmm/5", "mse-hsmm/6", "mse-hsmm/7", "mse-hsmm/8",
    "mse-hsmm/9", FORMAT,
)
_UNIT_FIELDS = ("means", "variances", "duration_means", "duration_variances")


def model_bytes(model: HsmmModel) -> bytes:
    """The archive bytes of ``model``."""
    template = model.template
    skeleton = template.skeleton
    meta: dict[str, Any] = {
        "format": FORMAT,
        "action": model.action,
        "style": model.style,
        "cycle": model.cycle,
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
            "twisted_root": template.twisted_root,
            "feet_lift": template.feet_lift,
            "turning": template.turning,
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
        if name in model.carried:
            arrays[f"unit:{name}:carried"] = model.carried[name]
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def save_model(path: str | os.PathLike[str], model: HsmmModel) -> None:
    """Write ``model`` atomically to ``path`` (the name is kept as given)."""
    write_atomic(path, model_bytes(model))


def _cycle(meta: dict[str, Any], carried: bool) -> CycleKind:
    """The model's cycle kind; formats before ``/8`` stored whether it cycles only (steps
    carry the body: their units have ``carried`` profiles)."""
    if "cycle" in meta:
        cycle = str(meta["cycle"])
        if cycle not in ("steps", "hands", "none"):
            raise ValueError(f"unknown cycle kind {cycle!r}")
        return cast(CycleKind, cycle)
    if not meta.get("cyclic"):
        return "none"
    return "steps" if carried else "hands"


def _error(path: str, message: str) -> MseError:
    return MseError([Diagnostic("E100", message, Span(path))])


def _read_arrays(name: str) -> dict[str, Any]:
    """The arrays of an archive: a regular file of at most MAX_MODEL_BYTES whose members
    decompress to at most MAX_MODEL_BYTES together (no zip bomb); no pickle."""
    data = read_input(name, limit=MAX_MODEL_BYTES, what="HSMM model")
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            if sum(member.file_size for member in archive.infolist()) > MAX_MODEL_BYTES:
                raise _error(name, f"HSMM model expands beyond {MAX_MODEL_BYTES} bytes")
            for member in archive.infolist():  # what each header claims, before numpy allocates it
                if member.filename.endswith(".npy") and _claimed_bytes(archive, member) > MAX_MODEL_BYTES:
                    raise _error(name, f"HSMM model array {member.filename[:80]!r} claims more than "
                                 f"{MAX_MODEL_BYTES} bytes")
        with np.load(io.BytesIO(data), allow_pickle=False) as arrays:
            return {key: arrays[key] for key in arrays.files}
    except (OSError, ValueError, EOFError, KeyError, NotImplementedError, zipfile.BadZipFile, zlib.error,
            RecursionError, MemoryError, SyntaxError, TypeError, tokenize.TokenError):
        # (crafted .npy headers: numpy parses them as Python literals)
        raise _error(name, f"cannot read HSMM model: not an {FORMAT} archive (damaged?)") from None


def _claimed_bytes(archive: zipfile.ZipFile, member: zipfile.ZipInfo) -> int:
    """The bytes the .npy header of ``member`` says its array holds."""
    with archive.open(member) as stream:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(stream)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(stream)
    count = 1
    for size in shape:
        count *= int(size)
    return count * max(1, int(dtype.itemsize))


def _check(model: HsmmModel) -> str | None:
    """Why a decoded model cannot be used (sizes, frame time, finite numbers), or None."""
    template = model.template
    skeleton = template.skeleton
    joints = len(skeleton.names)
    if not MIN_FRAME_TIME <= template.frame_time <= MAX_FRAME_TIME:
        return f"frame_time {template.frame_time!r} is outside [{MIN_FRAME_TIME:g}, {MAX_FRAME_TIME:g}] s"
    if not model.units:
        return "the model has no units"
    if not (
        len(skeleton.parents) == len(skeleton.channels) == len(skeleton.end_sites) == joints
        and skeleton.offsets.shape == (joints, 3)
        and all(-1 <= parent < index for index, parent in enumerate(skeleton.parents))
    ):
        return "the skeleton's names, parents, channels and offsets disagree"
    contacts = (*template.contacts[0], *template.contacts[1])
    if not all(0 <= j < joints for j in (template.root_joint, *template.rotated, *template.legs, *contacts)):
        return "the template names a joint the skeleton lacks"
    for unit_name, unit in model.units.items():
        arrays = (unit.means, unit.variances, unit.duration_means, unit.duration_variances)
        states = unit.duration_means.shape[0] if unit.duration_means.ndim == 1 else -1
        if states < 1 or any(a.shape[:1] != (states,) for a in arrays) or unit.means.shape != unit.variances.shape:
            return f"unit {unit_name!r} has inconsistent array shapes"
        if not all(np.isfinite(a).all() for a in arrays) or (unit.variances <= 0).any():
            return f"unit {unit_name!r} holds non-finite numbers or non-positive variances"
        carried = model.carried.get(unit_name)
        if carried is not None and (carried.shape != (states, 4) or not np.isfinite(carried).all()):
            return f"unit {unit_name!r} has a malformed carried profile"
        seconds = float(unit.duration_means.sum()) * template.frame_time
        if (unit.duration_means < 0).any() or seconds > MAX_MOTION_SECONDS:
            return f"unit {unit_name!r} has durations outside [0, {MAX_MOTION_SECONDS:g}] s"
    return None


def load_model(path: str | os.PathLike[str]) -> HsmmModel:
    """Read a model file; missing, damaged or malformed files raise MseError (E100)."""
    name = os.fspath(path)
    arrays = _read_arrays(name)
    try:
        meta = json.loads(str(arrays["meta"]))
        if meta.get("format") not in READABLE_FORMATS:
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
            twisted_root=bool(tp.get("twisted_root", False)),
            feet_lift=float(tp.get("feet_lift", 0.0)),
            turning=bool(tp.get("turning", False)),
        )
        units = {
            unit: UnitModel(
                *(np.asarray(arrays[f"unit:{unit}:{f}"], dtype=np.float64) for f in _UNIT_FIELDS)
            )
            for unit in meta["units"]
        }
        model = HsmmModel(
            action=str(meta["action"]),
            style=str(meta["style"]),
            cycle=_cycle(meta, any(f"unit:{u}:carried" in arrays for u in meta["units"])),
            units=units,
            template=template,
            gv_mean=np.asarray(arrays["gv_mean"], dtype=np.float64),
            gv_var=np.asarray(arrays["gv_var"], dtype=np.float64),
            variance_floor=np.asarray(arrays["variance_floor"], dtype=np.float64),
            first_leg=str(meta["first_leg"]),
            info=dict(meta.get("info", {})),
            carried={
                unit: np.asarray(arrays[f"unit:{unit}:carried"], dtype=np.float64)
                for unit in meta["units"]
                if f"unit:{unit}:carried" in arrays
            },
        )
        problem = _check(model)
    except (KeyError, IndexError, TypeError, ValueError, AttributeError) as error:
        raise _error(name, f"malformed HSMM model: {str(error)[:200]!r}") from None
    except RecursionError:  # the meta JSON nests too deeply
        raise _error(name, "malformed HSMM model: its metadata nests too deeply") from None
    if problem is not None:
        raise _error(name, f"malformed HSMM model: {problem}")
    return model
