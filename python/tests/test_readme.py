# The README's Python example runs as written. Truths: it completes, writes the CLI's files, and the
# needle pushes the tissue (a positive axial force at full depth).
import os
import re

import pytest


def readme_example():
    source = os.environ.get("VIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
    text = open(os.path.join(source, "README.md"), encoding="utf-8").read()
    section = text[text.index("## Python module"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_readme_example_runs_as_written(tmp_path, monkeypatch, capsys):
    code = readme_example()
    assert 8 <= len(code.strip().splitlines()) <= 14
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(code, "README.md", "exec"), namespace)
    for name in ("mesh.vtu", "needle.csv", "simulation.pvd", "report.json"):
        assert (tmp_path / "ball_needle" / name).exists(), name
    assert namespace["result"].forces[-1] > 0
    assert namespace["mesh"].cell_data["object"].sum() > 0
    assert "elements in the ball" in capsys.readouterr().out
