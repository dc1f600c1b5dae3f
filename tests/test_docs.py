"""The documentation site's invariants, checked without building it (no mkdocs needed; CI builds the site with
`mkdocs build --strict` after the tests, .ci/run).

- mkdocs.yml's nav names pages that exist, and every page under docs/ is in the nav;
- every public module of warpdyn has an API page that renders it (`::: warpdyn.<module>`);
- the tutorial (docs/tutorial.md) follows examples/tour.py as it says: each block tagged "# cell N" calls
  warpdyn exactly as the tour's cell N does (the same functions with the same arguments), the blocks cover
  every cell of the tour, and they run at build time, in one session, on the CPU;
- every warpdyn name a page's Python code uses exists (a renamed function fails here, not in a user's hands);
- the home page's set-up commands are README's, which CI runs;
- the griffe extension that renders the plain-prose docstrings escapes what Markdown would eat.
"""

import ast
import importlib
import importlib.util
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
MKDOCS = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
TOUR = ROOT / "examples" / "tour.py"
TUTORIAL = (DOCS / "tutorial.md").read_text(encoding="utf-8")

# A fenced Python block: its options (markdown-exec's exec="on" ...) and its code.
PYTHON_BLOCK = re.compile(r"^```python([^\n]*)\n(.*?)^```$", flags=re.S | re.M)


def nav_pages() -> list[str]:
    """The .md paths of mkdocs.yml's nav (its `- Title: path.md` and `- path.md` entries)."""
    nav = MKDOCS[MKDOCS.index("\nnav:\n") :]
    return re.findall(r"^\s+- (?:[^:\n]+: )?(\S+\.md)\s*$", nav, flags=re.M)


def doc_pages() -> list[str]:
    """Every Markdown page under docs/, but the build helpers of docs/_ext (mkdocs.yml's exclude_docs)."""
    return sorted(str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md") if "_ext" not in p.parts)


def public_modules() -> list[str]:
    """warpdyn's public modules: the submodules its __init__ lists in __all__, and the optional ones a user
    imports by name (warpdyn.envs, warpdyn.torch)."""
    init = ROOT / "warpdyn" / "__init__.py"
    names = next(
        ast.literal_eval(node.value)
        for node in ast.parse(init.read_text(encoding="utf-8")).body
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets)
    )
    modules = [n for n in names if (ROOT / "warpdyn" / f"{n}.py").exists() or (ROOT / "warpdyn" / n / "__init__.py").exists()]
    return sorted(set(modules) | {"envs", "torch"})


def test_nav_pages_exist():
    pages = nav_pages()
    assert len(pages) >= 20, pages  # a regex that found nothing would make the checks below vacuous
    missing = [p for p in pages if not (DOCS / p).is_file()]
    assert not missing, f"mkdocs.yml's nav names pages that do not exist: {missing}"
    assert len(set(pages)) == len(pages), "a page is twice in the nav"


def test_every_page_is_in_the_nav():
    """A page outside the nav is built but unreachable (the strict build warns too)."""
    assert sorted(set(doc_pages()) - set(nav_pages())) == []


def test_the_pages_the_site_promises_are_in_the_nav():
    pages = set(nav_pages())
    for page in ("index.md", "getting-started.md", "tutorial.md", "robots.md", "simulation.md", "differentiation.md", "rl.md",
                 "performance.md", "architecture.md", "mujoco_semantics.md", "formats_sdf.md", "porting.md", "api/index.md"):  # fmt: skip
        assert page in pages, page


@pytest.mark.parametrize("module", public_modules())
def test_every_public_module_has_an_api_page(module):
    """api/<module>.md is in the nav and renders warpdyn.<module> (mkdocstrings' `::: warpdyn.<module>`)."""
    page = f"api/{module}.md"
    assert page in nav_pages(), f"warpdyn.{module} has no API page in mkdocs.yml's nav ({page})"
    assert re.search(rf"^::: warpdyn\.{module}\s*$", (DOCS / page).read_text(encoding="utf-8"), flags=re.M), page


