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


def run_block(path: Path, number: int, block: str, tmp_path: Path, monkeypatch):
    """(its scratch folder, its namespace) after block ``number`` (from 1) of ``path`` ran in
    a fresh namespace and a folder of its own, as a reader copies one block into a new file."""
    folder = tmp_path / f"block{number}"
    folder.mkdir()
    # a guide is run from the repository's root: its example files are where it says
    (folder / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(folder)
    namespace: dict = {}
    where = f"{path.relative_to(ROOT)} python block {number}"
    exec(compile(block, where, "exec"), namespace)
    return folder, namespace


def run_blocks(path: Path, tmp_path: Path, monkeypatch) -> list[tuple[Path, dict]]:
    return [run_block(path, number, block, tmp_path, monkeypatch)
            for number, block in enumerate(python_blocks(path), start=1)]  # fmt: skip


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


#: The guides' blocks the default suite leaves to the slow one (each takes 20 s to a minute on
#: a busy 2-core machine: solves on feet, a study, MuJoCo), keyed by their guide and a text
#: only that block holds (a test holds each key to exactly one block, so none goes stale).
SLOW_BLOCKS = {
    ("examples/feet.md", "footed_step(step_length=0.5"): "a step on feet solved and verified",
    ("examples/feet.md", "Study("): "a study of five steps on feet",
    ("examples/feet.md", "run_feet_in_mujoco("): "a step on feet solved and walked in MuJoCo",
    ("examples/drives.md", "with_drives(step, walker"): "a step planned with its drives",
    ("examples/drives.md", "footed_step_at(v, speed_limit"): "two steps on feet and a selection",
}


def _guide_blocks():
    """pytest params (guide, block number, block) of every guide's Python blocks, the ones
    in SLOW_BLOCKS marked slow."""
    params = []
    for path in DOCUMENTS:
        if path == ROOT / "README.md":
            continue  # its one example has its own test
        name = str(path.relative_to(ROOT))
        for number, block in enumerate(python_blocks(path), start=1):
            slow = any(guide == name and key in block for guide, key in SLOW_BLOCKS)
            params.append(pytest.param(path, number, block, id=f"{name}:{number}",
                                       marks=[pytest.mark.slow] if slow else []))  # fmt: skip
    return params


def test_each_slow_block_is_one_block_of_its_guide():
    for guide, key in SLOW_BLOCKS:
        holding = [block for block in python_blocks(ROOT / guide) if key in block]
        assert len(holding) == 1, f"{guide}: {len(holding)} blocks hold {key!r}, not one"


@pytest.mark.parametrize("document, number, block", _guide_blocks())
def test_guide_python_blocks_run_each_on_its_own(document, number, block, tmp_path, monkeypatch):
    folder, namespace = run_block(document, number, block, tmp_path, monkeypatch)
    if document.name == "planning.md" and (folder / "gait.csv").exists():
        # the block that exports a gait: it solved, on its mesh and refined
        assert namespace["sol"].success and namespace["fine"].success


def test_the_planning_guide_exports_a_gait():
    assert any("gait.csv" in block for block in python_blocks(ROOT / "examples/planning.md"))


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


#: Quoted commands that a test of their own runs as the guide writes them, checking what they
#: print and write beyond the exit status.
RUN_BY_THEIR_OWN_TEST = {
    "walk --feedback": "tests/test_walking_feedback.py::"
    "test_walk_feedback_prints_the_closed_loop_and_writes_the_gains",
}


def commands_to_run(document: Path) -> list[str]:
    """The document's quoted commands less those run elsewhere, so that each distinct command
    runs once in the slow suite: a README command that a guide quotes too runs with the guide,
    and a command with a test of its own runs there."""
    elsewhere = set(RUN_BY_THEIR_OWN_TEST)
    if document == ROOT / "README.md":
        for guide in DOCUMENTS[1:]:
            elsewhere.update(quoted_commands(guide))
    return [command for command in quoted_commands(document) if command not in elsewhere]


def output_folder(command: str) -> str | None:
    argv = shlex.split(command)
    return argv[argv.index("--output-dir") + 1] if "--output-dir" in argv else None


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda path: str(path.relative_to(ROOT)))
def test_a_command_run_elsewhere_feeds_none_that_runs_here(document):
    """A command left to another run writes nothing that a command still run here reads:
    the guide's chain stays whole."""
    kept = commands_to_run(document)
    for dropped in set(quoted_commands(document)) - set(kept):
        for command in kept:
            assert not feeds(dropped, command), (
                f"{document.name}: `{command}` reads what `{dropped}` writes, which runs "
                "elsewhere: quote the chain whole in one guide"
            )


