"""Which HDM05 / CMU motion class becomes which CCNet motion type (dataset knowledge).

HDM05's 11 classes keep their own type, except where a CMU clip shows the same action: CMU
run joins HDM05's jog (jogLeftCircle), CMU jump joins hopBothLegs, CMU kick joins kickLFront.
CMU walk is its own type (HDM05 has only sneaking steps), and CMU punch is kept as a type for
the paper's vocabulary though no clip here carries it. The vocabulary itself (the meaning of
the one-hot c^t) is :data:`mocapviz.features.motion_types.MOTION_TYPES`.
"""

from __future__ import annotations

MOTION_TYPE_MERGE = {
    ("cmu", "walk"): "walk",
    ("cmu", "run"): "jog",
    ("hdm05", "jogLeftCircle4StepsRstart"): "jog",
    ("hdm05", "sneak2StepsLStart"): "sneak",
    ("cmu", "jump"): "hop",
    ("hdm05", "hopBothLegs1hops"): "hop",
    ("cmu", "kick"): "kick",
    ("hdm05", "kickLFront1Reps"): "kick",
    ("cmu", "punch"): "punch",
    ("hdm05", "depositFloorR"): "deposit_floor",
    ("hdm05", "elbowToKnee1RepsLelbowStart"): "elbow_to_knee",
    ("hdm05", "grabHighR"): "grab_high",
    ("hdm05", "lieDownFloor"): "lie_down_floor",
    ("hdm05", "rotateArmsBothBackward1Reps"): "rotate_arms",
    ("hdm05", "squat1Reps"): "squat",
    ("hdm05", "throwBasketball"): "throw_basketball",
}


def merged_type(source: str, motion_type: str) -> str:
    """The CCNet motion type of a catalog clip's ``source`` and ``motion_type``."""
    try:
        return MOTION_TYPE_MERGE[(source, motion_type)]
    except KeyError:
        raise KeyError(f"motion type {motion_type!r} of {source!r} has no merged CCNet type; "
                       "add it to MOTION_TYPE_MERGE") from None
