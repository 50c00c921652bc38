"""The README's Python code runs as written: every block on its own (a fresh namespace and a
scratch folder of its own), as a reader copies one block into a new file."""

import re
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_python_blocks_run_each_on_its_own(tmp_path, monkeypatch):
    blocks = python_blocks()
    assert len(blocks) >= 3, "the README lost its code examples"
    namespaces = []
    for number, block in enumerate(blocks):
        folder = tmp_path / f"block{number + 1}"
        folder.mkdir()
        monkeypatch.chdir(folder)
        namespace: dict = {}
        exec(compile(block, f"README.md python block {number + 1}", "exec"), namespace)
        namespaces.append((folder, namespace))
    # The blocks' products exist: an exported torque profile and an exported gait.
    torques = [folder for folder, _ in namespaces if (folder / "torques.csv").exists()]
    assert torques and (torques[0] / "torques.csv").stat().st_size > 0
    gait = [ns for folder, ns in namespaces if (folder / "gait.csv").exists()]
    assert gait and gait[0]["sol"].success and gait[0]["fine"].success
