"""ASF/AMC reader (the Acclaim/VICON format of CMU and HDM05).

An ASF bone has a rest ``direction`` and ``length`` in the world frame, an ``axis``
(Euler angles and order) defining its local frame C, and ``dof`` channels. An AMC frame
gives dof values M per bone; the bone's rotation in the world-aligned rest frame is
C M C^-1. We build a joint tree where each joint sits where its bone starts (so a joint's
offset is its parent bone's direction * length) and the bone's end becomes a child joint
or an End Site, the layout of the CMU BVH conversions.

Acclaim Euler orders list the first-applied axis first ("XYZ", "rx ry rz" mean
R = Rz @ Ry @ Rx), the reverse of BVH's channel order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mocapviz.errors import MocapFormatError
from mocapviz.io._text import fast_number_table, read_text
from mocapviz.io.axes import to_y_up
from mocapviz.motion import Motion
from mocapviz.rotations import euler_to_matrix
from mocapviz.skeleton import Skeleton

_ROT_DOFS = ("rx", "ry", "rz")
_TRANS_DOFS = ("tx", "ty", "tz")


@dataclass
class AsfBone:
    name: str
    direction: np.ndarray = field(default_factory=lambda: np.zeros(3))
    length: float = 0.0
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis_order: str = "XYZ"
    dof: list[str] = field(default_factory=list)


@dataclass
class AsfSkeleton:
    """Parsed ASF: bones by name, hierarchy, units. Index 0 of ``joint_names`` is root."""

    bones: dict[str, AsfBone]
    children: dict[str, list[str]]
    length_unit: float  # metres per ASF length unit
    angle_in_degrees: bool
    root_order: list[str]
    path: str | None = None
    _axis_cache: dict = field(default_factory=dict, repr=False, compare=False)

    def joint_order(self) -> list[str]:
        order, stack = [], ["root"]
        while stack:
            name = stack.pop()
            order.append(name)
            stack.extend(reversed(self.children.get(name, [])))
        return order

    def axis_matrix(self, name: str) -> np.ndarray:
        """The bone's local frame C (world-from-bone at rest), from ``axis`` and its order."""
        if name not in self._axis_cache:
            self._axis_cache[name] = self._axis_matrix(name)
        return self._axis_cache[name]

    def _axis_matrix(self, name: str) -> np.ndarray:
        bone = self.bones[name]
        angles = bone.axis if self.angle_in_degrees else np.degrees(bone.axis)
        return _acclaim_euler(angles[None], bone.axis_order)[0]

    def to_skeleton(self) -> Skeleton:
        names = self.joint_order()
        index = {n: i for i, n in enumerate(names)}
        parents = np.full(len(names), -1)
        offsets = np.zeros((len(names), 3))
        for parent, kids in self.children.items():
            for kid in kids:
                parents[index[kid]] = index[parent]
                bone = self.bones[parent]
                offsets[index[kid]] = bone.direction * bone.length * self.length_unit
        ends = tuple((index[n], tuple(self.bones[n].direction * self.bones[n].length * self.length_unit))
                     for n in names if n != "root" and not self.children.get(n))
        return Skeleton(tuple(names), parents, offsets, ends)


def _floats(parts, path, lineno, n=None):
    try:
        vals = np.array([float(p) for p in parts])
    except ValueError:
        raise MocapFormatError(path, lineno, f"not a number in {' '.join(parts)!r}") from None
    if n is not None and vals.size != n:
        raise MocapFormatError(path, lineno, f"expected {n} numbers, found {vals.size}")
    if not np.all(np.isfinite(vals)):
        raise MocapFormatError(path, lineno, "value is not finite")
    return vals


