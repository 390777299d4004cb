"""Fetch the motion data for users who have no copy of the shared data folder.

``python -m data_prep download [--source cmu|hdm05|h36m|bandai] [--dest data/raw] [--mirror URL]
[--accept-license]``

What the manifest (``data_prep/manifest.json``) pins, and why
---------------------------------------------------------------
Every file of the project's reference data folder (the ``../shared/data`` the tests and the
notebooks run on) is listed with its destination (``<source>/...``), size and **sha256 of the
file as it is in that folder**. Those checksums are exact, but only some of the files are
byte-identical to something downloadable from a public URL:

- **CMU**: ``index.tsv`` records the public repository and commit of every clip
  (``github.com/una-dinosauria/cmu-mocap@<commit>:<path>``, B. Hahne's BVH conversion), so the
  manifest gives each clip's raw.githubusercontent.com URL. Our copies are *edited*, though
  (``Frames:`` line rewritten, line endings normalised to LF, and 8 of the 15 clips cut to a
  window of the trial), so the original's checksum is not the pinned one and is not known
  here (``url_sha256`` is empty). Downloading from upstream therefore verifies on first use:
  the sha256 of what was fetched is recorded in ``<dest>/checksums.lock.json`` and every later
  download must match it. The upstream files are the **complete original trials** (e.g.
  16_07 has 423 frames, not our 43-frame excerpt); the ``cmu/index.tsv`` written beside them
  says ``segment = full``, and the catalog reads frame counts from the files. Reproducing the
  excerpts from the originals is out of scope: the window bounds in ``index.tsv`` are only
  known to +-3 frames.
- **Bandai** (CC BY-NC 4.0): our copies are byte-identical to the upstream files, so the
  manifest keeps ``bandai/index.tsv`` (``bandai_index``) with each file's path in the public
  repository and its **git blob SHA-1**; files are fetched from raw.githubusercontent.com at
  the pinned commit (``sources.bandai.commit``) and verified with that hash (what ``git
  hash-object`` prints, and what GitHub's tree lists), and ``bandai/index.tsv`` is written
  beside them. Non-commercial use only: models trained on them inherit that in practice.
- **HDM05** (CC BY-SA 3.0) and **H3.6M** (academic use only): the exact public per-file
  source of these copies is not recorded, so the manifest has no upstream URL for them; the
  command says where to obtain them (``homepage`` in the manifest) and where to put them.
- **Any source, exact copy**: ``--mirror URL`` (or ``$MOCAPVIZ_DATA_MIRROR``) fetches
  ``URL/<dest>`` for every manifest file from a server that holds a copy of the reference data
  folder (a lab server, ``python -m http.server`` on a machine that has it, or a ``file://``
  path) and verifies every file against the pinned sha256.

H3.6M is for academic, non-commercial research only: it is fetched only with
``--accept-license``.

Every file is downloaded to ``<name>.part`` and renamed into place only after its checksum
matched; an interrupted download resumes from the ``.part`` file (HTTP Range), a checksum
mismatch removes the ``.part`` file and raises :class:`ChecksumError` naming the file.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import sys
import urllib.error
import urllib.request
from dataclasses import dataclass
from pathlib import Path

from tqdm.auto import tqdm

from data_prep.sources import REPO_ROOT, SOURCES
from mocapviz.atomic import atomic_path

MANIFEST_PATH = Path(__file__).with_name("manifest.json")
DEFAULT_DEST = REPO_ROOT / "data" / "raw"
LOCK_NAME = "checksums.lock.json"
_CHUNK = 1 << 16


class DownloadError(RuntimeError):
    pass


class ChecksumError(DownloadError):
    pass


class LicenseNotAcceptedError(DownloadError):
    pass


@dataclass(frozen=True)
class Entry:
    source: str
    dest: str          # path relative to the data folder, e.g. "cmu/07/07_01.bvh"
    size: int
    sha256: str        # of the file as in the reference data folder
    url: str = ""      # public upstream URL, "" if none is known
    url_sha256: str = ""  # sha256 of what ``url`` serves, "" if unknown (verify on first use)


def load_manifest(path: str | Path = MANIFEST_PATH) -> dict:
    with open(path, encoding="utf-8") as f:
        man = json.load(f)
    man["entries"] = [Entry(**e) for e in man["files"]]
    return man


def sha256_file(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def git_blob_sha1(path: str | Path) -> str:
    """The file's git blob hash (``git hash-object``): SHA-1 of ``blob <size>\\0`` + content."""
    data = Path(path).read_bytes()
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def download_file(url: str, dest: str | Path, sha256: str | None = None, *, git_sha1: str | None = None,
                  progress: bool = True, timeout: float = 60.0) -> str:
    """Download ``url`` to ``dest`` through ``dest.part``; return the file's sha256.

    A ``.part`` file left by an interrupted download is resumed with an HTTP Range request
    (restarted if the server ignores Range). With ``sha256`` or ``git_sha1`` (git blob hash)
    given, a mismatch deletes the ``.part`` file and raises :class:`ChecksumError`; ``dest``
    is only created on success.
    """
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    part = dest.with_name(dest.name + ".part")
    have = part.stat().st_size if part.is_file() else 0
    req = urllib.request.Request(url, headers={"Range": f"bytes={have}-"} if have else {})
    h = hashlib.sha256()
    try:
        resp = urllib.request.urlopen(req, timeout=timeout)
    except urllib.error.HTTPError as e:
        if e.code == 416 and have:  # nothing left to fetch: the .part file is complete
            resp = None
        else:
            raise DownloadError(f"{dest.name}: HTTP {e.code} {e.reason} for {url}") from None
    except (urllib.error.URLError, OSError) as e:
        raise DownloadError(f"{dest.name}: cannot reach {url}: {getattr(e, 'reason', e)}") from None
    if resp is not None:
        with resp:
            status = getattr(resp, "status", None) or 200
            content_range = resp.headers.get("Content-Range", "")
            resume = bool(have) and status == 206 and content_range.startswith(f"bytes {have}-")
            if not resume:
                have = 0
            length = resp.headers.get("Content-Length")
            total = have + int(length) if length else None
            if resume:
                with open(part, "rb") as f:
                    for chunk in iter(lambda: f.read(1 << 20), b""):
                        h.update(chunk)
            try:
                with open(part, "ab" if resume else "wb") as out, \
                        tqdm(total=total, initial=have, unit="B", unit_scale=True, leave=False,
                             desc=dest.name, disable=not progress) as bar:
                    for chunk in iter(lambda: resp.read(_CHUNK), b""):
                        out.write(chunk)
                        h.update(chunk)
                        bar.update(len(chunk))
            except (urllib.error.URLError, OSError) as e:
                raise DownloadError(f"{dest.name}: download from {url} interrupted ({e}); run the "
                                    f"command again to resume from {part}") from None
        digest = h.hexdigest()
    else:
        digest = sha256_file(part)
    for name, expected, got in (("sha256", sha256, lambda: digest), ("git blob SHA-1", git_sha1,
                                                                     lambda: git_blob_sha1(part))):
        if expected and got() != expected:
            actual = got()
            part.unlink(missing_ok=True)
            raise ChecksumError(f"checksum mismatch for {dest} (from {url}): expected {name} {expected}, "
                                f"got {actual}; the download was discarded")
    os.replace(part, dest)
    return digest


