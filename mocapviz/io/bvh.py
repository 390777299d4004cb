"""BVH reader and writer.

Supports any rotation channel order per joint, position channels on any joint, End Sites,
tabs and CRLF, and rounded ``Frame Time`` values (1/120 written as 0.008333 reads as 120 fps).
Lengths are converted to metres; the file's unit is stored in ``motion.meta['length_unit']``
(metres per file unit) so that :func:`write_bvh` writes the file back in its own unit.
"""

from __future__ import annotations

import io
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mocapviz.errors import MocapFormatError
from mocapviz.io._text import decode, guess_length_unit, parse_number_lines
from mocapviz.io.axes import to_y_up
from mocapviz.motion import Motion
from mocapviz.rotations import euler_to_matrix, matrix_to_euler
from mocapviz.skeleton import Skeleton

_ROT = {"xrotation": "X", "yrotation": "Y", "zrotation": "Z"}
_POS = {"xposition": 0, "yposition": 1, "zposition": 2}


@dataclass
class _Joint:
    name: str
    parent: int
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    channels: list[str] = field(default_factory=list)
    line: int = 0


def _frame_rate(frame_time: float) -> float:
    """fps from a Frame Time that files round to 6 digits (0.008333 -> 120, 0.033333 -> 30)."""
    fps = 1.0 / frame_time
    nearest = round(fps)
    return float(nearest) if nearest > 0 and abs(fps - nearest) < 1e-3 * nearest else fps


def _offset(parts: list[str], path, lineno: int) -> tuple[float, float, float]:
    if len(parts) != 4:
        raise MocapFormatError(path, lineno, "OFFSET needs 3 numbers")
    try:
        off = (float(parts[1]), float(parts[2]), float(parts[3]))
    except ValueError:
        raise MocapFormatError(path, lineno, f"not a number in OFFSET: {' '.join(parts[1:])}") from None
    if not (math.isfinite(off[0]) and math.isfinite(off[1]) and math.isfinite(off[2])) or "_" in parts[1] + parts[2] + parts[3]:
        raise MocapFormatError(path, lineno, "OFFSET is not a finite number")
    return off


_CHANNEL_LINES: dict[tuple[str, ...], list[str]] = {}  # files repeat a few layouts per joint


def _channels(parts: list[str], path, lineno: int) -> list[str]:
    known = _CHANNEL_LINES.get(tuple(parts))
    if known is not None:
        return list(known)
    try:
        n = int(parts[1])
    except (IndexError, ValueError):
        raise MocapFormatError(path, lineno, "CHANNELS needs a count") from None
    names = [p.lower() for p in parts[2:]]
    if n != len(names) or not all(c in _ROT or c in _POS for c in names):
        raise MocapFormatError(path, lineno, f"bad CHANNELS line: {' '.join(parts[1:])}")
    rot = [c for c in names if c in _ROT]
    if len(rot) not in (0, 3) or len(set(rot)) != len(rot):
        raise MocapFormatError(path, lineno, "a joint needs all three rotation channels or none")
    if len(_CHANNEL_LINES) < 256:
        _CHANNEL_LINES[tuple(parts)] = names
    return list(names)


