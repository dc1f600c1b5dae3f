"""The repository is self-contained: nothing in it reads a file outside it (a bare clone has nothing beside it).

Scanned: every file git tracks, but for the shipped URDF (a robot description, whose mesh URIs are
package:// names, not paths), benchmarks/results/ (what scripts printed, e.g. Warp's cache directory) and
this file (which spells out the patterns). Refused: a relative path that climbs out of the repository ("../" anywhere in a file,
but in a Markdown link that resolves inside the repository, as the docs' pages link each other), `Path(__file__).parents[k]` that reaches above the
repository's root, and absolute paths into home or work directories. Each finding names the file and line.
"""

import pathlib
import re
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[1]
CLIMB = re.compile(r"\.\./")
PARENTS = re.compile(r"parents\[(\d+)\]")
ABSOLUTE = re.compile(r"[\"'`(\s]/(?:work|home|root|Users|mnt)/")
MARKDOWN_LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)]*)?\)")


def _climbs_out(path: pathlib.Path, line: str) -> bool:
    """Whether the line names a path above the repository: any "../", but for Markdown links from a Markdown
    file that resolve inside the repository."""
    if path.suffix == ".md":
        links = MARKDOWN_LINK.findall(line)
        if any(not (path.parent / link).resolve().is_relative_to(ROOT) for link in links):
            return True
        line = MARKDOWN_LINK.sub("", line)
    return bool(CLIMB.search(line))


def _scanned(name: str) -> bool:
    return not (name.endswith(".urdf") or name.startswith("benchmarks/results/") or name == "tests/test_self_contained.py")


def _tracked_files() -> list[pathlib.Path]:
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return [ROOT / name for name in out.splitlines() if _scanned(name)]


def test_no_file_names_a_path_outside_the_repository():
    files = _tracked_files()
    assert any(f.name == "README.md" for f in files)  # git saw the repository (not an empty listing)
    findings = []
    for path in files:
        if not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:  # binary files (plots, reference arrays) name no paths
            continue
        depth = len(path.relative_to(ROOT).parts)  # parents[depth - 1] is the root; parents[depth] is outside
        for number, line in enumerate(text.splitlines(), 1):
            where = f"{path.relative_to(ROOT)}:{number}: {line.strip()[:120]}"
            if _climbs_out(path, line) or ABSOLUTE.search(line):
                findings.append(where)
            findings.extend(where for k in PARENTS.findall(line) if path.suffix == ".py" and int(k) >= depth)
    assert not findings, "these lines name paths outside the repository:\n" + "\n".join(findings)


def test_the_check_catches_what_it_is_for(tmp_path):
    """The patterns match the forms that broke bare clones (tests/robots.py read the models from the workplace
    folder beside the repository)."""
    outside = "/".join(["..", "shared"])  # assembled, so that this file names no such path itself
    assert CLIMB.search(f'ERGOCUB = ROOT / "{outside}/models/ergoCubSN001.urdf"')
    assert ABSOLUTE.search(f'open("/work/{outside[3:]}/models/x.urdf")')
    assert PARENTS.findall(f'pathlib.Path(__file__).resolve().parents[2] / "{outside[3:]}"') == ["2"]
    page = ROOT / "docs" / "api" / "index.md"
    assert not _climbs_out(page, "[Porting](../porting.md#tables)")  # a page beside it
    assert _climbs_out(page, f"[robot]({'/'.join(['..'] * 3)}/{outside[3:]}/models/x.urdf)")  # above the root
    assert _climbs_out(page, f"see {outside}/DESIGN.md")  # not a link
