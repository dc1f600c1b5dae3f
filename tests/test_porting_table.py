"""docs/porting.md, the porting table, covers JaxSim 0.9.0's public names and points at real tests.

Reference: tests/jaxsim/jaxsim_api.txt, every public function, class, method and constant of the JaxSim 0.9.0
modules issue 34 names (jaxsim.api, jaxsim.math, jaxsim.terrain, jaxsim.rbda.contacts), listed from JaxSim's
source by tests/jaxsim/generate_reference.py. Each has exactly one row; every "same" or "alias" row names a
test that exists (a parity case of tests/jaxsim/cases.py, or a test of tests/test_jaxsim_api.py) and a warpdyn
object that exists; every "different", "planned" or "n/a" row gives its reason.
"""

from __future__ import annotations

import ast
import dataclasses
import pathlib
import re
import sys

import numpy as np

import warpdyn as wd

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "jaxsim"))

import cases  # noqa: E402

STATUSES = ("same", "alias", "different", "planned", "n/a")


def documented_name(name: str) -> str:
    """jaxsim_api.txt's `api.model.reduce` as the table writes it, `js.model.reduce`; `math.adjoint.Adjoint` as
    `jaxsim.math.Adjoint` (JaxSim's packages export their submodules' names)."""
    parts = name.split(".")
    if parts[0] == "api":
        return "js." + ".".join(parts[1:])
    if parts[0] == "math":
        return "jaxsim.math." + ".".join(parts[1:] if len(parts) == 2 else parts[2:])
    if parts[0] == "terrain":
        return "jaxsim.terrain." + ".".join(parts[2:])
    if parts[:2] == ["rbda", "contacts"]:
        return "jaxsim.rbda.contacts." + ".".join(parts[3:])
    raise ValueError(name)


def rows() -> dict[str, list[str]]:
    """{JaxSim name: [warpdyn, status, notes, test]} of docs/porting.md's tables."""
    out = {}
    for line in (ROOT / "docs" / "porting.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[0].startswith("`") and cells[2] in STATUSES:
            name = cells[0].strip("`")
            assert name not in out, f"{name} has two rows"
            out[name] = cells[1:]
    return out


def test_every_jaxsim_name_has_one_row_with_a_status():
    """One row per public name of JaxSim 0.9.0, no row for a name JaxSim has not; a status from STATUSES."""
    names = [documented_name(n) for n in (ROOT / "tests" / "jaxsim" / "jaxsim_api.txt").read_text().split()]
    table = rows()
    assert len(names) > 250
    missing = sorted(set(names) - set(table))
    extra = sorted(set(table) - set(names))
    assert not missing, f"JaxSim names without a row: {missing}"
    assert not extra, f"rows for names JaxSim 0.9.0 does not have: {extra}"


def _api_tests(file: str = "test_jaxsim_api.py") -> set[str]:
    tree = ast.parse((ROOT / "tests" / file).read_text())
    return {node.name for node in tree.body if isinstance(node, ast.FunctionDef) and node.name.startswith("test_")}


def _parity_calls() -> set[str]:
    model = wd.model.Model.build_from_model_description((ROOT / cases.MODELS["arm"]["path"]).read_text(), dtype=np.float64)
    hopper = wd.model.Model.build_from_model_description((ROOT / cases.MODELS["hopper"]["path"]).read_text(), dtype=np.float64)
    found = set()
    for m, name in ((model, "arm"), (hopper, "hopper")):
        x = cases.inputs(name, m.dofs(), m.number_of_links()) | {"link": cases.MODELS[name]["link"], "frame": cases.MODELS[name]["frame"]}
        found |= set(cases.calls(wd, m, wd.data.Data.build(m), x))
    return found


def test_same_and_alias_rows_name_existing_tests_and_objects():
    """Every same/alias row names a test that exists, and its warpdyn object exists (the JaxSim name with js. as
    wd., jaxsim. as warpdyn., or the object the warpdyn column names); different/planned/n/a rows give a reason."""
    table = rows()
    api_tests, parity, math = _api_tests(), _parity_calls(), set(cases.math_calls(wd.math, wd.terrain, wd.rbda.contacts))
    problems = []
    for name, (warpdyn_name, status, notes, test) in table.items():
        if status in ("different", "planned", "n/a"):
            if not notes:
                problems.append(f"{name}: {status} without a reason")
            continue
        kind, _, what = test.partition(":")
        known = {"api": api_tests, "parity": parity, "math": math, "contacts": _api_tests("test_contact_models.py"),
                 "constraints": _api_tests("test_kinematic_constraints.py")}.get(kind, set())  # fmt: skip
        if what not in known:
            problems.append(f"{name}: its test '{test}' does not exist")
        target = warpdyn_name.strip("`") if warpdyn_name.startswith("`") and warpdyn_name.strip("`").startswith("wd.") else None
        path = target or re.sub(r"^js\.", "wd.", re.sub(r"^jaxsim\.", "wd.", name))
        obj = wd
        for part in path.split(".")[1:]:
            fields = {f.name for f in dataclasses.fields(obj)} if dataclasses.is_dataclass(obj) else set()
            obj = getattr(obj, part, None)
            if obj is None:
                if part in fields or part in ("description", "built_from"):  # instance attributes
                    break
                problems.append(f"{name}: {path} does not exist in warpdyn")
                break
    assert not problems, "\n".join(problems)