def _parse_hierarchy(lines: list[str], path) -> tuple[list[_Joint], list[tuple[int, tuple]], int]:
    """Joints, End Sites and the index of the MOTION line. Lines are 0-based here.

    A plain loop over lines keyed on the first word: headers are a few hundred lines, and
    this runs once per file, so it is written to do little per line (no regex, no arrays).
    """
    joints: list[_Joint] = []
    end_sites: list[tuple[int, tuple]] = []
    stack: list[int] = []  # joint index per open brace, -2 for an End Site block
    pending: str | None = None  # a joint name, or "" for an End Site, awaiting "{"
    for i, line in enumerate(lines):
        parts = line.split()
        if not parts:
            continue
        lineno = i + 1
        key = parts[0]
        if key == "{":
            if pending is None:
                raise MocapFormatError(path, lineno, "'{' without ROOT, JOINT or End Site")
            if pending:
                parent = stack[-1] if stack else -1
                if parent == -2:
                    raise MocapFormatError(path, lineno, "joint inside an End Site")
                joints.append(_Joint(pending, parent, line=lineno))
                stack.append(len(joints) - 1)
            else:
                end_sites.append((stack[-1], (0.0, 0.0, 0.0)))
                stack.append(-2)
            pending = None
            continue
        if key == "}":
            if not stack:
                raise MocapFormatError(path, lineno, "unbalanced '}'")
            stack.pop()
            continue
        key = key.upper()
        if key == "OFFSET":
            if not stack:
                raise MocapFormatError(path, lineno, "OFFSET outside a joint")
            if stack[-1] == -2:
                end_sites[-1] = (end_sites[-1][0], _offset(parts, path, lineno))
            else:
                joints[stack[-1]].offset = _offset(parts, path, lineno)
        elif key == "CHANNELS":
            if not stack or stack[-1] == -2:
                raise MocapFormatError(path, lineno, "CHANNELS outside a joint")
            joints[stack[-1]].channels = _channels(parts, path, lineno)
        elif key in ("ROOT", "JOINT"):
            if len(parts) < 2:
                raise MocapFormatError(path, lineno, f"{key} without a name")
            if (key == "ROOT") != (not stack):
                raise MocapFormatError(path, lineno, f"{key} at the wrong nesting depth")
            pending = " ".join(parts[1:])
        elif key == "END":
            if not stack:
                raise MocapFormatError(path, lineno, "End Site outside a joint")
            pending = ""
        elif key == "MOTION":
            if stack or pending is not None:
                raise MocapFormatError(path, lineno, "unbalanced braces before MOTION")
            if not joints:
                raise MocapFormatError(path, lineno, "no ROOT joint in HIERARCHY")
            return joints, end_sites, i
        elif key != "HIERARCHY":
            raise MocapFormatError(path, lineno, f"unexpected {parts[0]!r} in HIERARCHY")
    raise MocapFormatError(path, len(lines), "no MOTION section (truncated file?)")


_MOTION_RE = re.compile(rb"^[ \t]*MOTION[ \t]*\r?$", re.MULTILINE | re.IGNORECASE)
_FRAME_TIME_RE = re.compile(rb"^[ \t]*Frame[ \t]*Time[^\n]*(\n|$)", re.MULTILINE | re.IGNORECASE)
# A file may hold up to this many frame lines (or 1 %) more than its "Frames:" declares:
# exporters miscount by one or two. Fewer lines than declared is what a truncated file
# looks like, and more than a few extra a spliced one: both stay errors.
FRAME_COUNT_SLACK = 5


def _motion_header_end(text: bytes) -> int:
    """Offset just past the "Frame Time" line that follows MOTION (or len(text) if absent)."""
    m = _MOTION_RE.search(text)
    if m is None:
        return len(text)
    ft = _FRAME_TIME_RE.search(text, m.end())
    return len(text) if ft is None else ft.end()


def _header_value(lines: list[str], i: int, key: str, path, cast) -> tuple[object, int]:
    """Value of the ``key:`` line at or after line ``i`` (blank lines skipped) and the next index."""
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines):
        raise MocapFormatError(path, len(lines), f"MOTION section without '{key}:'")
    head, _, value = lines[i].partition(":")
    if " ".join(head.split()).lower() != key.lower():
        raise MocapFormatError(path, i + 1, f"expected '{key}:'")
    try:
        out = cast(value.strip())
    except ValueError:
        raise MocapFormatError(path, i + 1, f"bad {key} value {value.strip()!r}") from None
    if not out > 0:
        raise MocapFormatError(path, i + 1, f"{key} must be positive")
    return out, i + 1


