"""The real QGIS window (under Xvfb) in Korean: the wit:citymodel dialog opens and speaks Korean.

Runs scripts/screenshot_dialog.py as QGIS's start-up script in a throwaway profile (plugin linked
in and enabled, locale overridden to ko_KR), which writes what the dialog shows to a JSON file.
"""
from __future__ import annotations

import json
import os
import re
import subprocess

import pytest
from conftest import ROOT, qgis_gui_profile

HANGUL = re.compile("[\uac00-\ud7a3]")

pytestmark = [pytest.mark.slow, pytest.mark.qgis_facing]


def test_citymodel_dialog_is_korean(tmp_path, xvfb_display):
    profile = qgis_gui_profile(tmp_path / "profile", locale="ko_KR")
    report = tmp_path / "dialog.json"
    picture = tmp_path / "dialog.png"
    env = dict(os.environ, DISPLAY=xvfb_display, QT_QPA_PLATFORM="xcb",
               QGIS_CUSTOM_CONFIG_PATH=str(profile), LANG="ko_KR.UTF-8",
               WIT_SHOT_ALGS="wit:citymodel", WIT_SHOT_JSON=str(report),
               WIT_SHOT_DIALOG=str(picture), WIT_SHOT_DELAY_MS="1000")
    command = (f'source "{ROOT}/scripts/env.sh" && exec qgis --nologo --noversioncheck '
               f'--code "{ROOT}/scripts/screenshot_dialog.py"')
    run = subprocess.run(["bash", "-c", command], env=env, capture_output=True, text=True,
                         timeout=120)
    assert report.exists(), f"QGIS exit {run.returncode}: {run.stdout[-2000:]}{run.stderr[-2000:]}"
    shown = json.loads(report.read_text(encoding="utf-8"))
    assert "error" not in shown, shown["error"]
    assert run.returncode == 0, run.stderr[-2000:]

    assert shown["algorithm"] == "wit:citymodel"
    assert shown["user_locale"] == "ko_KR"
    assert HANGUL.search(shown["window_title"]), shown["window_title"]
    assert HANGUL.search(shown["display_name"]), shown["display_name"]
    untranslated = [text for text in shown["parameters"] if not HANGUL.search(text)]
    assert not untranslated, f"parameter labels without Korean: {untranslated}"
    assert "출력 폴더" in shown["labels"]  # a label the dialog really shows (Output folder)
    assert picture.stat().st_size > 10_000  # the dialog was drawn
