"""Downloads against a local HTTP server (127.0.0.1, port 0) serving real files of the data."""

from __future__ import annotations

import csv
import hashlib
import json
import re
import shutil
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from data_prep import cli
from data_prep.catalog import build_catalog
from data_prep.download import (LOCK_NAME, ChecksumError, DownloadError, LicenseNotAcceptedError,
                                download, download_file, load_manifest)
from data_prep.sources import DataNotFoundError, find_data_dir

try:
    DATA = find_data_dir(source="cmu")
except DataNotFoundError as e:
    pytest.skip(str(e), allow_module_level=True)

MANIFEST = load_manifest()
BY_DEST = {e.dest: e for e in MANIFEST["entries"]}


class RangeHandler(BaseHTTPRequestHandler):
    """Serves files under ``root``; honours ``Range: bytes=N-`` unless ``ranges`` is False."""

    def __init__(self, *a, root: Path, log: list, ranges: bool, **kw):
        self.root, self.log, self.ranges = root, log, ranges
        super().__init__(*a, **kw)

    def do_GET(self):
        self.log.append((self.path, self.headers.get("Range")))
        path = self.root / self.path.lstrip("/")
        if not path.is_file():
            self.send_error(404)
            return
        body = path.read_bytes()
        m = re.fullmatch(r"bytes=(\d+)-", self.headers.get("Range") or "")
        if m and self.ranges:
            start = int(m[1])
            if start >= len(body):
                self.send_error(416)
                return
            self.send_response(206)
            self.send_header("Content-Range", f"bytes {start}-{len(body) - 1}/{len(body)}")
            body = body[start:]
        else:
            self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture
def server(tmp_path):
    """(base URL, served folder, request log, settings) of a server on 127.0.0.1."""
    root = tmp_path / "served"
    root.mkdir()
    log, settings = [], {"ranges": True}

    def handler(*a, **kw):
        return RangeHandler(*a, root=root, log=log, ranges=settings["ranges"], **kw)

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}", root, log, settings
    httpd.shutdown()
    httpd.server_close()
    thread.join(5)


def _serve(root: Path, dest: str, src: str | None = None) -> Path:
    """Copy the real file ``src`` (default ``dest``) of the data folder to ``root/dest``."""
    target = root / dest
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(DATA / (src or dest), target)
    return target


CLIP = "cmu/07/07_01.bvh"


def test_manifest_pins_the_reference_files():
    entries = MANIFEST["entries"]
    on_disk = sorted(p.relative_to(DATA).as_posix() for s in ("hdm05", "cmu", "h36m")
                     for p in (DATA / s).rglob("*") if p.is_file())
    assert sorted(e.dest for e in entries) == on_disk
    for dest in (CLIP, "cmu/index.tsv", "hdm05/bd/HDM_bd.asf", "h36m/S5/walking_1.txt"):
        assert hashlib.sha256((DATA / dest).read_bytes()).hexdigest() == BY_DEST[dest].sha256
        assert (DATA / dest).stat().st_size == BY_DEST[dest].size
    with open(DATA / "cmu" / "index.tsv", newline="") as f:
        for r in csv.DictReader(f, delimiter="\t"):
            e = BY_DEST[f"cmu/{r['clip'].split('_')[0]}/{r['clip']}.bvh"]
            repo_commit, path = r["source_path"].split(":")
            commit = repo_commit.split("@")[1]
            assert e.url == f"https://raw.githubusercontent.com/una-dinosauria/cmu-mocap/{commit}/{path}"
            assert e.url_sha256 == ""  # our copies are edited: the original's checksum is unknown
    assert not any(e.url for e in entries if e.source in ("hdm05", "h36m"))
    assert MANIFEST["sources"]["h36m"]["requires_license_acceptance"]


def test_download_file_success(server, tmp_path):
    base, root, log, _ = server
    _serve(root, CLIP)
    dest = tmp_path / "out" / "07_01.bvh"
    digest = download_file(f"{base}/{CLIP}", dest, BY_DEST[CLIP].sha256, progress=False)
    assert digest == BY_DEST[CLIP].sha256
    assert dest.read_bytes() == (DATA / CLIP).read_bytes()
    assert not dest.with_name("07_01.bvh.part").exists()
    assert log == [(f"/{CLIP}", None)]


def test_checksum_mismatch_leaves_nothing(server, tmp_path):
    base, root, _, _ = server
    _serve(root, CLIP, src="cmu/08/08_09.bvh")  # the wrong real file behind the right name
    dest = tmp_path / "out" / "07_01.bvh"
    with pytest.raises(ChecksumError, match=r"07_01\.bvh.*expected sha256 " + BY_DEST[CLIP].sha256):
        download_file(f"{base}/{CLIP}", dest, BY_DEST[CLIP].sha256, progress=False)
    assert list((tmp_path / "out").iterdir()) == []


