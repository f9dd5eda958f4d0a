"""The documentation cannot drift from the code: the site builds strictly, and every Python block runs.

* ``mkdocs build --strict`` (a broken link, a missing anchor or a reference to a missing name fails it; skipped,
  saying why, only when mkdocs is not installed: ``pip install -e '.[docs]'``).
* Every fenced ``python`` block of the README and of each page under ``docs/`` runs, a page's blocks in order in
  one fresh interpreter (later blocks use what earlier ones defined), with the repository root as the working
  directory (so a block writes its files under a temporary directory, never into the repository). A block that
  names the service's default address, ``http://127.0.0.1:8000``, runs against a real server
  (``python -m service``) that this test starts: the address is replaced by the server's.
* The marker ``<!-- docs-test: skip REASON -->`` on the line before a block's fence skips that block; the
  reason is required and every use is listed by :func:`test_skipped_blocks_say_why`. Use it only for what
  cannot run here (a Ray cluster's address, a second machine).
* The commands of the command-line page run and exit 0.
* The README stays a front door: at most 250 lines, its relative links exist, and its test command is the one
  CI runs (``.ci/run``).
* ``python -m service`` serves a built site at ``/guide``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from service_fixtures import REPO, in_process_app, shared_server

README = REPO / "README.md"
DOCS = REPO / "docs"
SERVER_URL = "http://127.0.0.1:8000"
SKIP = re.compile(r"<!--\s*docs-test:\s*skip\s+(?P<reason>\S.*?)\s*-->")
FENCE = re.compile(r"^(?P<indent> *)(?P<fence>`{3,}|~{3,})\s*(?P<info>[^\n`]*)$")
LINK = re.compile(r"(?<!\!)\[[^\]]*\]\((?P<target>[^)\s]+)\)|!\[[^\]]*\]\((?P<image>[^)\s]+)\)")


def code_blocks(path: Path) -> list[dict]:
    """The fenced blocks of a Markdown file: language, first line number, code, skip reason (or None)."""
    lines = path.read_text().splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence = len(m["indent"]), m["fence"]
        lang = (m["info"].strip().split() or [""])[0].lstrip(".{").rstrip("}")
        prev = lines[i - 1] if i else ""
        skip = SKIP.search(prev)
        body, j = [], i + 1
        while j < len(lines) and not lines[j].strip().startswith(fence):
            body.append(lines[j][indent:] if lines[j][:indent].strip() == "" else lines[j])
            j += 1
        blocks.append({"lang": lang, "line": i + 2, "code": "\n".join(body) + "\n",
                       "skip": skip["reason"] if skip else None})
        i = j + 1
    return blocks


def pages() -> list[Path]:
    return [README, *sorted(DOCS.rglob("*.md"))]


def python_pages() -> list[Path]:
    return [p for p in pages() if any(b["lang"] in ("python", "py") for b in code_blocks(p))]


# One interpreter per page: each block compiled under its file and line, so that a traceback points at the page.
RUNNER = textwrap.dedent("""
    import json, sys
    namespace = {"__name__": "__main__"}
    for block in json.load(sys.stdin):
        print(f"--- {block['file']}:{block['line']}", flush=True)
        code = compile("\\n" * (block["line"] - 1) + block["code"], block["file"], "exec")
        exec(code, namespace)
