"""A leading T-pose frame that a converter inserted before the motion (CMU BVH conversions).

B. Hahne's CMU conversions (MotionBuilder- and 3dsMax-friendly) write a T-pose as frame 0 and
the recorded motion after it; the catalog knows this of the CMU files it lists
(``first_frame = 1``). A user's own file carries no such label, so the frame is recognised by
what it is: a pose the body jumps away from, far more than between any two later frames.
"""

from __future__ import annotations

import numpy as np

from mocapviz.motion import Motion

# Frame 0 -> 1 moves some joint (root-relative) this many times more than the largest later
# frame-to-frame move. Measured on the shared data: 11-45x on all 15 CMU files, <= 1.6x on
# Bandai takes and HDM05 clips.
JUMP_RATIO = 5.0


def leading_tpose_frames(motion: Motion) -> int:
    """1 if frame 0 is an inserted pose (a T-pose) the motion jumps away from, else 0."""
    if motion.n_frames < 3:
        return 0
    pos = motion.positions()
    pos = pos - pos[:, :1]  # root-relative: a jump of the pose, not of the character's place
    move = np.linalg.norm(np.diff(pos, axis=0), axis=-1).max(axis=-1)  # (F-1,) largest joint move, m
    return int(move[0] > JUMP_RATIO * max(move[1:].max(), 1e-6))
