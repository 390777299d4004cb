"""Fuzz the readers with mutated real files: each must succeed or raise MocapFormatError.

    python tools/fuzz_readers.py                 # 10,000 mutants per format (bvh, asf, amc, h36m)
    python tools/fuzz_readers.py --n 500 --seed 3

Mutations of short excerpts of real files (CMU and Bandai BVH, an HDM05 ASF and AMC, an
H3.6M exp-map file from the data folder): flip a character, delete or duplicate a line,
truncate, insert a token that readers trip on. Anything other than success or a
MocapFormatError naming the file is a crash; the first few are printed with tracebacks.
The last line printed is a JSON summary. ``tests/test_fuzz_readers.py`` runs the same
mutations through hypothesis, a few hundred per format, in the default test run.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import time
import traceback
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from data_prep.sources import find_data_dir  # noqa: E402
from mocapviz.errors import MocapFormatError  # noqa: E402
from mocapviz.io.asfamc import read_amc, read_asf  # noqa: E402
from mocapviz.io.bvh import read_bvh  # noqa: E402
from mocapviz.io.h36m import read_h36m  # noqa: E402

TOKENS = ["{", "}", "ROOT", "JOINT x", "End Site", "OFFSET", "CHANNELS 3", "CHANNELS 6 Xposition",
          "Xrotation", "MOTION", "Frames: 3", "Frames: -1", "Frame Time: 0", "nan", "inf", "1e999",
          "-", "+", ".", "1_0", "0x1F", "root", "lfemur", "lhand 1 2", "0", "7", ":DEGREES", ":RADIANS",
          "# c", "\t", "\r\n", "\n", "\r", ",", ",,", "begin", "end", "dof rx ry", "axis 0 0 0 ZZZ",
          "length", "name", "direction", "axis", "dof", "limits", "order", "orientation", "position",
          ":bonedata", ":hierarchy", ":root", ":units", "\xe9", "\x00", "1.2.3", "--1"]
OPS = ("flip", "delete_line", "duplicate_line", "truncate", "insert")


def mutate(text: str, ops: list[tuple]) -> str:
    """Apply ``ops``: (op, position in [0, 1), character code, token) tuples, in order."""
    for op, where, code, token in ops:
        if not text:
            break
        if op == "flip":
            i = int(where * len(text))
            text = text[:i] + chr(code) + text[i + 1:]
        elif op in ("delete_line", "duplicate_line"):
            lines = text.split("\n")
            k = int(where * len(lines))
            lines[k:k + 1] = [] if op == "delete_line" else [lines[k], lines[k]]
            text = "\n".join(lines)
        elif op == "truncate":
            text = text[:int(where * (len(text) + 1))]
        else:
            i = int(where * (len(text) + 1))
            sep = " \n"[code % 2] if code % 3 else ""
            text = text[:i] + sep + token + sep + text[i:]
    return text


def random_ops(rng: random.Random) -> list[tuple]:
    return [(rng.choice(OPS), rng.random(), rng.randrange(256), rng.choice(TOKENS))
            for _ in range(rng.randint(1, 3))]


def short_bvh(path: Path, n_frames: int = 4) -> str:
    """The file's header and its first frames, with ``Frames:`` saying so."""
    text = path.read_text()
    head, _, body = text.partition("Frame Time:")
    ft, *frames = body.split("\n")
    frames_line = head[head.index("Frames:"):].split("\n")[0]
    return head.replace(frames_line, f"Frames: {n_frames}") + "Frame Time:" + ft + "\n" + \
        "\n".join(frames[:n_frames]) + "\n"


def short_amc(path: Path) -> str:
    """Header and the first three frames of an AMC file."""
    lines = path.read_bytes().decode("latin-1").split("\n")
    fourth = [i for i, line in enumerate(lines) if line.strip() == "4"][0]
    return "\n".join(lines[:fourth]) + "\n"


def bases(data: Path) -> dict[str, list[str]]:
    cmu = sorted((data / "cmu").glob("*/*.bvh"))[0]
    amc = sorted((data / "hdm05").glob("*/*.amc"))[0]
    h36m = sorted((data / "h36m").glob("S*/*.txt"))[0]
    bvh = [short_bvh(cmu)]
    bandai = sorted((data / "bandai").glob("*/*.bvh"))
    if bandai:
        bvh.append(short_bvh(bandai[0]))
    return {"bvh": bvh, "asf": [(amc.parent / f"HDM_{amc.parent.name}.asf").read_text(encoding="latin-1")],
            "amc": [short_amc(amc)], "h36m": ["\n".join(h36m.read_text().split("\n")[:3]) + "\n"]}


def read_any(kind: str, text: str, base_asf):
    """Read ``text`` as ``kind``; an ASF that parses is also converted and used for an AMC."""
    if kind == "bvh":
        read_bvh("fuzz.bvh", text=text, drop_static_root=True)
    elif kind == "amc":
        read_amc("fuzz.amc", base_asf, text=text)
    elif kind == "asf":
        asf = read_asf("fuzz.asf", text=text)
        asf.to_skeleton()
    else:
        read_h36m("fuzz.txt", text=text)


def run(kind: str, texts: list[str], n: int, rng: random.Random, base_asf, show: int = 3) -> dict:
    counts = {"read": 0, "MocapFormatError": 0, "crash": 0}
    for k in range(n):
        text = mutate(texts[k % len(texts)], random_ops(rng))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                read_any(kind, text, base_asf)
            counts["read"] += 1
        except MocapFormatError as err:
            counts["MocapFormatError" if err.path and err.path in str(err) else "crash"] += 1
        except Exception:  # noqa: BLE001 - anything else is what we are looking for
            counts["crash"] += 1
            if counts["crash"] <= show:
                print(f"--- {kind} crash on mutant {k}:\n{traceback.format_exc()}", file=sys.stderr)
    return counts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10_000, help="mutants per format")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--formats", nargs="*", default=["bvh", "asf", "amc", "h36m"])
    args = ap.parse_args(argv)
    data = find_data_dir()
    texts = bases(data)
    base_asf = read_asf("base.asf", text=texts["asf"][0])
    summary = {}
    for kind in args.formats:
        t = time.perf_counter()
        summary[kind] = run(kind, texts[kind], args.n, random.Random(f"{args.seed}-{kind}"), base_asf)
        print(f"{kind:5s} {summary[kind]}  ({time.perf_counter() - t:.1f} s)")
    print(json.dumps(summary))
    return int(any(c["crash"] for c in summary.values()))


if __name__ == "__main__":
    sys.exit(main())
