"""The README's and the guides' Python code runs as written: every block on its own (a fresh
namespace and a scratch folder of its own), as a reader copies one block into a new file; and
every link between them leads to a file that exists."""

import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from model import Dynamics

ROOT = Path(__file__).resolve().parent.parent
#: The README and every guide beside what it describes.
DOCUMENTS = [
    ROOT / "README.md",
    *sorted((ROOT / "examples").rglob("*.md")),
    *sorted((ROOT / "model").glob("*.md")),
    *sorted((ROOT / "tests").glob("*.md")),
]


def python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)


def run_blocks(path: Path, tmp_path: Path, monkeypatch) -> list[tuple[Path, dict]]:
    namespaces = []
    for number, block in enumerate(python_blocks(path)):
        folder = tmp_path / f"block{number + 1}"
        folder.mkdir()
        # a guide is run from the repository's root: its example files are where it says
        (folder / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
        monkeypatch.chdir(folder)
        namespace: dict = {}
        where = f"{path.relative_to(ROOT)} python block {number + 1}"
        exec(compile(block, where, "exec"), namespace)
        namespaces.append((folder, namespace))
    return namespaces


def test_the_readme_cites_the_seed_paper():
    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert "Compilation of a system equations dynamics of a six-link mechanism with " \
        "branching using complex functions" in text  # fmt: skip


def test_the_guides_are_found():
    # the guard: the documents the README links to are the ones this module runs
    names = {str(path.relative_to(ROOT)) for path in DOCUMENTS}
    assert {"README.md", "examples/planning.md", "model/README.md", "tests/extremes.md"} <= names
    assert sum(len(python_blocks(path)) for path in DOCUMENTS) >= 6


def test_the_readme_example_writes_its_torque_file(tmp_path, monkeypatch):
    namespaces = run_blocks(ROOT / "README.md", tmp_path, monkeypatch)
    assert len(namespaces) == 1, "the README holds one example, its own OCP"
    folder, namespace = namespaces[0]
    assert namespace["solution"].success
    assert (folder / "torques.csv").stat().st_size > 0
    # "at rest at both ends": the file's first and last samples neither move nor accelerate,
    # so the last torque is the one that holds the arm level against gravity
    from model import LinkageTrajectory

    written = LinkageTrajectory.load(folder / "torques.csv")
    arm = namespace["arm"]
    for k in (0, -1):
        assert abs(written.dpsi[k]).max() < 1e-9 and abs(written.ddpsi[k]).max() < 1e-6, k
    holding = np.asarray(Dynamics(arm).function("gravity_torques")(written.psi[-1])).ravel()
    np.testing.assert_allclose(written.torques[-1], holding, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize(
    "document",
    [path for path in DOCUMENTS if path.name != "README.md" or path.parent != ROOT],
    ids=lambda path: str(path.relative_to(ROOT)),
)
def test_guide_python_blocks_run_each_on_its_own(document, tmp_path, monkeypatch):
    namespaces = run_blocks(document, tmp_path, monkeypatch)
    if document.name == "planning.md":
        # its blocks export a gait that solved, on its mesh and refined
        gait = [ns for folder, ns in namespaces if (folder / "gait.csv").exists()]
        assert gait and gait[0]["sol"].success and gait[0]["fine"].success


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda path: str(path.relative_to(ROOT)))
def test_links_lead_to_files_that_exist(document):
    text = document.read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)#\s]+)\)", text)
    missing = [
        target
        for target in targets
        if not target.startswith(("http://", "https://"))
        and not (document.parent / target).exists()
    ]
    assert not missing, f"{document.relative_to(ROOT)} links to missing files: {missing}"


def quoted_commands(path: Path) -> list[str]:
    """Every ``python -m problems ...`` command line of a bash block, its comment cut off;
    the ones with "..." (elisions) and the README's install lines left out (a command named
    in prose is a mention, not a command line)."""
    text = path.read_text(encoding="utf-8")
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        lines += block.splitlines()
    commands = []
    for line in lines:
        found = re.search(r"python -m problems (.*)", line.split("#")[0])
        if found and "..." not in found.group(1) and "&&" not in found.group(1):
            commands.append(found.group(1).strip())
    return commands


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda path: str(path.relative_to(ROOT)))
def test_quoted_commands_are_commands_the_program_takes(document):
    """Each command a guide quotes parses with today's command line: its command and every
    option exist and take the values written (running them all is the benchmarks' job)."""
    import shlex

    from problems.cli import build_parser
    from problems.cli.common import UsageError

    parser = build_parser()
    for command in quoted_commands(document):
        argv = shlex.split(command)
        try:
            parser.parse_args(argv)
        except (SystemExit, UsageError) as error:  # a bad command line
            raise AssertionError(f"{document.name}: `python -m problems {command}` does not "
                                 f"parse ({error})") from None  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize(
    "document",
    [path for path in DOCUMENTS if quoted_commands(path)],
    ids=lambda path: str(path.relative_to(ROOT)),
)
def test_quoted_commands_exit_0(document, tmp_path):
    """Each command a guide quotes runs as written and exits 0: in the guide's order, in one
    scratch folder per guide standing for the clone (a later command reads what an earlier
    one wrote; examples/ is the clone's), with the shared human walking data at
    ../shared/human_gait beside it as in a clone."""
    import os
    import subprocess
    import sys

    from conftest import human_gait_data

    commands = quoted_commands(document)
    data = human_gait_data()
    if data is None and any("../shared/" in c for c in commands):
        pytest.skip("the shared human walking data is not here (../shared/human_gait)")
    work = tmp_path / "clone"
    work.mkdir()
    (work / "examples").symlink_to(ROOT / "examples", target_is_directory=True)  # its inputs
    if data is not None:
        (tmp_path / "shared").mkdir()
        (tmp_path / "shared" / "human_gait").symlink_to(data.parent, target_is_directory=True)
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    for command in commands:
        run = subprocess.run([sys.executable, "-m", "problems", *shlex.split(command)], cwd=work,
                             env=environment, capture_output=True, text=True)  # fmt: skip
        assert run.returncode == 0, (
            f"{document.name}: `python -m problems {command}` exited {run.returncode}:\n"
            f"{run.stderr[-2000:]}"
        )