def test_api_pages_name_existing_modules():
    """Every `::: warpdyn.x.y` of the API pages is a module file of the package (mkdocstrings reads the sources
    statically: a module that is not there fails the build)."""
    identifiers = [m for p in (DOCS / "api").glob("*.md") for m in re.findall(r"^::: (\S+)", p.read_text(encoding="utf-8"), flags=re.M)]
    assert "warpdyn" in identifiers and len(identifiers) >= 17
    for identifier in identifiers:
        path = ROOT.joinpath(*identifier.split("."))
        assert path.with_suffix(".py").is_file() or (path / "__init__.py").is_file(), identifier


# --- the tutorial and examples/tour.py ---------------------------------------------------------------


def wd_calls(tree: ast.AST) -> list[ast.Call]:
    """The calls of warpdyn's API in `tree`: calls whose function is an attribute chain rooted at `wd`."""

    def root(node):
        while isinstance(node, ast.Attribute):
            node = node.value
        return node

    return [
        node for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and isinstance(root(node.func), ast.Name) and root(node.func).id == "wd"
    ]  # fmt: skip


def tour_calls() -> tuple[dict[int, set[str]], set[str]]:
    """({cell: the warpdyn calls of examples/tour.py's cell}, every warpdyn call of the file), as ast.unparse
    writes them. A cell runs from its '# --- cell N' marker to the next marker or the end of run_tour."""
    source = TOUR.read_text(encoding="utf-8")
    tree = ast.parse(source)
    markers = [(i + 1, int(m.group(1))) for i, line in enumerate(source.splitlines()) if (m := re.match(r"\s*# --- cell (\d+)", line))]
    end = next(node.end_lineno for node in tree.body if isinstance(node, ast.FunctionDef) and node.name == "run_tour")
    bounds = [(start, markers[k + 1][0] if k + 1 < len(markers) else end + 1, cell) for k, (start, cell) in enumerate(markers)]
    cells: dict[int, set[str]] = {cell: set() for _, _, cell in bounds}
    everywhere = set()
    for call in wd_calls(tree):
        everywhere.add(ast.unparse(call))
        for start, stop, cell in bounds:
            if start <= call.lineno < stop:
                cells[cell].add(ast.unparse(call))
    return cells, everywhere


def tutorial_blocks() -> list[tuple[str, str, list[int]]]:
    """(options, code, cells) of each Python block of the tutorial; cells from its first line '# cell N: ...'
    or '# cells N-M: ...' (empty for an untagged block)."""
    blocks = []
    for options, code in PYTHON_BLOCK.findall(TUTORIAL):
        tag = re.match(r"# cells? (\d+)(?:-(\d+))?:", code)
        cells = list(range(int(tag.group(1)), int(tag.group(2) or tag.group(1)) + 1)) if tag else []
        blocks.append((options, code, cells))
    return blocks


def test_tutorial_calls_warpdyn_as_the_tour_does():
    """Each warpdyn call of a tutorial block tagged with cell N is a call of the tour's cell N, with the same
    arguments; an untagged block's calls are calls of the tour anywhere."""
    cells, everywhere = tour_calls()
    checked = 0
    for _, code, tagged in tutorial_blocks():
        allowed = set().union(*(cells.get(c, set()) for c in tagged)) if tagged else everywhere
        for call in wd_calls(ast.parse(code)):
            text = ast.unparse(call)
            assert text in allowed, f"the tutorial's {text} is not examples/tour.py's (cells {tagged or 'any'}):\n{code}"
            checked += 1
    assert checked >= 30, checked


def test_tutorial_covers_every_cell_of_the_tour():
    cells, _ = tour_calls()
    ported = set(cells) - {1}  # cell 1 is the notebook's set-up (imports)
    assert ported >= set(range(3, 19)) and sum(1 for c in ported if cells[c]) >= 14, sorted(cells)
    covered = {c for _, _, tagged in tutorial_blocks() for c in tagged}
    assert ported <= covered, f"cells of examples/tour.py that the tutorial lacks: {sorted(ported - covered)}"


def test_tutorial_runs_at_build_time_on_the_cpu():
    """Every block runs (markdown-exec's exec="on") in one session and shows what it printed; the model is built
    on Warp's CPU device."""
    blocks = tutorial_blocks()
    assert len(blocks) >= 15
    for options, code, _ in blocks:
        assert 'exec="on"' in options and 'session="tour"' in options and 'result="text"' in options, options
    setup = blocks[0][1]
    assert re.search(r'^device = "cpu"$', setup, flags=re.M) and 'dtype = "float64"' in setup
    assert "device=device" in TUTORIAL


