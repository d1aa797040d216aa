"""docs/python.md's worked example, run as written."""

from __future__ import annotations

import os
import re

import numpy as np
from conftest import ROOT, mitsuba_variant


def test_worked_example_runs(tmp_path, monkeypatch, capsys):
    text = (ROOT / "docs" / "python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) == 1, "docs/python.md has one worked example"
    mitsuba_variant("llvm_ad_rgb")  # LLVM 19 present (or the reason it is not)
    (tmp_path / "data-measured").symlink_to(ROOT / "data-measured")
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(blocks[0], "docs/python.md", "exec"), ns)
    out = capsys.readouterr().out
    assert "MerlTable(dims=(90, 90, 180)" in out and "physical checks passed" in out
    assert ns["iters"], "the progress callback was called"
    assert ns["result"].record["family"] == "cook-torrance"
    for name in ("gold-measured.png", "gold-fitted.png"):
        assert os.path.getsize(name) > 1000
    # The fit is close enough that the two renders agree to a few per cent.
    m, f = np.mean(ns["measured"]), np.mean(ns["fitted"])
    assert abs(m - f) < 0.1 * m, (m, f)
