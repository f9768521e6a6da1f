"""The README is for users and the documentation builds (issue 37).

The README stays short (at most 250 lines: what the tool is, the two commands, a walkthrough on
your data, the file format, links); everything else is a page of ``docs/``, built into a static
site by mkdocs in strict mode, which fails on a link to a page or an anchor that does not exist.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_readme_is_short_and_starts_with_the_two_commands():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 250, len(lines)
    commands = [l for l in lines[:6] if l.startswith(("Run the sweep: `", "Run the tests: `"))]
    assert len(commands) == 2, lines[:6]


def test_readme_links_point_at_files_that_exist():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text)
    assert links
    missing = [l for l in links if "://" not in l and not (ROOT / l).exists()]
    assert not missing, missing


def test_documentation_site_builds_with_its_links_checked(tmp_path):
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    out = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                          str(ROOT / "mkdocs.yml"), "--site-dir", str(tmp_path / "site")],
                         capture_output=True, text=True, env=env, cwd=ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / "site" / "diagnosis" / "index.html").is_file()
