"""JaxSim 0.9.0's results of the parity cases (tests/jaxsim/cases.py) into tests/jaxsim/reference.npz, and the
list of JaxSim's public names into tests/jaxsim/jaxsim_api.txt.

Run from the repository's root where JaxSim 0.9.0 is installed (`pip install jaxsim==0.9.0`; it needs no
Gazebo for SDF files): `python tests/jaxsim/generate_reference.py`. float64 (jax_enable_x64). A call that
raises in JaxSim is stored as its error (key `<case>/error`), so that the tests can say so. Each model and
representation runs in a process of its own (`--part MODEL REPRESENTATION`): XLA's CPU compiler ran out of
mappable memory after some hundreds of compiled calls in one. Not run by the tests or CI: JaxSim compiles
each call for seconds, hundreds of them here.
"""

from __future__ import annotations

import ast
import importlib.util
import pathlib
import subprocess
import sys
import tempfile
import traceback

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "jaxsim"))

import cases  # noqa: E402

MODULES = (
    "api/model.py", "api/data.py", "api/references.py", "api/link.py", "api/frame.py", "api/joint.py", "api/com.py",
    "api/contact.py", "api/kin_dyn_parameters.py", "api/ode.py", "api/integrators.py", "api/actuation_model.py",
    "api/common.py", "terrain/terrain.py", "rbda/contacts/common.py", "rbda/contacts/soft.py", "rbda/contacts/rigid.py",
    "rbda/contacts/relaxed_rigid.py", "math/__init__.py", "math/adjoint.py", "math/cross.py", "math/inertia.py",
    "math/joint_model.py", "math/quaternion.py", "math/rotation.py", "math/skew.py", "math/transform.py", "math/utils.py",
)  # fmt: skip
"""The JaxSim source files of the modules issue 34 names (jaxsim.api, jaxsim.math, jaxsim.terrain, jaxsim.rbda.contacts)."""


def public_names(package: pathlib.Path) -> list[str]:
    """`module.name` and `module.Class.method` of every public function, class, method and constant."""
    names = []
    for relative in MODULES:
        module = relative.removesuffix(".py").replace("/__init__", "").replace("/", ".")
        tree = ast.parse((package / relative).read_text())
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
                names.append(f"{module}.{node.name}")
            elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                names.append(f"{module}.{node.name}")
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and not item.name.startswith("_"):
                        names.append(f"{module}.{node.name}.{item.name}")
            elif isinstance(node, ast.Assign):
                names += [f"{module}.{t.id}" for t in node.targets if isinstance(t, ast.Name) and not t.id.startswith("_")]
    return names


def math_part(into: pathlib.Path) -> None:
    """JaxSim's results of cases.math_calls into the file `into` (.npz), keys `math/<call>`."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxsim.math
    import jaxsim.rbda.contacts
    import jaxsim.terrain

    out = {}
    for call, run in cases.math_calls(jaxsim.math, jaxsim.terrain, jaxsim.rbda.contacts).items():
        try:
            out.update(cases.flatten(cases.host(run()), f"math/{call}"))
        except Exception as error:  # noqa: BLE001 (JaxSim's own failures are data here)
            out[f"math/{call}/error"] = np.asarray(f"{type(error).__name__}: {str(error).splitlines()[0][:200]}")
            traceback.print_exc(limit=1)
    np.savez_compressed(into, **out)


def part(name: str, representation: str, into: pathlib.Path) -> None:
    """JaxSim's results of one model in one representation into the file `into` (.npz)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxsim.api as js

    spec = cases.MODELS[name]
    model = js.model.JaxSimModel.build_from_model_description((ROOT / spec["path"]).read_text(), considered_joints=spec["considered_joints"])
    out = {}
    if representation == cases.REPRESENTATIONS[0]:
        for kind, names in (("links", model.link_names()), ("joints", model.joint_names()), ("frames", model.frame_names())):
            out[f"{name}/{kind}"] = np.asarray(names, dtype=str)
        out[f"{name}/points"] = np.asarray(model.kin_dyn_parameters.contact_parameters.point)
    kwargs = cases.state(name, model.joint_names(), model.floating_base())
    x = cases.inputs(name, model.dofs(), model.number_of_links()) | {"link": spec["link"], "frame": spec["frame"]}
    data = js.data.JaxSimModelData.build(model=model, velocity_representation=getattr(js.common.VelRepr, representation), **kwargs)
    for call, run in cases.calls(js, model, data, x).items():
        key = f"{name}/{representation}/{call}"
        try:
            out.update(cases.flatten(cases.host(run()), key))
        except Exception as error:  # noqa: BLE001 (JaxSim's own failures are data here)
            out[f"{key}/error"] = np.asarray(f"{type(error).__name__}: {str(error).splitlines()[0][:200]}")
            traceback.print_exc(limit=1)
        print(key, flush=True)
    np.savez_compressed(into, **out)


def main() -> None:
    import jaxsim

    package = pathlib.Path(importlib.util.find_spec("jaxsim").origin).parent
    (ROOT / "tests" / "jaxsim" / "jaxsim_api.txt").write_text("\n".join(public_names(package)) + "\n")
    out = {"jaxsim_version": np.asarray(jaxsim.__version__)}
    with tempfile.TemporaryDirectory() as folder:
        for name in cases.MODELS:
            for representation in cases.REPRESENTATIONS:
                into = pathlib.Path(folder) / f"{name}_{representation}.npz"
                subprocess.run([sys.executable, __file__, "--part", name, representation, str(into)], check=True)
                out.update(dict(np.load(into)))
        into = pathlib.Path(folder) / "math.npz"
        subprocess.run([sys.executable, __file__, "--math", str(into)], check=True)
        out.update(dict(np.load(into)))
    np.savez_compressed(ROOT / "tests" / "jaxsim" / "reference.npz", **out)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--part"]:
        part(sys.argv[2], sys.argv[3], pathlib.Path(sys.argv[4]))
    elif sys.argv[1:2] == ["--math"]:
        math_part(pathlib.Path(sys.argv[2]))
    else:
        main()