def read_asf(path: str | Path, text: str | None = None) -> AsfSkeleton:
    text = read_text(path) if text is None else text
    bones: dict[str, AsfBone] = {"root": AsfBone("root")}
    children: dict[str, list[str]] = {}
    length_value, degrees, root_order = 1.0, True, ["tx", "ty", "tz", "rx", "ry", "rz"]
    section, bone, in_hierarchy = None, None, False
    root_axis = "XYZ"
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        key = parts[0].lower()
        if key.startswith(":"):
            section = key
            if bone is not None:
                raise MocapFormatError(path, lineno, f"bone {bone.name!r} has no 'end'")
            continue
        if section == ":units" and len(parts) == 2:
            if key == "length":
                length_value = _floats(parts[1:], path, lineno, 1)[0]
            elif key == "angle":
                if parts[1].lower() not in ("deg", "rad"):
                    raise MocapFormatError(path, lineno, f"unknown angle unit {parts[1]!r}")
                degrees = parts[1].lower() == "deg"
        elif section == ":root":
            if key == "order":
                root_order = [p.lower() for p in parts[1:]]
                if sorted(root_order) != sorted(_ROT_DOFS + _TRANS_DOFS):
                    raise MocapFormatError(path, lineno, f"bad root order {' '.join(parts[1:])}")
            elif key == "axis":
                root_axis = parts[1].upper() if len(parts) > 1 else "XYZ"
                if sorted(root_axis) != ["X", "Y", "Z"]:
                    raise MocapFormatError(path, lineno, f"bad root axis order {root_axis!r}")
            elif key == "orientation":
                bones["root"].axis = _floats(parts[1:], path, lineno, 3)
        elif section == ":bonedata":
            if key == "begin":
                bone = AsfBone("")
            elif bone is None:
                raise MocapFormatError(path, lineno, f"{parts[0]!r} outside a begin/end block")
            elif key == "end":
                if not bone.name:
                    raise MocapFormatError(path, lineno, "bone without a name")
                bones[bone.name] = bone
                bone = None
            elif key == "name":
                if len(parts) != 2:
                    raise MocapFormatError(path, lineno, "'name' needs one bone name")
                bone.name = parts[1]
            elif key == "direction":
                bone.direction = _floats(parts[1:], path, lineno, 3)
            elif key == "length":
                bone.length = _floats(parts[1:], path, lineno, 1)[0]
            elif key == "axis":
                bone.axis = _floats(parts[1:4], path, lineno, 3)
                bone.axis_order = parts[4].upper() if len(parts) > 4 else "XYZ"
                if sorted(bone.axis_order) != ["X", "Y", "Z"]:
                    raise MocapFormatError(path, lineno, f"bad axis order {bone.axis_order!r}")
            elif key == "dof":
                bone.dof = [p.lower() for p in parts[1:]]
                bad = [d for d in bone.dof if d not in _ROT_DOFS + _TRANS_DOFS + ("l",)]
                if bad:
                    raise MocapFormatError(path, lineno, f"unknown dof {bad[0]!r}")
        elif section == ":hierarchy":
            if key == "begin":
                in_hierarchy = True
            elif key == "end":
                in_hierarchy = False
            elif in_hierarchy:
                for name in parts:
                    if name not in bones:
                        raise MocapFormatError(path, lineno, f"unknown bone {name!r} in hierarchy")
                children.setdefault(parts[0], []).extend(parts[1:])
    bones["root"].axis_order = root_axis
    if bone is not None:
        raise MocapFormatError(path, None, f"bone {bone.name!r} has no 'end' (truncated file?)")
    if in_hierarchy:
        raise MocapFormatError(path, None, "hierarchy has no 'end' (truncated file?)")
    asf = AsfSkeleton(bones, children, 0.0254 / length_value, degrees, root_order, str(path))
    reached = set(asf.joint_order())
    if len(reached) != sum(len(k) for k in children.values()) + 1:
        raise MocapFormatError(path, None, "hierarchy is not a tree rooted at 'root'")
    return asf