def _check_frame_count(values: np.ndarray, declared: int, path, last_line: int) -> None:
    found = len(values)
    if found == declared:
        return
    if not 0 < found - declared <= max(FRAME_COUNT_SLACK, declared // 100):
        raise MocapFormatError(path, last_line, f"file declares {declared} frames but has {found}"
                               + (" (truncated?)" if found < declared else ""))
    warnings.warn(f"{path}: 'Frames: {declared}' but {found} frame lines; read the {found} frames "
                  "that are there", stacklevel=3)


def read_bvh(path: str | Path, length_unit: float | None = None, up: str = "y",
             drop_static_root: bool = False, text: str | None = None) -> Motion:
    """Read a BVH file into a :class:`Motion` (metres; Y up unless ``up="y"`` keeps a file's
    other axes, see below).

    length_unit: metres per file unit; ``None`` guesses among m, cm, mm, inch and the CMU
    ASF unit by the height of the rest skeleton below its body root (so a reference root or
    a placement OFFSET does not count; the CMU BVH files come out in the CMU unit).
    up: the file's up axis, ``"y"`` (kept as is), ``"z"`` (Blender, 3ds Max: converted to
    Y up) or ``"auto"`` (the axis of Y and Z along which the body is tallest); ``meta['up']``
    records the file's axis and ``meta['axes']`` the conversion applied.
    drop_static_root: fold a root whose channels are constant (a reference node at the
    origin, Bandai's ``joint_Root``) into its only child, which becomes the root.

    Position channels on any joint are applied (they replace that joint's OFFSET on each
    frame); a joint whose position channels only repeat its OFFSET stays rigid.
    """
    raw = Path(path).read_bytes() if text is None else text.encode("utf-8", "surrogateescape")
    # Decode and split only the header (up to "Frame Time"); the frames stay bytes.
    head_end = _motion_header_end(raw)
    lines = decode(raw[:head_end]).split("\n")
    joints, ends, motion_line = _parse_hierarchy(lines, path)
    n_frames, i = _header_value(lines, motion_line + 1, "Frames", path, int)
    frame_time, i = _header_value(lines, i, "Frame Time", path, float)
    block = "\n".join(lines[i:]).encode("utf-8", "surrogateescape") + raw[head_end:]
    n_channels = sum(len(j.channels) for j in joints)
    values = parse_number_lines(block, n_channels, i + 1, path)
    _check_frame_count(values, n_frames, path, i + 1 + block.rstrip().count(b"\n"))
    n_frames = len(values)
    if n_frames == 0:
        raise MocapFormatError(path, i + 1, "no frames")

    n = len(joints)
    names = tuple(j.name for j in joints)
    if len(set(names)) != n:
        dup = next(j for k, j in enumerate(joints) if j.name in names[:k])
        raise MocapFormatError(path, dup.line, f"duplicate joint name {dup.name!r}")
    offsets = np.array([j.offset for j in joints])
    translations = {}
    col = 0
    by_order: dict[str, tuple[list[int], list[list[int]]]] = {}
    for k, joint in enumerate(joints):
        chans = joint.channels
        rot_cols = [col + i for i, c in enumerate(chans) if c in _ROT]
        if rot_cols:
            order = "".join(_ROT[c] for c in chans if c in _ROT)
            by_order.setdefault(order, ([], []))
            by_order[order][0].append(k)
            by_order[order][1].append(rot_cols)
        pos = [(i, c) for i, c in enumerate(chans) if c in _POS]
        if pos:
            trans = np.tile(offsets[k], (n_frames, 1))
            for i, c in pos:
                trans[:, _POS[c]] = values[:, col + i]
            if k == 0 or not (trans == offsets[k]).all():  # channels that repeat OFFSET: rigid
                translations[k] = trans
        col += len(chans)

    def rotations() -> np.ndarray:  # evaluated by Motion on first use
        if len(by_order) == 1 and len(next(iter(by_order.values()))[0]) == n:  # the usual file
            order, (_, cols) = next(iter(by_order.items()))
            return euler_to_matrix(values[:, cols], order)
        out = np.broadcast_to(np.eye(3), (n_frames, n, 3, 3)).copy()
        for order, (idx, cols) in by_order.items():  # one batched conversion per Euler order
            out[:, idx] = euler_to_matrix(values[:, cols], order)
        return out

    parents = np.array([j.parent for j in joints])
    ends = tuple((j, tuple(o)) for j, o in ends)
    if length_unit is None:
        length_unit = guess_length_unit(Skeleton(names, parents, offsets, ends).height_from_bones())
    unit = length_unit
    root = translations.pop(0, np.tile(offsets[0], (n_frames, 1))) * unit
    rest_offsets = offsets * unit
    rest_offsets[0] = 0.0  # the root's place is root_positions
    skeleton = Skeleton(names, parents, rest_offsets,
                        tuple((j, tuple(v * unit for v in off)) for j, off in ends))
    meta = {"source": str(path), "format": "bvh", "length_unit": unit, "frame_time": frame_time,
            "channels": [j.channels for j in joints], "root_offset": offsets[0] * unit,
            "channel_values": values}
    motion = Motion(skeleton, rotations, root, _frame_rate(frame_time), name=Path(str(path)).stem, meta=meta,
                    translations={k: v * unit for k, v in translations.items()})
    if drop_static_root and len(skeleton.children(0)) == 1 and (values[:, :len(joints[0].channels)]
                                                               == values[0, :len(joints[0].channels)]).all():
        motion = motion.fold_root()
    return to_y_up(motion, up)


def _closest_euler(angles: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Of the two Tait-Bryan triples of each rotation, +-360 per angle, the one nearest ``ref``."""
    alt = angles + np.array([180.0, 0.0, 180.0])
    alt[..., 1] = 180.0 - angles[..., 1]
    best = None
    for cand in (angles, alt):
        cand = cand + 360.0 * np.round((ref - cand) / 360.0)
        err = np.abs(cand - ref).max(axis=-1)
        if best is None:
            best, best_err = cand, err
        else:
            take = err < best_err
            best = np.where(take[..., None], cand, best)
    return best


def _fmt(x: float) -> str:
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def write_bvh(motion: Motion, path: str | Path | None = None, length_unit: float | None = None,
              precision: int = 6) -> str:
    """Write ``motion`` as BVH text (and to ``path`` if given); returns the text.

    Channel layouts come from ``motion.meta['channels']`` when the motion was read from BVH,
    else 6 channels on the root and ``Zrotation Yrotation Xrotation`` elsewhere.
    """
    sk = motion.skeleton
    unit = motion.meta.get("length_unit", 1.0) if length_unit is None else length_unit
    channels = motion.meta.get("channels") or [
        (["xposition", "yposition", "zposition"] if j == 0 else []) + ["zrotation", "yrotation", "xrotation"]
        for j in range(sk.n_joints)]
    channels = [list(c) for c in channels]
    for j in motion.translations:  # a moving joint needs position channels to say so
        if not any(c in _POS for c in channels[j]):
            channels[j] = ["xposition", "yposition", "zposition"] + channels[j]
    root_offset = np.asarray(motion.meta.get("root_offset", np.zeros(3)))
    joint_trans = motion.translations
    label = {c: c[0].upper() + c[1:] for c in list(_ROT) + list(_POS)}
    out = io.StringIO()
    out.write("HIERARCHY\n")
    ends_of = {}
    for j, off in sk.end_sites:
        ends_of.setdefault(j, []).append(off)

    def emit(j: int, depth: int):
        pad = "\t" * depth
        kind = "ROOT" if j == 0 else "JOINT"
        off = (root_offset if j == 0 else sk.offsets[j]) / unit
        out.write(f"{pad}{kind} {sk.names[j]}\n{pad}{{\n")
        out.write(f"{pad}\tOFFSET {' '.join(_fmt(v) for v in off)}\n")
        chans = channels[j]
        if chans:
            out.write(f"{pad}\tCHANNELS {len(chans)} {' '.join(label[c] for c in chans)}\n")
        for c in sk.children(j):
            emit(c, depth + 1)
        for off in ends_of.get(j, []):
            out.write(f"{pad}\tEnd Site\n{pad}\t{{\n{pad}\t\tOFFSET "
                      f"{' '.join(_fmt(v / unit) for v in off)}\n{pad}\t}}\n")
        out.write(f"{pad}}}\n")

    emit(0, 0)
    columns = []
    # Angles as read, when the motion still has the file's frames: an unchanged rotation is
    # written with its original angles (wrap-around and gimbal choices kept), a changed one
    # with the Euler triple nearest to them.
    ref_values = motion.meta.get("channel_values")
    n_chan = sum(len(c) for c in channels)
    if ref_values is None or ref_values.shape != (motion.n_frames, n_chan):
        ref_values = None
    col = 0
    for j, chans in enumerate(channels):
        rot = [c for c in chans if c in _ROT]
        euler = None
        if rot:
            order = "".join(_ROT[c] for c in rot)
            euler = matrix_to_euler(motion.rotations[:, j], order)
            if ref_values is not None:
                ref = ref_values[:, [col + chans.index(c) for c in rot]]
                euler = _closest_euler(euler, ref)
                same = np.abs(euler_to_matrix(ref, order) - motion.rotations[:, j]).max(axis=(-1, -2)) < 1e-10
                euler[same] = ref[same]
        col += len(chans)
        trans = motion.root_positions if j == 0 else joint_trans.get(j)
        if trans is None or len(trans) != motion.n_frames:
            trans = np.tile(sk.offsets[j], (motion.n_frames, 1))
        for c in chans:
            columns.append(euler[:, rot.index(c)] if c in _ROT else trans[:, _POS[c]] / unit)
    frame_time = motion.meta.get("frame_time")
    if frame_time is None or abs(1.0 / frame_time - motion.fps) > 1e-3 * motion.fps:
        frame_time = 1.0 / motion.fps
    out.write(f"MOTION\nFrames: {motion.n_frames}\nFrame Time: {frame_time:.6f}\n")
    data = np.stack(columns, axis=1) if columns else np.zeros((motion.n_frames, 0))
    np.savetxt(out, data, fmt=f"%.{precision}f", delimiter=" ")
    text = out.getvalue()
    if path is not None:
        Path(path).write_text(text)
    return text
