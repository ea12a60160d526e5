"""The documents and code comments point at things that exist, and speak of
the software as it is.

(a) Every relative Markdown link in README.md and docs/*.md resolves to a
    file or folder of the repository; a link with an #anchor into a .md file
    names one of its headings (GitHub's slugs).
(b) Every path of the form docs/..., compare/..., native/..., tests/...,
    scripts/... or scenes/... that README.md, docs/*.md or a code comment
    (.py, .hpp, .cpp, .h, .cu, .sh, .toml, CMakeLists.txt) mentions exists; glob
    patterns (scenes/drum/*.toml) and {a,b} alternatives match something;
    a section named after it (docs/X.md, "Section") begins a heading of X.
(c) No text anywhere in the project's documents, code and scripts speaks of
    how it was developed (numbered stops, issues, sessions, launches named
    after them).
"""

from __future__ import annotations

import ast
import glob
import io
import re
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# Top-level folders whose text files are checked by (b), in comments, and (c).
CODE_DIRS = ["compare", "native", "scripts", "tests", "lammps_cases", "yade_cases", "scenes", ".ci"]
CODE_SUFFIXES = {".py", ".hpp", ".cpp", ".h", ".cu", ".sh", ".toml", ".in"}
# Inputs, not text: the fuzzer's corpus and the deliberately broken scenes.
SKIP_PARTS = {"corpus", "__pycache__"}


def tracked_and_new_files() -> list[Path]:
    """The repository's files: tracked ones and untracked ones git does not ignore."""
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT,
                         stdout=subprocess.PIPE, text=True, check=True).stdout
    return [ROOT / p for p in out.splitlines() if (ROOT / p).is_file()]


FILES = tracked_and_new_files()


def markdown_files() -> list[Path]:
    return [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))


def code_files() -> list[Path]:
    out = []
    for f in FILES:
        rel = f.relative_to(ROOT)
        if rel.parts[0] not in CODE_DIRS and rel.name != "CMakeLists.txt":
            continue
        if SKIP_PARTS & set(rel.parts):
            continue
        if f.suffix in CODE_SUFFIXES or f.name in ("CMakeLists.txt", "run") or f.suffix == ".md":
            out.append(f)
    out.append(ROOT / "CMakeLists.txt")
    # This file's own examples and patterns are left out.
    return sorted(set(out) - {Path(__file__).resolve()})


def text(path: Path) -> str:
    return path.read_text(encoding="utf-8", errors="replace")


def without_code_blocks(md: str) -> str:
    """Markdown with fenced code blocks blanked (line numbers kept)."""
    lines, fenced = [], False
    for line in md.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            lines.append("")
        else:
            lines.append("" if fenced else line)
    return "\n".join(lines)


# ---- (a) Markdown links --------------------------------------------------------

LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: the rendered text, lower case, without
    punctuation other than - and _, spaces as hyphens."""
    t = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # links: their text
    t = t.replace("`", "").replace("*", "")
    t = t.strip().lower()
    t = re.sub(r"[^\w\- ]", "", t)
    return t.replace(" ", "-")


def anchors(md_path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for line in without_code_blocks(text(md_path)).splitlines():
        m = re.match(r"^(#{1,6})\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        s = slug(m.group(2))
        n = seen.get(s, 0)
        seen[s] = n + 1
        out.add(s if n == 0 else f"{s}-{n}")
    return out


def link_problems(md_path: Path) -> list[str]:
    problems = []
    body = without_code_blocks(text(md_path))
    for lineno, line in enumerate(body.splitlines(), 1):
        for m in LINK.finditer(line):
            target = m.group(1)
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
                continue
            path_part, _, anchor = target.partition("#")
            dest = (md_path.parent / path_part).resolve() if path_part else md_path
            where = f"{md_path.relative_to(ROOT)}:{lineno}: {target}"
            if not dest.exists():
                problems.append(f"{where}: no such file")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                problems.append(f"{where}: no heading with that anchor")
    return problems


@pytest.mark.parametrize("md", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_markdown_links_resolve(md):
    assert link_problems(md) == []


def test_the_link_check_catches_a_missing_file_and_a_missing_anchor(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "a.md").write_text("# A page\n\n## Its `part` (one)\n")
    page = tmp_path / "README.md"
    page.write_text("[ok](docs/a.md) [ok](docs/a.md#its-part-one) [bad](docs/none.md)\n"
                    "[bad anchor](docs/a.md#nothing)\n```\n[in code](docs/x.md)\n```\n")
    found = link_problems(page)
    assert len(found) == 2
    assert "docs/none.md: no such file" in found[0]
    assert "docs/a.md#nothing: no heading" in found[1]


# ---- (b) paths mentioned ---------------------------------------------------------

PATH = re.compile(r"(?<![\w./$-])((?:docs|compare|native|tests|scripts|scenes)/[\w.*{},/\[\]+-]*[\w*}/\]])")

# Paths that are mentioned but are not files of the repository, each with why.
PATH_ALLOW = {
    # A made-up scene file in docs/errors.md's example of an error message.
    "scenes/x.toml",
}


def comments(path: Path) -> str:
    """The comments (and, for Python, docstrings) of a code file."""
    src = text(path)
    if path.suffix == ".py":
        parts = []
        try:
            for tok in tokenize.generate_tokens(io.StringIO(src).readline):
                if tok.type == tokenize.COMMENT:
                    parts.append(tok.string)
        except (tokenize.TokenError, IndentationError, SyntaxError):
            pass
        try:
            tree = ast.parse(src)
            for node in ast.walk(tree):
                if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
                    doc = ast.get_docstring(node, clean=False)
                    if doc:
                        parts.append(doc)
        except SyntaxError:
            pass
        return "\n".join(parts)
    if path.suffix in (".hpp", ".cpp", ".h", ".cu", ".in"):
        parts = re.findall(r"//[^\n]*", src) + re.findall(r"/\*.*?\*/", src, flags=re.S)
        return "\n".join(parts)
    if path.suffix == ".md":
        return src
    return "\n".join(m.group(0) for m in re.finditer(r"#[^\n]*", src))  # .sh, .toml, CMake


def expand_braces(p: str) -> list[str]:
    m = re.search(r"\{([^{}]*)\}", p)
    if not m:
        return [p]
    return [q for alt in m.group(1).split(",") for q in expand_braces(p[:m.start()] + alt + p[m.end():])]


def path_exists(p: str) -> bool:
    p = p.rstrip(".")
    for q in expand_braces(p):
        if any(c in q for c in "*?["):
            if not glob.glob(str(ROOT / q)):
                return False
        elif not (ROOT / q).exists():
            return False
    return True


def path_like(p: str) -> bool:
    """A file (its name has a suffix), a pattern, a folder written with a
    trailing slash, or a path two folders deep; "native/LAMMPS" (a ratio of
    engines) is none of these."""
    last = p.rstrip("/").rsplit("/", 1)[-1]
    return "." in last or any(c in p for c in "*?[{") or p.endswith("/") or p.count("/") >= 2


def path_problems(path: Path, body: str) -> list[str]:
    problems = []
    for lineno, line in enumerate(body.splitlines(), 1):
        for m in PATH.finditer(line):
            p = m.group(1)
            if p.endswith("'s"):
                p = p[:-2]
            if not path_like(p):
                continue
            if p in PATH_ALLOW or path_exists(p):
                continue
            problems.append(f"{path.relative_to(ROOT)}: {p}")
    return problems


def test_mentioned_paths_exist():
    found = []
    for md in markdown_files():
        found += path_problems(md, text(md))
    for f in code_files():
        found += path_problems(f, comments(f))
    assert found == []


SECTION = re.compile(r"\b(docs/\w+\.md),\s*\"([^\"]+)\"")


def headings(md_path: Path) -> list[str]:
    """The page's headings, and the first cells of its tables' rows (a row of
    a table of rules is named like a section)."""
    out = []
    for line in without_code_blocks(text(md_path)).splitlines():
        m = re.match(r"^#{1,6}\s+(.*?)\s*$", line) or re.match(r"^\|\s*([^|]+?)\s*\|", line)
        if m:
            out.append(re.sub(r"[`*]", "", m.group(1)))
    return out


def section_problems(path: Path, body: str) -> list[str]:
    """References of the form docs/X.md, "Section": a heading of X begins so."""
    flat = " ".join(re.sub(r"^\s*(//+|#+|\*+|/\*+)?\s*", "", line) for line in body.splitlines())
    problems = []
    for m in SECTION.finditer(flat):
        target, name = ROOT / m.group(1), m.group(2).rstrip(".,;: ")
        if target.exists() and not any(h.startswith(name) for h in headings(target)):
            problems.append(f"{path.relative_to(ROOT)}: {m.group(1)}, \"{name}\"")
    return problems


def test_mentioned_sections_exist():
    found = []
    for md in markdown_files():
        found += section_problems(md, text(md))
    for f in code_files():
        found += section_problems(f, comments(f))
    assert found == []


def test_the_path_check_catches_a_missing_file():
    page = ROOT / "README.md"
    assert path_problems(page, "see docs/no_such_page.md and compare/bench.py") == \
        ["README.md: docs/no_such_page.md"]
    assert path_problems(page, "scenes/drum/*.toml, scenes/drum/{A,B}.toml, native/tools/, native/LAMMPS") == []
    assert path_problems(page, "scenes/drum/*.nothing") == ["README.md: scenes/drum/*.nothing"]
    assert section_problems(page, '// docs/speed_accuracy.md, "Defaults"; docs/speed_accuracy.md,\n// "No such section"') == \
        ['README.md: docs/speed_accuracy.md, "No such section"']


# ---- (c) development-process words ----------------------------------------------

PROCESS = re.compile(
    r"\bstops? \d|\bstop \d+'s|\b(?:this|next|that|previous|last) stop\b|\bissues? #?\d|\bpart of issue"
    r"|\bsession|\blaunch [a-z]\b|\blaunch(?:es)? [a-z] of\b|(?<![\w&#/])#\d+\b|\bthe (?:issue|brief)\b",
    re.IGNORECASE)

# Legitimate uses of the words above, each with why.
PROCESS_ALLOW = [
    re.compile(r"start_new_session"),  # subprocess's option: a process group of its own
    re.compile(r"#[0-9a-fA-F]{6}\b"),  # colours
]


def process_problems(path: Path, body: str) -> list[str]:
    problems = []
    for lineno, line in enumerate(body.splitlines(), 1):
        rest = line
        for allow in PROCESS_ALLOW:
            rest = allow.sub("", rest)
        m = PROCESS.search(rest)
        if m:
            problems.append(f"{path.relative_to(ROOT)}:{lineno}: {line.strip()[:120]}")
    return problems


def test_no_development_process_words():
    found = []
    for f in sorted(set(markdown_files() + code_files())):
        found += process_problems(f, text(f))
    assert found == []


def test_the_process_check_catches_a_stop_number_and_leaves_run_names():
    page = ROOT / "README.md"
    assert process_problems(page, "measured at stop 45 (docs)") != []
    assert process_problems(page, "Part of issue 8.") != []
    assert process_problems(page, "see #47") != []
    assert process_problems(page, "drum #A and #T; the run stops; a stop request; color '#000000'") == []