def _acclaim_euler(values_deg: np.ndarray, order: str) -> np.ndarray:
    """(F, 3, 3) rotations for 1-3 angles in Acclaim order (first listed applied first)."""
    full = order + "".join(a for a in "XYZ" if a not in order)
    padded = np.zeros((values_deg.shape[0], 3))
    padded[:, :len(order)] = values_deg
    return euler_to_matrix(padded[:, ::-1], full[::-1])


def _parse_amc_frames(text: str, path, bone_dofs: dict[str, int]):
    """Per-bone value arrays (F, n_dof) from AMC text.

    Fast path when every frame repeats the first frame's layout (bone lines in the same
    order), checked and blanked out with vectorised byte comparisons, then each frame is
    joined into one line of numbers that :func:`fast_number_table` parses in C. Anything else (a bad token, an unknown joint,
    another order, truncation, comments) falls back to the line-by-line parse, which
    names the offending line.
    """
    lines = text.split("\n", 200)  # enough to find the header and the first frame
    start = 0
    while start < len(lines) - 1 and (not lines[start].strip() or lines[start].lstrip()[0] in "#:"):
        start += 1
    offset = sum(len(line) + 1 for line in lines[:start])
    values = _parse_amc_fast(text[offset:], lines[start:], bone_dofs)
    if values is not None:
        return values
    return _parse_amc_slow(text.split("\n"), start, path, bone_dofs)


def _parse_amc_fast(body: str, first_lines: list[str], bone_dofs: dict[str, int]):
    if not first_lines or not first_lines[0].strip().isdigit():
        return None
    layout = []
    for line in first_lines[1:]:
        parts = line.split()
        if not parts or parts[0].isdigit():
            break
        n = bone_dofs.get(parts[0])
        if n is None or n == 0 or len(parts) != n + 1 or parts[0] in dict(layout):
            return None
        layout.append((parts[0], n))
    if not layout:
        return None
    try:
        data = body.encode("ascii").rstrip()
    except UnicodeEncodeError:
        return None
    b = np.frombuffer(data, dtype=np.uint8).copy()
    b[b == 13] = 32  # CR -> space
    newlines = np.flatnonzero(b == 10)
    per_frame = len(layout) + 1
    n_frames, rest = divmod(newlines.size + 1, per_frame)
    if rest or n_frames == 0:
        return None
    starts = np.concatenate(([0], newlines + 1)).reshape(n_frames, per_frame)
    for r, (name, _) in enumerate(layout, 1):
        # every frame's line r must start with "<name> "; blank the name out
        expected = np.frombuffer(name.encode() + b" ", dtype=np.uint8)
        if starts[-1, r] + expected.size > b.size:
            return None
        idx = starts[:, r, None] + np.arange(expected.size)
        if not (b[idx] == expected).all():
            return None
        b[idx] = 32
    # join each frame's lines into one line of numbers: keep only newlines before a frame number
    keep = (np.arange(newlines.size) + 1) % per_frame == 0
    b[newlines[~keep]] = 32
    table = fast_number_table(b.tobytes())
    width = 1 + sum(n for _, n in layout)
    if table is None or table.shape != (n_frames, width):
        return None
    frame_no = table[:, 0]
    if frame_no[0] < 0 or not np.array_equal(frame_no, frame_no[0] + np.arange(n_frames)):
        return None  # frame numbers must count up by one (else the slow path decides)
    cols = np.cumsum([1] + [n for _, n in layout])
    return {name: table[:, c:c + n] for c, (name, n) in zip(cols, layout)}, n_frames


