"""The repository says what is true now: no tracked text file outside ``docs/history.md`` names a work session
(the word followed by its number), an issue number (with or without ``#``) or a path under the retired
top-level results folder.

History (dates, commits, what changed when) has one home, ``docs/history.md``; everywhere else a reader finds
the code and its measured behaviour as they are. The test reads the files git tracks (``git ls-files``), skips
binary files, and lists every offending line, so a failure says where to look. The examples below are assembled
from parts, so this file passes its own check.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HISTORY = "docs/history.md"
EXEMPT = frozenset({HISTORY})

# the words for a work session or an issue followed by a number, any case; the digits make the word a reference to a
# round of work, where "race session" or "a GitHub issue" are ordinary words
PROCESS_WORDS = re.compile(r"\bsession ?[0-9]+|\bissue ?#?[0-9]+", re.IGNORECASE)
# a path that starts at the top-level results folder: not docs/results/..., not my_results/ or test-results/;
# the slash is a character class so that this line does not match itself
RESULTS_PATH = re.compile(r"(?<![\w./-])results[/]")


def tracked_text_files() -> dict[str, str]:
    """Each git-tracked file's path and text, for the files that decode as UTF-8 and hold no NUL byte."""
    git = shutil.which("git")
    if git is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout and the git command (the files to read are the tracked ones)")
    listing = subprocess.run(
        [git, "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True, timeout=60
    ).stdout.decode()
    texts: dict[str, str] = {}
    for name in filter(None, listing.split("\0")):
        path = ROOT / name
        if not path.is_file():  # deleted in the working tree, not yet committed
            continue
        data = path.read_bytes()
        if b"\0" in data:
            continue
        try:
            texts[name] = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
    return texts


def offending_lines(name: str, text: str) -> list[str]:
    """``path:line: text`` for each line of ``text`` with a process word or a results-folder path."""
    found = []
    for number, line in enumerate(text.splitlines(), start=1):
        if PROCESS_WORDS.search(line) or RESULTS_PATH.search(line):
            found.append(f"{name}:{number}: {line.strip()[:160]}")
    return found


def test_the_patterns_catch_what_they_should_and_nothing_else() -> None:
    """The two patterns on their own: what counts as a process word or a results path, and what does not."""
    session, issue, results = "ses" + "sion", "is" + "sue", "results" + "/"
    caught = [f"{session.title()} 28: the check", f"since {session} 18", f"{issue} 11's series"]
    caught += [f"see {issue.title()} #14", f"{session}12"]
    caught_paths = [f"{results}rl/README.md", f"(`{results}{issue}11/`)", f"default {results}tournaments/ID"]
    passed = ["a race session", "the issues' notes", "docs/results/README.md", "test-results/x", "my_results/a"]
    assert all(PROCESS_WORDS.search(line) for line in caught)
    assert all(RESULTS_PATH.search(line) for line in caught_paths)
    assert not any(PROCESS_WORDS.search(line) or RESULTS_PATH.search(line) for line in passed)
    assert offending_lines("x.md", f"fine\nas of {session} 3\n") == [f"x.md:2: as of {session} 3"]


def test_no_tracked_file_outside_the_history_names_sessions_issues_or_the_results_folder() -> None:
    """Every tracked text file but ``docs/history.md`` (and this one) is free of process words and results-folder
    paths."""
    texts = tracked_text_files()
    assert len(texts) > 50, "too few tracked text files found: is this the repository root?"
    assert HISTORY in texts, "docs/history.md is where history belongs: is it tracked?"
    found = [line for name, text in sorted(texts.items()) if name not in EXEMPT for line in offending_lines(name, text)]
    assert not found, f"{len(found)} lines name a session, an issue or the results folder:\n" + "\n".join(found)