@pytest.mark.parametrize("ranges", [True, False])
def test_resume_partial_file(server, tmp_path, ranges):
    base, root, log, settings = server
    settings["ranges"] = ranges
    _serve(root, CLIP)
    original = (DATA / CLIP).read_bytes()
    dest = tmp_path / "out" / "07_01.bvh"
    dest.parent.mkdir()
    half = len(original) // 2
    dest.with_name("07_01.bvh.part").write_bytes(original[:half])  # an interrupted download
    assert download_file(f"{base}/{CLIP}", dest, BY_DEST[CLIP].sha256, progress=False) == BY_DEST[CLIP].sha256
    assert dest.read_bytes() == original
    assert log == [(f"/{CLIP}", f"bytes={half}-")]  # asked only for the rest (restarts if ignored)
    assert not dest.with_name("07_01.bvh.part").exists()


def test_resume_of_complete_part_file(server, tmp_path):
    base, root, log, _ = server
    _serve(root, CLIP)
    dest = tmp_path / "07_01.bvh"
    dest.with_name("07_01.bvh.part").write_bytes((DATA / CLIP).read_bytes())
    download_file(f"{base}/{CLIP}", dest, BY_DEST[CLIP].sha256, progress=False)  # server: 416
    assert dest.read_bytes() == (DATA / CLIP).read_bytes()


def test_mirror_download_of_cmu_gives_the_same_catalog(server, tmp_path):
    base, root, log, _ = server
    (root / "cmu").symlink_to(DATA / "cmu", target_is_directory=True)
    out = tmp_path / "raw"
    done = download("cmu", out, mirror=base, progress=False)
    cmu_entries = [e for e in MANIFEST["entries"] if e.source == "cmu"]
    assert len(done["cmu"]) == len(cmu_entries) == 18 and len(log) == 18
    assert not list(out.rglob("*.part"))
    ours = build_catalog(out, cache=False)
    ref = build_catalog(DATA, cache=False)
    ref = ref[ref.source == "cmu"]
    assert ours[["clip", "frames", "segment", "trainable"]].values.tolist() == \
        ref[["clip", "frames", "segment", "trainable"]].values.tolist()
    download("cmu", out, mirror=base, progress=False)  # everything present and verified: no requests
    assert len(log) == 18


def test_upstream_download_verifies_on_first_use(server, tmp_path):
    base, root, log, _ = server
    _serve(root, "upstream/07_01.bvh", src=CLIP)
    entry = BY_DEST[CLIP]
    man = {**MANIFEST, "entries": [type(entry)(**{**entry.__dict__, "url": f"{base}/upstream/07_01.bvh"})]}
    out = tmp_path / "raw"
    download("cmu", out, manifest=man, progress=False)
    lock = json.loads((out / LOCK_NAME).read_text())
    assert lock[CLIP]["sha256"] == entry.sha256  # the file served here is our copy
    index = (out / "cmu" / "index.tsv").read_text().splitlines()
    assert index[0].split("\t")[:6] == ["clip", "subject", "description", "motion_type", "source_path", "segment"]
    assert len(index) == 16 and all(l.split("\t")[5] == "full" for l in index[1:])
    # upstream now serves something else: the recorded checksum catches it
    _serve(root, "upstream/07_01.bvh", src="cmu/08/08_09.bvh")
    with pytest.raises(ChecksumError, match="07_01.bvh"):
        download("cmu", out, manifest=man, progress=False, force=True)
    assert (out / CLIP).read_bytes() == (DATA / CLIP).read_bytes()  # the good copy is untouched


def test_h36m_needs_license_acceptance(server, tmp_path, capsys):
    base, root, log, _ = server
    with pytest.raises(LicenseNotAcceptedError, match="academic"):
        download("h36m", tmp_path / "raw", mirror=base, progress=False)
    assert cli.main(["download", "--source", "h36m", "--dest", str(tmp_path / "raw"), "--mirror", base]) == 2
    err = capsys.readouterr().err
    assert "--accept-license" in err and "Traceback" not in err
    assert log == [] and not (tmp_path / "raw").exists()
    # with the flag it proceeds (a manifest of the one real file served here)
    _serve(root, "h36m/S5/walking_1.txt")
    one = [e for e in MANIFEST["entries"] if e.dest == "h36m/S5/walking_1.txt"]
    done = download("h36m", tmp_path / "raw", mirror=base, accept_license=True, progress=False,
                    manifest={**MANIFEST, "entries": one})
    assert done["h36m"][0].read_bytes() == (DATA / "h36m/S5/walking_1.txt").read_bytes()


def test_cli_download_errors_are_clear(tmp_path, capsys):
    assert cli.main(["download", "--source", "hdm05", "--dest", str(tmp_path / "raw")]) == 2
    err = capsys.readouterr().err
    assert "hdm05: no public per-file URL" in err and "--mirror" in err and "Traceback" not in err


def test_missing_file_on_server_names_it(server, tmp_path):
    base, root, _, _ = server
    with pytest.raises(DownloadError, match=r"07_01\.bvh: HTTP 404"):
        download_file(f"{base}/{CLIP}", tmp_path / "07_01.bvh", BY_DEST[CLIP].sha256, progress=False)
    assert list(tmp_path.glob("07_01*")) == []