def _parse_amc_slow(lines, start, path, bone_dofs):
    """Line-by-line AMC parse with exact error lines (also handles varying layouts)."""
    frames: list[dict[str, np.ndarray]] = []
    frame_lines: list[int] = []
    for i in range(start, len(lines)):
        parts = lines[i].split()
        if not parts:
            continue
        if parts[0][0] in "#:":
            continue
        if len(parts) == 1 and parts[0].isdigit():
            frames.append({})
            frame_lines.append(i + 1)
            continue
        if not frames:
            raise MocapFormatError(path, i + 1, f"expected a frame number, found {parts[0]!r}")
        name = parts[0]
        if name not in bone_dofs:
            raise MocapFormatError(path, i + 1, f"unknown joint {name!r} in AMC frame")
        if name in frames[-1]:
            raise MocapFormatError(path, i + 1, f"joint {name!r} twice in one frame")
        frames[-1][name] = _floats(parts[1:], path, i + 1, bone_dofs[name])
    if not frames:
        raise MocapFormatError(path, len(lines), "no frames in AMC file")
    names = list(frames[0])
    for f, frame in enumerate(frames):
        if set(frame) != set(names):
            missing = [n for n in names if n not in frame]
            what = f"lacks {missing[0]!r}" if missing else f"has {sorted(set(frame) - set(names))[0]!r} " \
                "that the first frame has not"
            raise MocapFormatError(path, frame_lines[f], f"frame {f + 1} {what}"
                                   + (" (truncated file?)" if f == len(frames) - 1 else ""))
    return {n: np.stack([fr[n] for fr in frames]) for n in names}, len(frames)


def read_amc(amc_path: str | Path, asf: AsfSkeleton | str | Path, fps: float = 120.0,
             up: str = "y", text: str | None = None) -> Motion:
    """Read an AMC motion for an ASF skeleton (an :class:`AsfSkeleton` or a path to one), in
    metres; ``up`` is the file's up axis ("y", "z" or "auto"), converted to Y up."""
    if not isinstance(asf, AsfSkeleton):
        asf = read_asf(asf)
    text = read_text(amc_path) if text is None else text
    head = text[:2000].upper()
    degrees = asf.angle_in_degrees if ":RADIANS" not in head else False
    bone_dofs = {name: len(b.dof) for name, b in asf.bones.items()}
    bone_dofs["root"] = len(asf.root_order)
    values, n_frames = _parse_amc_frames(text, amc_path, bone_dofs)

    skeleton = asf.to_skeleton()
    root_positions = np.zeros((n_frames, 3))
    # Group joints by their (padded) Euler order so each order is one batched conversion.
    groups: dict[str, tuple[list[int], list[np.ndarray]]] = {}
    for j, name in enumerate(skeleton.names):
        if name not in values:
            continue
        dofs = asf.root_order if name == "root" else asf.bones[name].dof
        if name == "root":
            root_positions = values[name][:, [dofs.index(d) for d in _TRANS_DOFS]] * asf.length_unit
        rot = [d for d in dofs if d in _ROT_DOFS]
        if not rot:
            continue
        order = "".join(d[1].upper() for d in rot)
        order += "".join(a for a in "XYZ" if a not in order)
        angles = np.zeros((n_frames, 3))
        angles[:, :len(rot)] = values[name][:, [dofs.index(d) for d in rot]]
        groups.setdefault(order, ([], []))
        groups[order][0].append(j)
        groups[order][1].append(angles)

    def rotations() -> np.ndarray:  # evaluated by Motion on first use
        out = np.broadcast_to(np.eye(3), (n_frames, skeleton.n_joints, 3, 3)).copy()
        axes = np.array([asf.axis_matrix(name) for name in skeleton.names])
        for order, (idx, angles) in groups.items():
            stacked = np.stack(angles, axis=1)
            if not degrees:
                stacked = np.degrees(stacked)
            # Acclaim lists the first-applied axis first: R = R[order[2]] R[order[1]] R[order[0]].
            out[:, idx] = euler_to_matrix(stacked[..., ::-1], order[::-1], axes=axes[idx])
        return out
    meta = {"source": str(amc_path), "format": "amc", "asf": asf.path, "length_unit": asf.length_unit}
    return to_y_up(Motion(skeleton, rotations, root_positions, fps, name=Path(str(amc_path)).stem, meta=meta), up)