def _read_lock(root: Path) -> dict:
    p = root / LOCK_NAME
    return json.loads(p.read_text()) if p.is_file() else {}


def _write_lock(root: Path, lock: dict) -> None:
    _atomic_write_bytes(root / LOCK_NAME, json.dumps(lock, indent=1, sort_keys=True).encode())


def _cmu_upstream_index(manifest: dict) -> bytes:
    """``cmu/index.tsv`` for the complete upstream trials (segment = full)."""
    buf = io.StringIO()
    cols = ["clip", "subject", "description", "motion_type", "source_path", "segment", "notes"]
    w = csv.DictWriter(buf, cols, delimiter="\t", lineterminator="\n")
    w.writeheader()
    for rec in manifest["cmu_index"]:
        w.writerow({**{k: rec[k] for k in cols[:5]}, "segment": "full",
                    "notes": "complete original trial downloaded from source_path"})
    return buf.getvalue().encode()


def download(sources=None, dest: str | Path = DEFAULT_DEST, *, mirror: str | None = None,
             accept_license: bool = False, force: bool = False, progress: bool = True,
             manifest: dict | None = None) -> dict:
    """Download ``sources`` (default: every source whose license needs no acceptance, plus
    H3.6M when ``accept_license``; Bandai only when named) into ``dest``. Returns {source: [paths written or kept]}.

    Files already present with the expected checksum are kept. Raises
    :class:`LicenseNotAcceptedError` for H3.6M without ``accept_license`` and
    :class:`DownloadError` for a requested source that has no public URL and no ``mirror``
    (without ``sources``, such a source is skipped with a warning).
    """
    manifest = manifest or load_manifest()
    mirror = mirror or os.environ.get("MOCAPVIZ_DATA_MIRROR") or None
    info = manifest["sources"]
    explicit = sources is not None
    if sources is None:
        sources = [s for s in SOURCES if not info[s].get("opt_in")
                   and (accept_license or not info[s]["requires_license_acceptance"])]
    sources = [sources] if isinstance(sources, str) else list(sources)
    for s in sources:
        if s not in info:
            raise DownloadError(f"unknown source {s!r}; choose from {', '.join(SOURCES)}")
        if info[s]["requires_license_acceptance"] and not accept_license:
            raise LicenseNotAcceptedError(
                f"{s}: {info[s]['license']} Pass --accept-license (accept_license=True) to confirm "
                "that you accept these terms.")
    root = Path(dest)
    lock = _read_lock(root)
    done: dict[str, list[Path]] = {}
    for s in sources:
        if s == "bandai":
            done[s] = _download_bandai(manifest, root, mirror, force, progress)
            continue
        entries = [e for e in manifest["entries"] if e.source == s]
        if mirror:
            jobs = [(mirror.rstrip("/") + "/" + e.dest, e, e.sha256) for e in entries]
        else:
            jobs = [(e.url, e, e.url_sha256) for e in entries if e.url]
            if not jobs:
                msg = (
                    f"{s}: no public per-file URL is known for these files. Obtain them from "
                    f"{info[s]['homepage']} and put them under {root / s} (layout: "
                    f"{info[s]['layout']}), or pass --mirror URL of a server holding a copy of "
                    "the reference data folder.")
                if explicit:
                    raise DownloadError(msg)
                print(f"skipped {msg}", file=sys.stderr)
                continue
        written = []
        for url, e, expected in tqdm(jobs, desc=f"download {s}", unit="file", disable=not progress):
            target = root / e.dest
            pinned = expected or (lock.get(e.dest, {}).get("sha256") if not mirror else None)
            if target.is_file() and not force:
                have = sha256_file(target)
                if pinned and have != pinned:
                    raise ChecksumError(f"{target} exists but its sha256 {have} differs from the "
                                        f"expected {pinned}; delete it or pass --force")
                written.append(target)
                continue
            digest = download_file(url, target, pinned, progress=progress)
            if not expected and not mirror:  # verify-on-first-use: remember what we got
                lock[e.dest] = {"sha256": digest, "url": url}
                _write_lock(root, lock)
            written.append(target)
        if s == "cmu" and not mirror:
            _atomic_write_bytes(root / "cmu" / "index.tsv", _cmu_upstream_index(manifest))
            written.append(root / "cmu" / "index.tsv")
        done[s] = written
    return done


