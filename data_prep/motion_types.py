"""Which source class becomes which CCNet motion type (dataset knowledge).

HDM05's 11 classes keep their own type, except where a CMU clip shows the same action: CMU
run joins HDM05's jog (jogLeftCircle), CMU jump joins hopBothLegs, CMU kick joins kickLFront.
CMU walk is its own type (HDM05 has only sneaking steps).

Bandai (keyed by its upstream content label, the catalog's ``description``): walk and both
turning walks are ``walk``: the turn is what the trajectory control c^d already carries (as
for CMU's turning walk 16_27), so a turning-walk type would only split the walk data and could
contradict c^d (a "turn left" type along a path that turns right); the catalog's
``motion_type`` keeps walk-turn-left/right apart for seeds and tables. Bandai run joins CMU run
in ``jog`` (the same action under the same label; their speeds overlap: see the dataset
table), dash (a sprint) is its own type. Side steps left and right are one ``side_step`` (c^d
gives the side), waving with either or both hands ``wave``, raising them ``raise_hand``; the
conversational gestures (bow, bye, byebye, call, guide, respond) are one ``gesture``; kick joins
kick, punch fills the paper's punch type, slash and dance are their own. The style (normal,
elderly, ...) stays in the dataset's clip table, not in c^t.

The vocabulary itself (the meaning of the one-hot c^t) is
:data:`mocapviz.features.motion_types.MOTION_TYPES`.
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
    **{("bandai", c): "walk" for c in ("walk", "walk-turn-left", "walk-turn-right")},
    ("bandai", "run"): "jog",
    ("bandai", "dash"): "dash",
    ("bandai", "walk-back"): "walk_back",
    ("bandai", "walk-left"): "side_step",
    ("bandai", "walk-right"): "side_step",
    **{("bandai", f"wave-{s}"): "wave" for s in ("both-hands", "left-hand", "right-hand")},
    **{("bandai", f"raise-up-{s}"): "raise_hand" for s in ("both-hands", "left-hand", "right-hand")},
    **{("bandai", c): "gesture" for c in ("bow", "bye", "byebye", "call", "guide", "respond")},
    ("bandai", "kick"): "kick",
    ("bandai", "punch"): "punch",
    ("bandai", "slash"): "slash",
    ("bandai", "dance-short"): "dance",
}


def source_label(row) -> str:
    """The label a catalog row is merged by: Bandai's upstream content (``description``; its
    ``motion_type`` groups contents), the source's own class otherwise."""
    return row.description if row.source == "bandai" else row.motion_type


def merged_type(source: str, motion_type: str) -> str:
    """The CCNet motion type of a catalog clip's ``source`` and label (:func:`source_label`)."""
    try:
        return MOTION_TYPE_MERGE[(source, motion_type)]
    except KeyError:
        raise KeyError(f"motion type {motion_type!r} of {source!r} has no merged CCNet type; "
                       "add it to MOTION_TYPE_MERGE") from None