# --- code on the pages ----------------------------------------------------------------------------------


def page_code() -> list[tuple[str, str]]:
    """(page, code) of every Python block of every page."""
    return [(page, code) for page in doc_pages() for _, code in PYTHON_BLOCK.findall((DOCS / page).read_text(encoding="utf-8"))]


def test_page_code_parses():
    blocks = page_code()
    assert len(blocks) >= 25
    for page, code in blocks:
        try:
            ast.parse(code)
        except SyntaxError as error:
            pytest.fail(f"{page}: {error}\n{code}")


def test_page_code_names_exist():
    """Every attribute chain a page's code reads from warpdyn (`wd.model.step`, `wdt.rollout`, `envs.terms`...)
    exists in the installed package: also in the blocks the build does not run (the torch bridge, the RL
    environment), whose optional dependencies are the test extra's."""
    checked = 0
    for page, code in page_code():
        tree = ast.parse(code)
        aliases = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "warpdyn":
                        aliases[alias.asname or alias.name] = alias.name
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute):
                continue
            chain, base = [], node
            while isinstance(base, ast.Attribute):
                chain.append(base.attr)
                base = base.value
            if not isinstance(base, ast.Name) or base.id not in aliases:
                continue
            obj = importlib.import_module(aliases[base.id])
            for k, name in enumerate(reversed(chain)):
                if not hasattr(obj, name):
                    try:  # a submodule not imported by its package (warpdyn.envs.rsl_rl)
                        obj = importlib.import_module(f"{obj.__name__}.{name}")
                        continue
                    except (ImportError, AttributeError):
                        pass
                    pytest.fail(f"{page}: {base.id}.{'.'.join(reversed(chain))}: no {name!r} in {obj!r}")
                obj = getattr(obj, name)
                if not (isinstance(obj, type) or hasattr(obj, "__path__") or type(obj).__name__ == "module"):
                    break  # a function or a value: what follows is its own attribute, e.g. an array's .numpy
            checked += 1
    assert checked >= 100, checked


def test_home_page_commands_are_readmes():
    """The two set-up commands on the home page are README's (the second is what CI runs)."""
    shell = re.compile(r"^```shell\n(.*?)^```$", flags=re.S | re.M)
    readme = shell.findall((ROOT / "README.md").read_text(encoding="utf-8"))[:2]
    home = shell.findall((DOCS / "index.md").read_text(encoding="utf-8"))[:2]
    assert home == readme and len(home) == 2


# --- the rendering of docstrings ------------------------------------------------------------------------


def plain_prose():
    spec = importlib.util.spec_from_file_location("plain_prose", DOCS / "_ext" / "plain_prose.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_docstring_brackets_and_tags_are_escaped():
    """Units after a bracket, and XML elements, stay text (Markdown would read a reference link, which fails
    the strict build, and an HTML tag, which hides the word); code spans and code blocks stay as written."""
    escape = plain_prose().escape_docstring
    assert escape("(6,) [linear; angular] [m/s^2, rad/s^2]") == "(6,) [linear; angular] \\[m/s^2, rad/s^2]"
    assert escape("W_f [N, N m][N]") == "W_f [N, N m]\\[N]"
    assert escape("MJCF <actuator> and </b>") == "MJCF &lt;actuator> and &lt;/b>"
    assert escape("`<frame>` and `a] [b`") == "`<frame>` and `a] [b`"
    assert escape("a < b, [x], [y]") == "a < b, [x], [y]"
    assert escape("Example:\n\n    x = f(<a>)[0] [1]\n\nafter <b>") == "Example:\n\n    x = f(<a>)[0] [1]\n\nafter &lt;b>"


def test_docstring_lists_and_indented_blocks_are_separated():
    """A list, and an indented block introduced by a colon, right under a line of prose get the blank line
    Markdown needs; a hanging indent (no colon) stays part of its paragraph."""
    separate = plain_prose().separate_blocks
    assert separate("with these differences:\n- one\n- two") == "with these differences:\n\n- one\n- two"
    assert separate("force:\n    motor: u\n    servo: kp e") == "force:\n\n    motor: u\n    servo: kp e"
    assert separate('the shapes among "box",\n    "sphere" (default)') == 'the shapes among "box",\n    "sphere" (default)'
    assert separate("- one\n- two") == "- one\n- two"