def _download_bandai(manifest: dict, root: Path, mirror: str | None, force: bool, progress: bool) -> list[Path]:
    """Every Bandai take of ``bandai_index`` from the pinned upstream commit (or ``mirror``),
    verified by its git blob SHA-1, and ``bandai/index.tsv``."""
    info, index = manifest["sources"]["bandai"], manifest["bandai_index"]
    cols = index["columns"]
    written = []
    for line in tqdm(index["rows"], desc="download bandai", unit="file", disable=not progress):
        rec = dict(zip(cols, line.split("\t")))
        target = root / "bandai" / rec["file"]
        url = (f"{mirror.rstrip('/')}/bandai/{rec['file']}" if mirror else
               f"{info['raw_base']}/{info['repository']}/{info['commit']}/{rec['source_path']}")
        if target.is_file() and not force:
            if git_blob_sha1(target) != rec["git_blob_sha1"]:
                raise ChecksumError(f"{target} exists but its git blob SHA-1 differs from the expected "
                                    f"{rec['git_blob_sha1']}; delete it or pass --force")
        else:
            download_file(url, target, git_sha1=rec["git_blob_sha1"], progress=progress)
        written.append(target)
    text = "".join(line + "\n" for line in ["\t".join(cols)] + index["rows"])
    _atomic_write_bytes(root / "bandai" / "index.tsv", text.encode())
    return written + [root / "bandai" / "index.tsv"]


# --- building the manifest from the reference data folder (maintainers) -------------------

