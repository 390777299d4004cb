"""Write the six target paths of the trajectory-following test (CCNet §4.3.2) as small JSON files.

    python tools/make_trajectories.py     # -> mocapviz/tasks/trajectories/<name>.json

Each path is drawn in the character's start frame (metres): it starts at the origin heading
+Z (X lateral, +X the character's left), as points every ~0.1 m. ``segments`` are arc-length
fractions where the motion type may change; ``type_seed`` seeds the draw of the segment types
(:func:`mocapviz.tasks.trajectory_following.segment_types`). The paper's six paths are in its
supplementary, which is not available: these are drawn for the purpose with the names the issue
gives. Lengths 12-19 m: 10-15 s at a walk.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent.parent / "mocapviz" / "tasks" / "trajectories"
STEP = 0.1  # m between points


def _line(p, heading, length):
    n = max(1, int(round(length / STEP)))
    d = np.array([np.sin(heading), np.cos(heading)])
    return p + np.outer(np.arange(1, n + 1) * (length / n), d), heading


def _arc(p, heading, radius, angle):
    """Turn by ``angle`` (rad, > 0 left) on a circle of ``radius`` from p heading ``heading``."""
    n = max(2, int(round(abs(angle) * radius / STEP)))
    left = np.array([np.cos(heading), -np.sin(heading)])   # +X at heading 0
    centre = p + np.sign(angle) * radius * left
    a = np.linspace(0, angle, n + 1)[1:]
    h = heading + a
    pts = centre - np.sign(angle) * radius * np.stack([np.cos(h), -np.sin(h)], 1)
    return pts, heading + angle


def build(moves):
    p, h, pts = np.zeros(2), 0.0, [np.zeros((1, 2))]
    for kind, *args in moves:
        seg, h = (_line if kind == "line" else _arc)(p, h, *args)
        pts.append(seg)
        p = seg[-1]
    return np.concatenate(pts)


PATHS = {
    "straight": ([("line", 14.0)], [0, 0.5, 1], 1),
    "s_curve": ([("line", 2.0), ("arc", 2.5, np.pi), ("arc", 2.5, -np.pi), ("line", 2.0)], [0, 0.5, 1], 2),
    "circle": ([("line", 1.0), ("arc", 2.5, 2 * np.pi)], [0, 0.5, 1], 3),
    "figure_eight": ([("arc", 1.6, 2 * np.pi), ("arc", 1.6, -2 * np.pi)], [0, 0.25, 0.5, 0.75, 1], 4),
    "zig_zag": ([("line", 1.0)] + [m for k in range(6) for m in (("arc", 0.6, (1 if k % 2 else -1) * np.pi / 2),
                                                                  ("line", 1.8))], [0, 0.33, 0.67, 1], 5),
    "tight_turns": ([("line", 2.0), ("arc", 0.5, np.pi / 2), ("line", 2.0), ("arc", 0.5, np.pi / 2), ("line", 1.5),
                     ("arc", 0.5, -np.pi / 2), ("line", 2.0), ("arc", 0.5, -np.pi), ("line", 2.0)], [0, 0.5, 1], 6),
}


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for name, (moves, segments, seed) in PATHS.items():
        pts = build(moves)
        length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        doc = dict(name=name, length_m=round(length, 2), segments=segments, type_seed=seed,
                   points=np.round(pts, 3).tolist())
        (OUT / f"{name}.json").write_text(json.dumps(doc, separators=(",", ":")) + "\n")
        print(f"{name}: {len(pts)} points, {length:.1f} m")


if __name__ == "__main__":
    main()
