"""The documentation stands on its own: no citation a reader of the repository cannot resolve.

The papers are cited by authors, year and title (docs/design.md section 8), never by the
numbers of a private reading list ("seed 001"), and the contract is docs/design.md, never a
DESIGN.md kept outside the repository.
"""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: What a user of the repository reads: the package, the Rust crates, notebooks, docs, README.
SCOPE = ("python/softshadows", "rust", "notebooks", "docs", "README.md")
#: Build outputs and fuzz corpora under rust/ are not documentation.
SKIP_DIRS = {"target", "corpus", "artifacts", "__pycache__", ".ipynb_checkpoints"}

# The number may sit on the next comment line ("seed\n//! 004").
SEED = re.compile(r"\bseeds?[\s/!#*]*0\d\d\b", re.IGNORECASE)
# "DESIGN.md" in any case, except where it is the repository's own docs/design.md.
OUTSIDE_DESIGN = re.compile(r"(?<!docs/)design\.md", re.IGNORECASE)


def _text_files():
    for name in SCOPE:
        top = ROOT / name
        paths = [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
        for path in paths:
            if SKIP_DIRS.intersection(path.relative_to(ROOT).parts):
                continue
            data = path.read_bytes()
            if b"\0" in data[:8192]:  # binary: the compiled extension, images
                continue
            try:
                yield path, data.decode("utf-8")
            except UnicodeDecodeError:
                continue


def test_no_unresolvable_citations():
    hits = []
    for path, text in _text_files():
        for number, line in enumerate(text.splitlines(), 1):
            if SEED.search(line) or OUTSIDE_DESIGN.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not hits, "cite papers by authors, year and title, and the contract as docs/design.md:\n" + "\n".join(hits)


def test_the_design_sections_cited_exist():
    sections = set(re.findall(r"^## (\d+)\. ", (ROOT / "docs" / "design.md").read_text(), re.MULTILINE))
    cited = set()
    for path, text in _text_files():
        for match in re.finditer(r"docs/design\.md`? sections? (\d+)(?:\s*-\s*(\d+))?", text):
            first, last = int(match[1]), int(match[2] or match[1])
            cited.update(str(n) for n in range(first, last + 1))
    assert cited and cited <= sections, f"cited sections {sorted(cited - sections)} are not in docs/design.md"