SOURCE_INFO = {
    "hdm05": dict(
        license="HDM05 is licensed CC BY-SA 3.0 Unported.",
        cite="M. Müller, T. Röder, M. Clausen, B. Eberhardt, B. Krüger, A. Weber. Documentation "
             "Mocap Database HDM05. Technical report CG-2007-2, Universität Bonn, 2007.",
        homepage="http://resources.mpi-inf.mpg.de/HDM05/ (the cut AMC files, classes listed in "
                 "hdm05/README.md)",
        layout="<actor>/HDM_<actor>.asf and <actor>/HDM_<actor>_<class>_<NNN>_120.amc",
        requires_license_acceptance=False),
    "cmu": dict(
        license="CMU Graphics Lab Motion Capture Database: free for all uses, do not resell the "
                "data as such; acknowledge mocap.cs.cmu.edu and NSF EIA-0196217.",
        cite="The data used in this project was obtained from mocap.cs.cmu.edu. The database was "
             "created with funding from NSF EIA-0196217.",
        homepage="http://mocap.cs.cmu.edu (BVH conversion by B. Hahne, "
                 "github.com/una-dinosauria/cmu-mocap)",
        layout="<subject>/<subject>_<trial>.bvh and index.tsv",
        requires_license_acceptance=False),
    "h36m": dict(
        license="Human3.6M is for academic, non-commercial research only (Ionescu et al., TPAMI "
                "2014); register and accept its license at http://vision.imar.ro/human36m/.",
        cite="C. Ionescu, D. Papava, V. Olaru, C. Sminchisescu. Human3.6M: Large Scale Datasets and "
             "Predictive Methods for 3D Human Sensing in Natural Environments. TPAMI 36(7), 2014.",
        homepage="http://vision.imar.ro/human36m/ (exp-map text form of Martinez et al. 2017)",
        layout="S<k>/<action>_<subaction>.txt",
        requires_license_acceptance=True),
    "bandai": dict(
        license="Bandai Namco Research Motion Dataset: CC BY-NC 4.0 (non-commercial use, with "
                "attribution); models trained on it inherit that restriction in practice.",
        cite="M. Kobayashi, C.-C. Liao, K. Inoue, S. Yojima, M. Takahashi. Motion Capture Dataset for "
             "Practical Use of AI-based Motion Editing and Stylization. arXiv:2306.08861, 2023.",
        homepage="https://github.com/BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset",
        layout="dataset-1/<file>.bvh, dataset-2/<file>.bvh and index.tsv",
        raw_base="https://raw.githubusercontent.com",
        repository="BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset",
        commit="74ead3ba1ae4696404e6086233779f60de8bf9ef",
        requires_license_acceptance=False,
        opt_in=True),  # 1,256 files, 259 MB: fetched when asked for (--source bandai)
}


def _cmu_url(source_path: str) -> str:
    repo_commit, path = source_path.split(":", 1)
    repo, commit = repo_commit.split("@")
    owner_repo = repo.removeprefix("github.com/")
    return f"https://raw.githubusercontent.com/{owner_repo}/{commit}/{path}"


def build_manifest(data_dir: str | Path) -> dict:
    """Manifest of every file under the source folders of ``data_dir`` (a reference copy)."""
    root = Path(data_dir)
    index = []
    with open(root / "cmu" / "index.tsv", newline="", encoding="utf-8") as f:
        index = [{k: rec[k] for k in ("clip", "subject", "description", "motion_type", "source_path")}
                 for rec in csv.DictReader(f, delimiter="\t")]
    urls = {f"cmu/{r['clip'].split('_')[0]}/{r['clip']}.bvh": _cmu_url(r["source_path"]) for r in index}
    files = []
    for s in (s for s in SOURCES if s != "bandai"):  # Bandai's files are pinned by bandai_index
        for p in sorted((root / s).rglob("*")):
            if p.is_file():
                rel = p.relative_to(root).as_posix()
                files.append(dict(source=s, dest=rel, size=p.stat().st_size, sha256=sha256_file(p),
                                  url=urls.get(rel, ""), url_sha256=""))
    return {"schema": 1,
            "about": "sha256 = the file as in the project's reference data folder; url = public "
                     "upstream file if known; url_sha256 = checksum of the upstream file if known "
                     "(empty: verified on first use). See data_prep/download.py.",
            "sources": SOURCE_INFO, "cmu_index": index, "bandai_index": _bandai_index(root), "files": files}


def _bandai_index(root: Path) -> dict:
    """``bandai/index.tsv`` as its column names and its lines (one string per file: compact)."""
    header, *lines = (root / "bandai" / "index.tsv").read_text(encoding="utf-8").splitlines()
    return {"columns": header.split("\t"), "rows": lines}


def write_manifest(data_dir: str | Path, path: str | Path = MANIFEST_PATH) -> Path:
    man = build_manifest(data_dir)
    _atomic_write_bytes(Path(path), (json.dumps(man, indent=1, ensure_ascii=False) + "\n").encode())
    return Path(path)