""")


@pytest.mark.parametrize("page", python_pages(), ids=lambda p: str(p.relative_to(REPO)))
def test_python_blocks_run(page: Path, tmp_path_factory):
    blocks = [b for b in code_blocks(page) if b["lang"] in ("python", "py") and not b["skip"]]
    if not blocks:
        pytest.skip("every Python block of this page is marked to skip")
    if any(SERVER_URL in b["code"] for b in blocks):
        url = shared_server(tmp_path_factory.getbasetemp()).url
        blocks = [{**b, "code": b["code"].replace(SERVER_URL, url)} for b in blocks]
    rel = str(page.relative_to(REPO))
    payload = json.dumps([{"file": rel, "line": b["line"], "code": b["code"]} for b in blocks])
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.run([sys.executable, "-c", RUNNER], input=payload, capture_output=True, text=True,
                          cwd=REPO, env=env, timeout=900)
    assert proc.returncode == 0, f"a Python block of {rel} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-6000:]}"


def test_command_line_page_runs(tmp_path):
    """Every ``$ dynamics ...`` line of the command-line page runs (as ``python -m dynamics``) and exits 0."""
    page = DOCS / "guide" / "cli.md"
    commands = [line[2:].strip() for b in code_blocks(page) if b["lang"] == "console"
                for line in b["code"].splitlines() if line.startswith("$ dynamics ")]
    assert commands, "the command-line page shows no commands"
    for command in commands:
        args = command.split()[1:]
        proc = subprocess.run([sys.executable, "-m", "dynamics", *args], cwd=tmp_path, capture_output=True,
                              text=True, timeout=600, env={**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(REPO)})
        assert proc.returncode == 0, f"{command}: exit {proc.returncode}\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}"


def test_skipped_blocks_say_why():
    skipped = [(str(p.relative_to(REPO)), b["line"], b["skip"]) for p in pages() for b in code_blocks(p)
               if b["skip"]]
    assert all(len(reason) > 10 for _, _, reason in skipped), skipped
    assert len(skipped) <= 6, f"the skip marker is for what cannot run here, not a way out: {skipped}"


def test_readme_is_a_front_door():
    text = README.read_text()
    assert len(text.splitlines()) <= 250, f"README.md has {len(text.splitlines())} lines; keep it <= 250"
    assert "pip install dynamics" not in text, "the PyPI name 'dynamics' is another project: install the clone"
    for m in LINK.finditer(text):
        target = (m["target"] or m["image"]).split("#")[0]
        if not target or re.match(r"^[a-z][a-z0-9+.-]*:", target):
            continue
        assert (REPO / target).exists(), f"README.md links to {target}, which does not exist"


def test_readme_test_command_is_what_ci_runs():
    lines = (REPO / ".ci" / "run").read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith("python3 -m venv"))
    ci = " && ".join(lines[start:start + 3])  # CI runs it one command a line, so that set -e sees each fail
    assert ci in README.read_text(), f"the README's test command differs from CI's: {ci}"


def test_site_builds_strictly(tmp_path):
    pytest.importorskip("mkdocs", reason="mkdocs is not installed: pip install -e '.[docs]'")
    pytest.importorskip("material", reason="mkdocs-material is not installed: pip install -e '.[docs]'")
    pytest.importorskip("mkdocstrings_handlers.python",
                        reason="mkdocstrings[python] is not installed: pip install -e '.[docs]'")
    site = tmp_path / "site"
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
                          cwd=REPO, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    assert (site / "index.html").is_file() and (site / "reference" / "http-api" / "index.html").is_file()
    api = (site / "reference" / "http-api" / "index.html").read_text()
    assert "/v1/robots/{robot_id}/inverse-dynamics" in api and "InverseDynamicsRequest" in api
    assert json.loads((site / "reference" / "openapi.json").read_text())["paths"]
    assert (site / "guide" / "pd_run.png").stat().st_size > 10_000  # drawn at build time by docs/_hooks/figures.py


def test_service_serves_the_built_site_at_guide(tmp_path, monkeypatch):
    site = tmp_path / "site"
    (site / "guide" / "service").mkdir(parents=True)
    (site / "index.html").write_text("<html>the site's home</html>")
    (site / "guide" / "service" / "index.html").write_text("<html>the service page</html>")
    monkeypatch.setenv("DYNAMICS_GUIDE_DIR", str(site))
    with in_process_app(tmp_path / "store") as client:
        assert "the site's home" in client.get("/guide/").text
        assert "the service page" in client.get("/guide/guide/service/").text
        assert client.get("/guide/nothing-here/").status_code == 404
        assert client.get("/docs").status_code == 200  # Swagger stays where it was
    monkeypatch.setenv("DYNAMICS_GUIDE_DIR", str(tmp_path / "not-built"))
    with in_process_app(tmp_path / "store2") as client:
        assert client.get("/guide/").status_code == 404
        assert client.get("/v1/health").status_code == 200
