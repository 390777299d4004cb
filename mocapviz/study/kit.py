"""A two-alternative forced-choice study kit (CCNet paper §4.5): videos, questionnaire, key.

``build_kit(pairs, folder, seed)`` writes::

    folder/key.json                    for the analysis only: which model is on which side
    folder/questionnaire/index.html    the page the participant opens (file://, no server)
    folder/questionnaire/criteria.txt  the judging criteria (also shown on the page)
    folder/questionnaire/videos/q01.mp4, q01.gif, ...

Give participants the ``questionnaire`` folder only. The page references its videos relatively,
carries its script inline and loads nothing from the network; it records each choice (left,
right or blank) and the seconds spent on each question, and offers the answers as a JSON file
to download, which :mod:`mocapviz.study.analysis` reads back with the key.

The seed fixes the question order and which clip of each pair is on the left, so the same
pairs and seed rebuild the same kit (and key). Video names (q01, q02, ...) and captions say
nothing about the models.
"""

from __future__ import annotations

import hashlib
import html
import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from mocapviz.motion import Motion
from mocapviz.study.render import PANEL_SIZE, render_pair

# Our wording: the paper's five criteria are in its supplementary material, which we do not have.
CRITERIA = """\
Which motion sequence in the pair is of better motion quality? Judge by these five criteria:

1. Naturalness: the motion looks like a real person moving, not like a machine or a puppet.
2. Smoothness: no jitter, sudden jumps or frozen moments.
3. Contact with the ground: feet do not slide while planted, do not float above or sink into the floor.
4. Physical plausibility: the body keeps its balance and its joints bend only in ways a body can.
5. Type of motion: the movement clearly is the action it is meant to be (walking, jogging, kicking...).

Each question shows two sequences side by side, on a loop. Choose the better one with the
buttons Left or Right, then press Next. You can press Next without choosing, but please answer
every question. Take the time you need."""

MEDIA = (".mp4", ".gif")  # the page shows the mp4 and falls back to the gif if the browser cannot play it


@dataclass(frozen=True)
class Clip:
    """One motion sequence of the study.

    ``item``: an id unique in the study (the same sequence shown in several pairs keeps its id:
    intransitive triads are found on it); ``model``: who made it ("mocap", "ccnet", ...).
    """

    item: str
    model: str
    motion: Motion


@dataclass(frozen=True)
class Pair:
    """A question: ``a`` against ``b`` within ``group``; the group counts how often ``b`` wins
    (in the paper's Table 2 groups ``b`` is the generated clip, in its Table 3 groups CCNet's)."""

    group: str
    a: Clip
    b: Clip


def plan(pairs: list[Pair], seed: int) -> dict:
    """The key: question order and sides drawn with ``numpy.random.default_rng(seed)``.

    Returns ``{"kit", "seed", "questions": [{"id", "group", "left": {"item", "model"},
    "right": {...}, "counted": "left" | "right"}, ...]}`` in presentation order; ``kit`` is a
    hash of the rest, which the page stamps on every response.
    """
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(pairs))
    b_left = rng.random(len(pairs)) < 0.5
    questions = []
    for k, i in enumerate(order):
        p = pairs[i]
        sides = (p.b, p.a) if b_left[i] else (p.a, p.b)
        questions.append(dict(id=f"q{k + 1:02d}", group=p.group,
                              left=dict(item=sides[0].item, model=sides[0].model),
                              right=dict(item=sides[1].item, model=sides[1].model),
                              counted="left" if b_left[i] else "right"))
    kit = hashlib.sha256(json.dumps([seed, questions], sort_keys=True).encode()).hexdigest()[:12]
    return dict(kit=kit, seed=int(seed), questions=questions)


def write_page(folder: str | Path, key: dict, title: str = "Motion quality study", criteria: str = CRITERIA) -> Path:
    """``folder/index.html`` and ``folder/criteria.txt`` for the questions of ``key`` (videos
    expected as ``videos/<id>.mp4`` and ``.gif``); the page gets question ids only, no models."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "criteria.txt").write_text(criteria + "\n")
    questions = [dict(id=q["id"], mp4=f"videos/{q['id']}.mp4", gif=f"videos/{q['id']}.gif") for q in key["questions"]]
    fill = {"TITLE": html.escape(title), "CRITERIA": html.escape(criteria), "KIT": key["kit"],
            # "</" would close the <script> element early
            "QUESTIONS": json.dumps(questions).replace("</", "<\\/")}
    page = resources.files("mocapviz.study").joinpath("questionnaire.html").read_text()
    for name, value in fill.items():
        page = page.replace("{{" + name + "}}", value)
    (folder / "index.html").write_text(page)
    return folder / "index.html"


def build_kit(pairs: list[Pair], folder: str | Path, seed: int = 0, fps: float = 30.0, seconds: float = 4.0,
              panel_size=PANEL_SIZE, title: str = "Motion quality study", criteria: str = CRITERIA,
              progress: bool = True) -> dict:
    """Render every pair side by side (``seconds`` at ``fps``, mp4 and gif), write the
    questionnaire folder and ``folder/key.json``; returns the key (see :func:`plan`)."""
    folder = Path(folder)
    key = plan(pairs, seed)
    by_question = _pairs_in_order(pairs, key)
    page_dir = folder / "questionnaire"
    for q, (left, right) in tqdm(list(zip(key["questions"], by_question)), desc="render pairs", disable=not progress):
        render_pair(left.motion, right.motion, [page_dir / "videos" / f"{q['id']}{ext}" for ext in MEDIA],
                    fps=fps, seconds=seconds, panel_size=panel_size)
    write_page(page_dir, key, title, criteria)
    (folder / "key.json").write_text(json.dumps(key, indent=1) + "\n")
    return key


def _pairs_in_order(pairs: list[Pair], key: dict) -> list[tuple[Clip, Clip]]:
    """(left clip, right clip) of each question of ``key``, found by group and item ids."""
    lookup = {(p.group, c.item, d.item): (c, d) for p in pairs for c, d in ((p.a, p.b), (p.b, p.a))}
    return [lookup[q["group"], q["left"]["item"], q["right"]["item"]] for q in key["questions"]]