# ---- Bandai: upstream files at a pinned commit, verified by their git blob SHA-1 ----------

needs_bandai = pytest.mark.skipif(not (DATA / "bandai").is_dir(), reason="no bandai folder in the data folder")


def _bandai_manifest(base: str, n: int = 3) -> dict:
    """The real manifest with its first ``n`` Bandai takes and raw_base pointing at ``base``."""
    info = {**MANIFEST["sources"]["bandai"], "raw_base": base}
    index = {**MANIFEST["bandai_index"], "rows": MANIFEST["bandai_index"]["rows"][:n]}
    return {**MANIFEST, "sources": {**MANIFEST["sources"], "bandai": info}, "bandai_index": index}


def _serve_upstream(root: Path, man: dict) -> list[dict]:
    """Lay the real files out as raw.githubusercontent.com does: <repo>/<commit>/<source_path>."""
    info, cols = man["sources"]["bandai"], man["bandai_index"]["columns"]
    recs = [dict(zip(cols, line.split("\t"))) for line in man["bandai_index"]["rows"]]
    for r in recs:
        _serve(root, f"{info['repository']}/{info['commit']}/{r['source_path']}", src=f"bandai/{r['file']}")
    return recs


@needs_bandai
def test_manifest_pins_bandai_by_index_and_git_blob_hash():
    from data_prep.download import git_blob_sha1
    info, index = MANIFEST["sources"]["bandai"], MANIFEST["bandai_index"]
    assert info["commit"] == "74ead3ba1ae4696404e6086233779f60de8bf9ef" and info["opt_in"]
    text = "".join(line + "\n" for line in ["\t".join(index["columns"])] + index["rows"])
    assert text == (DATA / "bandai" / "index.tsv").read_text()  # the index, byte for byte
    for line in index["rows"][::300]:
        rec = dict(zip(index["columns"], line.split("\t")))
        assert git_blob_sha1(DATA / "bandai" / rec["file"]) == rec["git_blob_sha1"]
    assert not any(e.source == "bandai" for e in MANIFEST["entries"])


@needs_bandai
def test_bandai_download_from_the_pinned_commit(server, tmp_path, capsys):
    base, root, log, _ = server
    man = _bandai_manifest(base)
    recs = _serve_upstream(root, man)
    out = tmp_path / "raw"
    done = download("bandai", out, manifest=man, progress=False)
    assert len(done["bandai"]) == 4 and len(log) == 3
    info = man["sources"]["bandai"]
    assert sorted(p for p, _ in log) == sorted(f"/{info['repository']}/{info['commit']}/{r['source_path']}"
                                               for r in recs)
    for r in recs:
        assert (out / "bandai" / r["file"]).read_bytes() == (DATA / "bandai" / r["file"]).read_bytes()
    ours = build_catalog(out, cache=False, sources=("bandai",))
    ref = build_catalog(DATA, cache=False, sources=("bandai",))
    cols = ["clip", "motion_type", "style", "frames"]
    assert ours[cols].values.tolist() == ref[ref["clip"].isin(ours["clip"])][cols].values.tolist()
    download("bandai", out, manifest=man, progress=False)  # present and verified: no requests
    assert len(log) == 3
    # upstream serves another file under a pinned path: the git blob hash refuses it
    _serve(root, f"{info['repository']}/{info['commit']}/{recs[0]['source_path']}", src=f"bandai/{recs[1]['file']}")
    with pytest.raises(ChecksumError, match=rf"{recs[0]['file'].split('/')[1]}.*git blob SHA-1"):
        download("bandai", tmp_path / "other", manifest=man, progress=False)
    assert not list((tmp_path / "other").rglob("*.bvh*"))


@needs_bandai
def test_bandai_is_not_in_the_default_download_and_the_cli_takes_it(server, tmp_path, capsys, monkeypatch):
    import data_prep.download as dl
    base, root, log, _ = server
    (root / "cmu").symlink_to(DATA / "cmu", target_is_directory=True)
    man = {**_bandai_manifest(base, n=2), "entries": [e for e in MANIFEST["entries"] if e.source == "cmu"]}
    done = download(None, tmp_path / "raw", mirror=base, progress=False, manifest=man)
    assert "bandai" not in done and len(done["cmu"]) == 18
    for line in man["bandai_index"]["rows"]:  # a mirror holds a copy of the data folder
        _serve(root, f"bandai/{line.split(chr(9))[0]}")
    monkeypatch.setattr(dl, "load_manifest", lambda *a, **k: man)
    assert cli.main(["download", "--source", "bandai", "--dest", str(tmp_path / "cli"), "--mirror", base]) == 0
    assert "bandai: 3 files" in capsys.readouterr().out
    assert (tmp_path / "cli" / "bandai" / "index.tsv").read_text().count("\n") == 3