def test_each_command_left_to_its_own_test_is_quoted_and_its_test_exists():
    quoted = {command for path in DOCUMENTS for command in quoted_commands(path)}
    for command, test in RUN_BY_THEIR_OWN_TEST.items():
        assert command in quoted, f"`{command}` is quoted by no guide: drop it from the table"
        file, name = test.split("::")
        assert f"def {name}(" in (ROOT / file).read_text(encoding="utf-8"), test


def feeds(earlier: str, command: str) -> bool:
    """Whether `command` reads what `earlier` writes: a path in its folder, that folder itself,
    or, with no --output-dir on either, the same command's default folder."""
    folder, words = output_folder(earlier), shlex.split(command)
    if folder is None:
        return words[0] == shlex.split(earlier)[0] and "--output-dir" not in words
    return any(word == folder or word.startswith(f"{folder}/") for word in words[1:])


def command_chains(document: Path) -> list[list[str]]:
    """`commands_to_run` cut into chains that run apart (each in a clone of its own, so the
    slow suite's workers share a long guide): a command joins every earlier chain it reads
    from; each chain keeps the guide's order."""
    commands = commands_to_run(document)
    chains: list[list[int]] = []
    for index, command in enumerate(commands):
        linked = [c for c in chains if any(feeds(commands[i], command) for i in c)]
        chains = [c for c in chains if c not in linked]
        chains.append([*sorted(i for c in linked for i in c), index])
    chains.sort(key=lambda chain: chain[0])
    return [[commands[i] for i in chain] for chain in chains]


def test_command_chains_follow_what_each_command_reads():
    guide = ROOT / "examples" / "drives.md"
    chains = command_chains(guide)
    assert sorted(c for chain in chains for c in chain) == sorted(commands_to_run(guide))
    steps = next(chain for chain in chains if chain[0].endswith("--output-dir walk_out"))
    assert any(command.startswith("drives walk_out/torques.csv") for command in steps[1:])
    study = command_chains(ROOT / "examples" / "walking_study.md")
    assert len(study) == 1 and len(study[0]) == 2  # the second run resumes the first's folder
    assert feeds("walk --output-dir a", "drives a/torques.csv")
    assert not feeds("walk --output-dir a", "drives ab/torques.csv")
    assert not feeds("walk", "walk --output-dir b")
    assert not feeds("library --output-dir library", "library --feet --output-dir library_feet")


CHAINS = [(path, chain) for path in DOCUMENTS for chain in command_chains(path)]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("document", "commands"),
    CHAINS,
    ids=[f"{path.relative_to(ROOT)}: {chain[0][:40]}" for path, chain in CHAINS],
)
def test_quoted_commands_exit_0(document, commands, tmp_path):
    """Each command a guide quotes runs as written and exits 0, once (`commands_to_run`): a
    chain of them (`command_chains`: a later command reads what an earlier one wrote) in the
    guide's order, in a scratch folder of its own standing for the clone (examples/ is the
    clone's), with the shared human walking data at ../shared/human_gait beside it."""
    import os
    import subprocess
    import sys

    from conftest import human_gait_data

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


def test_ci_runs_the_readmes_test_command_as_written():
    """`.ci/run` runs exactly the test command the README's second line gives a fresh machine
    (its pytest options and all), then the slow suite."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    found = re.search(r'pip install "\.\[test\]" && (python -m pytest[^\n]*)', readme)
    assert found, "the README gives no test command"
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert f'python -m pip install ".[test]" && {found.group(1)}' in ci
    assert any(line.startswith("python -m pytest") and "-m slow" in line for line in ci)
