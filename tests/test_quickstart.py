"""The README's quick start, run as a user would: every command line between the
``<!-- quickstart -->`` markers of README.md, in order, in a temporary copy of the folders they
read (examples/, tests/data/calibration/), each checked for exit 0 and for the outputs it names.
So the README cannot promise a command that no longer works.

Two lines are run with a change a user would not make: ``./bootstrap.sh demo`` runs as the
``mrcheck demo`` it execs, at 160 px wide (set-up is what ``./bootstrap.sh test`` just did), and
``source .venv/bin/activate`` is this interpreter's bin folder put first on the PATH. The review
server is started on a free port, asked for its page and one API call, and stopped with Ctrl-C.
The links of README.md and docs/ are checked too: a moved page or picture fails here.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
# what the quick start reads; copied, so that its outputs (quickstart/, mrcheck-demo/) land in a
# temporary folder and a run can never write into the repository
NEEDED = ["examples", "tests/data/calibration"]
DEMO_STUDY = "mrcheck-demo/robot_study.png"  # the sheet the quick start says to open first


def quickstart_lines(text: str) -> list[str]:
    """The command lines of the ```sh blocks between the quick start's markers."""
    match = re.search(r"<!-- quickstart -->(.*?)<!-- /quickstart -->", text, re.S)
    assert match, "README.md has no <!-- quickstart --> ... <!-- /quickstart --> section"
    blocks = re.findall(r"```sh\n(.*?)```", match.group(1), re.S)
    return [
        line.strip()
        for block in blocks
        for line in block.splitlines()
        if line.strip() and not line.strip().startswith("#")
    ]


def outputs_named(argv: list[str]) -> list[str]:
    """The ``-o`` / ``--output`` paths of a command line."""
    return [argv[i + 1] for i, arg in enumerate(argv[:-1]) if arg in ("-o", "--output")]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    work = tmp_path_factory.mktemp("quickstart")
    for folder in NEEDED:
        shutil.copytree(ROOT / folder, work / folder)
    return work


@pytest.fixture(scope="module")
def env():
    bindir = Path(sys.executable).parent
    assert (bindir / "mrcheck").exists(), f"no mrcheck script beside {sys.executable}: install mrcheck first"
    return dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ['PATH']}")


def run_line(argv: list[str], outputs: list[str], workdir: Path, env: dict) -> None:
    result = subprocess.run(argv, cwd=workdir, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"{shlex.join(argv)} exited {result.returncode}:\n{result.stderr[-2000:]}"
    for out in outputs:
        assert (workdir / out).exists(), f"{shlex.join(argv)} did not write {out}"


def review_once(argv: list[str], workdir: Path, env: dict) -> None:
    """Start the review server, fetch its page and the shots it serves, stop it with Ctrl-C."""
    port = free_port()
    server = subprocess.Popen(
        [*argv, "--port", str(port)],
        cwd=workdir,
        env=dict(env, PYTHONUNBUFFERED="1"),
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        url = None
        deadline = time.monotonic() + 120
        while url is None and time.monotonic() < deadline:
            line = server.stdout.readline()
            assert line or server.poll() is None, f"review exited {server.poll()}: {server.stderr.read()[-2000:]}"
            if found := re.search(r"http://\S+", line):
                url = found.group(0)
        assert url == f"http://127.0.0.1:{port}/", url
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200 and b"mrcheck review" in page.read()
        with urllib.request.urlopen(url + "api/shots", timeout=60) as shots:
            assert shots.status == 200 and b'"name":"box"' in shots.read()
    finally:
        server.send_signal(signal.SIGINT)
        try:
            code = server.wait(timeout=60)
        except subprocess.TimeoutExpired:
            server.kill()
            raise
    assert code == 0, f"review stopped by Ctrl-C exited {code}"


@pytest.mark.slow
def test_the_quick_start_runs_end_to_end(workdir, env):
    lines = quickstart_lines(README.read_text())
    commands = [shlex.split(line) for line in lines]
    assert [c[:2] for c in commands] == [
        ["./bootstrap.sh", "demo"],
        ["source", ".venv/bin/activate"],
        ["mrcheck", "calibrate"],
        ["mrcheck", "register"],
        ["mrcheck", "overlay"],
        ["mrcheck", "discrepancies"],
        ["mrcheck", "export"],
        ["mrcheck", "review"],
    ], lines
    # bootstrap.sh's demo is `mrcheck demo` with the same arguments, run where it was called
    assert 'demo) cd "$caller" && exec "$repo/.venv/bin/mrcheck" demo "$@"' in (ROOT / "bootstrap.sh").read_text()
    for line, argv in zip(lines, commands):
        outputs = outputs_named(argv)
        if argv[0] == "source":
            continue
        if argv[0] == "./bootstrap.sh":
            argv = ["mrcheck", "demo", *argv[2:], "--width", "160"]
        if argv[:2] == ["mrcheck", "calibrate"]:  # the shell expands the glob for the user
            argv = ["bash", "-c", line]
        if argv[:2] == ["mrcheck", "review"]:
            review_once(argv, workdir, env)
        else:
            run_line(argv, outputs, workdir, env)
    # the outputs the quick start's text names, beyond the -o paths
    for named in (DEMO_STUDY, "quickstart/export/report.html", "quickstart/discrepancies/heatmap.png"):
        assert (workdir / named).exists(), named


def test_the_quick_start_names_the_demo_sheet_it_writes():
    assert f"Open `{DEMO_STUDY}` first" in README.read_text()


def test_set_up_is_two_commands_as_its_heading_says():
    text = README.read_text()
    section = text.split("## Set-up: two commands", 1)[1].split("\n## ", 1)[0]
    first_block = re.search(r"```sh\n(.*?)```", section, re.S).group(1)
    assert [line.split("#")[0].strip() for line in first_block.strip().splitlines()] == [
        "./bootstrap.sh demo",
        "./bootstrap.sh test",
    ]
    assert "exec ./bootstrap.sh test" in (ROOT / ".ci" / "run").read_text()


def test_the_example_box_is_the_box_the_tests_measure():
    """examples/box/ is a copy of tests/data/pose/box/ (test_real_photo.py measures that one):
    the quick start's figures hold only while the two are the same."""
    example, tested = ROOT / "examples" / "box", ROOT / "tests" / "data" / "pose" / "box"
    pairs = {
        "resized_IMG_3875.JPG": "resized_IMG_3875.JPG",
        "box.ply": "box.ply",
        "LICENSE": "LICENSE",
        "scene.toml": "scene.toml",
        "corners.json": "corners.json",
        "camera.json": "canon.json",
    }
    for mine, theirs in pairs.items():
        assert (example / mine).read_bytes() == (tested / theirs).read_bytes(), mine


def markdown_files() -> list[Path]:
    return [README, *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "examples").rglob("*.md"))]


def anchors(page: Path) -> set[str]:
    """The #fragments of a Markdown page's headings, as GitHub makes them."""
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    return {
        re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        for heading in re.findall(r"^#+ (.*)$", text, re.M)
    }


@pytest.mark.parametrize("page", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_points_at_a_file_and_heading(page):
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):
            continue
        name, _, fragment = target.partition("#")
        path = (page.parent / name).resolve() if name else page
        assert path.exists(), f"{page.name}: link to {target}, which does not exist"
        if fragment:
            assert fragment in anchors(path), f"{page.name}: link to {target}: no such heading in {path.name}"


def test_docs_index_lists_every_page():
    index = (ROOT / "docs" / "README.md").read_text()
    for page in sorted((ROOT / "docs").glob("*.md")):
        if page.name != "README.md":
            assert f"]({page.name})" in index, f"docs/README.md does not list {page.name}"
