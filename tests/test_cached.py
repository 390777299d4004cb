from data_prep.cached import load_or_build


def test_load_or_build_uses_cache_and_rebuilds_unreadable_files(tmp_path):
    path = tmp_path / "ds.txt"
    builds = []

    def build():
        builds.append(1)
        return "built"

    def load(p):
        text = p.read_text()
        if text != "built":
            raise ValueError("truncated")
        return text

    save = lambda value, p: p.write_text(value)  # noqa: E731
    assert load_or_build(path, load, build, save) == "built" and len(builds) == 1
    assert load_or_build(path, load, build, save) == "built" and len(builds) == 1  # from the file
    path.write_text("bui")  # a crash mid-write of an older, non-atomic writer
    assert load_or_build(path, load, build, save) == "built" and len(builds) == 2
    assert load_or_build(tmp_path / "none.txt", load, build, save, cache=False) == "built"
    assert not (tmp_path / "none.txt").exists()
