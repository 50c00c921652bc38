"""The README's Python code runs as written (in order, in a scratch folder)."""

import re
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_python_blocks_run(tmp_path, monkeypatch):
    blocks = python_blocks()
    assert len(blocks) >= 3, "the README lost its code examples"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    for number, block in enumerate(blocks):
        exec(compile(block, f"README.md python block {number + 1}", "exec"), namespace)
    # The blocks' products exist: an exported torque profile and an exported gait.
    assert (tmp_path / "torques.csv").stat().st_size > 0
    assert (tmp_path / "gait.csv").stat().st_size > 0
    assert namespace["sol"].success and namespace["fine"].success
