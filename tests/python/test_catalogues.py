"""Every list of the tasks that people read is made from the core's registry or checked against
it here, so adding a task cannot leave a page behind (issue 56): the README's task catalogue
(which the documentation site's home page includes, one source), every other Markdown table
of tasks, the site's navigation (filled by ``scripts/docs_hooks.py``), counts of tasks in prose,
and the module documentation that lists the tasks' files."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path
from typing import Any

import pytest

from panda_rapier.registration import TASK_EPISODE_STEPS, TASK_NAMES, TASKS

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"

#: The pages people read (the lab notes and the changelog are dated records, not catalogues).
PAGES = [
    README,
    ROOT / "models" / "README.md",
    ROOT / "docs" / "index.md",
    ROOT / "docs" / "benchmark.md",
    *sorted((ROOT / "docs" / "guide").glob("*.md")),
    *sorted((ROOT / "docs" / "contributing").glob("*.md")),
]

_NUMBERS = "one two three four five six seven eight nine ten eleven twelve".split()


def _tables(text: str) -> list[list[list[str]]]:
    """Every Markdown table of ``text`` (indented ones too), as rows of stripped cells,
    the header and the rule left out."""
    tables: list[list[list[str]]] = []
    current: list[list[str]] = []
    for line in [*text.splitlines(), ""]:
        stripped = line.strip()
        if stripped.startswith("|"):
            current.append([c.strip() for c in stripped.strip("|").split("|")])
        elif current:
            tables.append(current[2:])
            current = []
    return tables


def _catalogue_rows(text: str) -> list[list[str]]:
    """The rows of the README's task catalogue (between its snippet markers)."""
    match = re.search(r"\[start:tasks\] -->\n(.*?)<!-- --8<-- \[end:tasks\]", text, re.S)
    assert match, "README.md: the task catalogue's snippet markers are missing"
    tables = _tables(match.group(1))
    assert len(tables) == 1, "README.md: the task catalogue holds exactly one table"
    return tables[0]


def _rate(cell: str) -> list[float]:
    """The two percentages (ee / joints) at the start of an expert cell: ``"99.3 / 99.7 %"``."""
    match = re.match(r"([\d.]+) / ([\d.]+) %", cell)
    assert match, f"an expert cell reads 'EE / JOINTS %': {cell!r}"
    return [float(match.group(1)), float(match.group(2))]


def test_the_readme_catalogue_lists_every_task_with_the_registry_s_facts() -> None:
    figures = json.loads((ROOT / "docs" / "expert-figures.json").read_text())["figures"]
    rows = _catalogue_rows(README.read_text())
    assert [row[0] for row in rows] == [f"`{stem}`" for stem in TASK_NAMES.values()], (
        "README.md's task table lists the registry's tasks, in its order"
    )
    placing = {t["name"]: bool(t["has_placed"]) for t in TASKS}
    for (task, stem), row in zip(TASK_NAMES.items(), rows, strict=True):
        assert row[3] == f"{TASK_EPISODE_STEPS[task]} steps", f"{stem}: episode length"
        expected = []
        for env_id in (f"panda_rapier/{stem}-v0", f"panda_rapier/{stem}Joints-v0"):
            record = figures[env_id]
            # The README shows pick-and-place's placed rate (it says "placed"), else success.
            key = "placed_rate" if "placed" in row[4] and placing[task] else "success_rate"
            expected.append(round(100 * record[key], 1))
        assert _rate(row[4]) == expected, f"{stem}: expert figures of docs/expert-figures.json"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_table_of_tasks_lists_them_all(page: Path) -> None:
    """A table whose first column names three or more tasks (each once) is a catalogue: it
    names all of them (in an order of its own: the README's results go from easy to hard)."""
    stems = list(TASK_NAMES.values())
    for table in _tables(page.read_text()):
        first = [re.sub(r"[`*\[\]]|\(.*\)", "", row[0]).strip() for row in table if row]
        named = [cell for cell in first if cell in stems]
        if len(named) >= 3 and len(named) == len(set(named)):
            missing = sorted(set(stems) - set(named))
            assert not missing, f"{page.name}: a table of tasks leaves out {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_prose_counts_the_tasks_there_are(page: Path) -> None:
    """ "five tasks" in a page left behind when the sixth came."""
    for match in re.finditer(r"\b(\w+) (?:cube )?tasks\b", page.read_text(), re.I):
        word = match.group(1).lower()
        if word in _NUMBERS:
            assert _NUMBERS.index(word) + 1 == len(TASKS), f"{page.name}: {match.group(0)!r}"


def _module_doc(path: Path) -> str:
    """A Rust file's module documentation (its ``//!`` lines)."""
    lines = path.read_text().splitlines()
    return "\n".join(line[3:] for line in lines if line.startswith("//!"))


@pytest.mark.parametrize(
    "where",
    [
        "docs/contributing/architecture.md",
        "docs/contributing/layout.md",
        "docs/contributing/adding-a-task.md",
        "env-core/src/task/mod.rs",
        "policies/src/scripted/mod.rs",
    ],
)
def test_pages_that_list_the_task_files_list_them_all(where: str) -> None:
    """A paragraph that names three or more tasks by their file or type name (``push``,
    ``push.rs``, ``Push``, ``slide::Slide``) names every one: the architecture, layout and
    contributing pages and the module documentation of the task and expert modules."""
    path = ROOT / where
    text = _module_doc(path) if path.suffix == ".rs" else path.read_text()
    names = list(TASK_NAMES)
    for paragraph in re.split(r"\n\s*\n", text):
        hits = [n for n in names if re.search(rf"`{n}(?:\.rs)?`|\b{n}\.rs\b|\[`{n}::", paragraph)]
        hits += [
            n
            for n, stem in TASK_NAMES.items()
            if n not in hits and re.search(rf"\b{stem}\b", paragraph)
        ]
        if len(hits) >= 3:
            missing = sorted(set(names) - set(hits))
            assert not missing, f"{where}: a list of tasks leaves out {missing}: {paragraph[:80]!r}"


def _docs_hooks() -> Any:
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "scripts" / "docs_hooks.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_site_navigation_has_a_page_per_registered_task() -> None:
    nav: list[Any] = [{"Guide": [{"Tasks": ["tasks/index.md"]}]}]
    _docs_hooks().on_config({"nav": nav})
    pages = nav[0]["Guide"][0]["Tasks"]
    assert pages == ["tasks/index.md", *(f"tasks/{task}.md" for task in TASK_NAMES)]
    text = (ROOT / "mkdocs.yml").read_text()
    assert not re.search(r"tasks/(?!index)\w+\.md", text), "mkdocs.yml lists no task page by hand"


def test_the_site_home_includes_the_readme_catalogue() -> None:
    home = (ROOT / "docs" / "index.md").read_text()
    assert '--8<-- "README.md:tasks"' in home
    assert not _tables(home), "docs/index.md repeats no table: it includes README.md's"
