"""The questionnaire in a real browser: headless Chromium opens the kit's page from disk
(file://), a test participant answers through clicks and downloads the JSON, and the analysis
reads the files back. The responses are made by this test: fixtures, never study results.

Needs Debian's ``chromium`` and ``chromium-driver`` (``.ci/run`` installs them) and selenium.
"""

from __future__ import annotations

import os
import shutil
import time

import pytest
from conftest import CMU_FILES, NO_DATA_REASON

CHROMIUM, DRIVER = shutil.which("chromium"), shutil.which("chromedriver")
NO_BROWSER = "no chromium / chromedriver on this machine (apt-get install chromium chromium-driver; .ci/run does it)"
if not (CHROMIUM and DRIVER) and os.environ.get("CI"):
    raise RuntimeError(f"{NO_BROWSER}: CI must run the browser test")  # never a silent skip in CI
pytestmark = pytest.mark.skipif(not (CHROMIUM and DRIVER), reason=NO_BROWSER)


@pytest.fixture(scope="module")
def kit(tmp_path_factory):
    """A three-question kit of three real CMU clips: one pair per group, so that the three
    answers can form a triad. The model labels are fixture names, not models."""
    if len(CMU_FILES) < 3:
        pytest.skip(NO_DATA_REASON)
    from data_prep.sources import SOURCE_LENGTH_UNITS
    from mocapviz.io.bvh import read_bvh
    from mocapviz.study.kit import Clip, Pair, build_kit

    x, y, z = (Clip(f"clip{k}", f"source_{k}", read_bvh(p, length_unit=SOURCE_LENGTH_UNITS["cmu"])[:120])
               for k, p in enumerate(sorted(CMU_FILES, key=lambda f: f.stat().st_size)[:3]))  # the quickest to read
    pairs = [Pair("x vs y", x, y), Pair("x vs z", x, z), Pair("y vs z", y, z)]
    folder = tmp_path_factory.mktemp("kit")
    key = build_kit(pairs, folder, seed=3, fps=10, seconds=1.0, panel_size=(160, 120), progress=False)
    return folder, key


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    downloads = tmp_path_factory.mktemp("downloads")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--autoplay-policy=no-user-gesture-required"):
        opts.add_argument(arg)
    opts.add_experimental_option("prefs", {"download.default_directory": str(downloads),
                                           "download.prompt_for_download": False})
    driver = webdriver.Chrome(service=Service(DRIVER), options=opts)  # the system driver: no download
    driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    yield driver, downloads
    driver.quit()


def _wait(predicate, seconds: float = 10.0):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    raise TimeoutError("condition not met in time")


def _answer(driver, downloads, page, participant: str, sides: list[str | None]) -> dict:
    """Open the page, answer each question with ``sides`` (None: press Next without choosing),
    download the JSON and return it parsed."""
    import json

    from selenium.webdriver.common.by import By

    driver.get(page.as_uri())
    driver.find_element(By.ID, "participant").send_keys(participant)
    driver.find_element(By.ID, "start").click()
    for side in sides:
        # the question's video (or its gif fallback) loaded from the kit folder
        _wait(lambda: driver.execute_script(
            "const v = document.getElementById('video'), g = document.getElementById('gif');"
            "return (v && v.readyState >= 1 && v.videoWidth > 0) || (g && g.complete && g.naturalWidth > 0);"))
        if side:
            driver.find_element(By.ID, f"choose-{side}").click()
        driver.find_element(By.ID, "next").click()
    assert driver.find_element(By.ID, "summary").text.startswith(f"Done: {len(sides)} questions")
    driver.find_element(By.ID, "download").click()
    path = _wait(lambda: [p for p in downloads.glob(f"responses_{participant}_*.json")])[0]
    _wait(lambda: path.stat().st_size > 0)
    return json.loads(path.read_text())


def test_questionnaire_answered_in_chromium(kit, browser):
    from mocapviz.study.analysis import (
        answers_table,
        group_counts,
        read_key,
        read_responses,
        validity,
    )

    folder, key = kit
    driver, downloads = browser
    page = folder / "questionnaire" / "index.html"
    assert (folder / "key.json").is_file() and not (folder / "questionnaire" / "key.json").exists()
    questions = key["questions"]
    assert len(questions) == 3

    def sides_for(winners: dict[str, str]) -> list[str]:
        """The side to click in each question so that winners[group] (an item) is chosen."""
        return ["left" if q["left"]["item"] == winners[q["group"]] else "right" for q in questions]

    transitive = sides_for({"x vs y": "clip0", "x vs z": "clip0", "y vs z": "clip1"})  # 0 > 1 > 2
    cyclic = sides_for({"x vs y": "clip0", "x vs z": "clip2", "y vs z": "clip1"})      # 0 > 1 > 2 > 0
    blank = transitive[:1] + [None] + transitive[2:]
    _answer(driver, downloads, page, "fixture_a", transitive)
    _answer(driver, downloads, page, "fixture_b", cyclic)
    got = _answer(driver, downloads, page, "fixture_c", blank)
    assert got["kit"] == key["kit"] and [a["question"] for a in got["answers"]] == [q["id"] for q in questions]
    assert all(a["seconds"] >= 0 for a in got["answers"]) and got["finished"] >= got["started"]

    responses = read_responses(downloads)
    assert sorted(r["participant"] for r in responses) == ["fixture_a", "fixture_b", "fixture_c"]
    key = read_key(folder / "key.json")
    v = validity(responses, key, min_seconds=0)
    assert v.loc["fixture_a"].valid and v.loc["fixture_a"].blank == 0 and v.loc["fixture_a"].triads == 0
    assert not v.loc["fixture_b"].valid and v.loc["fixture_b"].triads == 1 and v.loc["fixture_b"].blank == 0
    assert not v.loc["fixture_c"].valid and v.loc["fixture_c"].blank == 1 and v.loc["fixture_c"].triads == 0
    assert not validity(responses, key).valid.any()  # nobody spent the paper's 10 minutes

    answers = answers_table(responses, key)
    assert len(answers) == 9 and answers.choice.isna().sum() == 1
    counts = group_counts(answers, v.index[v.valid])
    # fixture_a chose clip0 in both groups with x and clip1 over clip2; b (clip y / z) is counted
    assert counts.loc["fixture_a"].to_dict() == {"x vs y": 0.0, "x vs z": 0.0, "y vs z": 0.0}
    everyone = group_counts(answers)
    assert everyone.loc["fixture_b"].to_dict() == {"x vs y": 0.0, "x vs z": 1.0, "y vs z": 0.0}
    assert everyone.sum().sum() == 1
