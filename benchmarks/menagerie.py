"""warpdyn against MuJoCo over MuJoCo Menagerie: does each robot entry point load, and are M, h and the
accelerations MuJoCo's (float64, 1e-8)?

    python benchmarks/menagerie.py --menagerie PATH [--output FILE.md] [--only NAME ...] [--jobs 2]

PATH is a checkout of https://github.com/google-deepmind/mujoco_menagerie (nothing in the repository reads
it otherwise; nothing defaults to it).

Entry points. A robot directory is a top-level directory of the Menagerie with a LICENSE file (each model's
own directory; `assets/` and `test/` have none). Its entry points are its top-level *.xml files that MuJoCo
compiles on their own (fragments such as aloha/keyframe_ctrl.xml do not), less the scene wrappers: a file
that <include>s another top-level file of the directory (directly or through others) and compiles to the
same dynamics, i.e. the same nq, nv, nu, na, and the same M, qfrc_bias and qfrc_passive + qfrc_actuator at a
seeded random state to 1e-12 (a floor, lights, cameras, static props, keyframes, visual options). A scene that
adds degrees of freedom or actuators is an entry point of its own (franka_emika_panda/mjx_single_cube.xml
adds a free cube beside the Panda; pal_talos/talos_motor.xml adds motors to talos.xml). The script prints the
rule's outcome: the entry points, the wrappers and what each wraps, the files that do not compile alone.

The comparison (tests/mjcf_compare.py, shared with the tests: the state mapping is there, in one function):
MuJoCo with mjDSBL_CONSTRAINT only (warpdyn solves no contact, limit or friction constraints, and its equality
constraints are compared apart: the constrained column; every other term stays in, so unmodelled features show
up), ctrl = 0, at qpos0 at rest and at `--states` seeded random states (joint
positions within limits, random quaternions, velocities N(0, 1)). Columns: relative errors (to the largest
entry of MuJoCo's) of M (armature included), h (qfrc_bias), forces (qfrc_passive + qfrc_actuator at
ctrl = 0) and qacc; start: how far warpdyn's default state is from MuJoCo's qpos0 (absolute, base position
[m], quaternion, joint positions); constrained, for an entry point with equality constraints warpdyn enforces
(connects, welds, joint and fixed-tendon couplings): the relative error of one Euler step's velocity change against mj_step's with
MuJoCo's equality rows active (its contacts, limits and frictionloss off, damping explicit in both;
mjcf_compare.constrained_step_error), which an unmodelled force also shows. An entry point matches when M, h and
qacc are within --tol.

Missing meshes. A Menagerie copy may lack some mesh files (a snapshot without its largest files). With
--stand-in-missing-meshes, an entry point that names missing meshes is compiled from a temporary mirror of its
directory (links to the files) where each missing mesh is a 4 x 6 x 10 cm box: MuJoCo and warpdyn then read the same
stand-in, so the comparison still holds, but the robot is not quite Menagerie's (a body whose inertia comes
from that mesh changes); such rows say how many meshes were stood in. Without the flag they are reported as not
compiling.

Warp compiles each kernel once per model size; --jobs N spreads the entry points over N processes. The
warpdyn measured is the one `import warpdyn` finds (its commit is in the report's header): to measure a commit
while the working tree is being edited, run from a clean checkout of it with PYTHONPATH at that checkout, which
the worker processes inherit.

Attribution. Each loaded entry point that does not match is compared again with the force features MuJoCo has
and warpdyn does not model switched off in a copy of MuJoCo's compiled model (UNMODELLED_FORCES; one at a time,
then all together; the warpdyn model and the comparison unchanged): the report's last section says which of
them account for the difference.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import copy
import dataclasses
import datetime
import importlib.metadata as md
import multiprocessing
import os
import pathlib
import platform
import shutil
import struct
import subprocess
import sys
import tempfile
import warnings
import xml.etree.ElementTree as ET

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))

import mjcf_compare  # noqa: E402  (tests/mjcf_compare.py: the mapping shared with the tests)

STAND_IN_HALF = (0.02, 0.03, 0.05)
"""Half the sides [m] of the box that stands in for a missing mesh (not a cube: a capsule fitted to it by
fitaabb needs a longest axis, as realsense_d435i's)."""

SAME_DYNAMICS_TOL = 1e-12


# ------------------------------------------------------------------------------------------- missing meshes


def _box_triangles():
    a, b, c = STAND_IN_HALF
    corners = np.array([[x, y, z] for x in (-a, a) for y in (-b, b) for z in (-c, c)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return corners, faces


def write_stand_in(path: pathlib.Path) -> None:
    """A closed box mesh at `path`, in the format its extension names (OBJ, or binary STL)."""
    corners, faces = _box_triangles()
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".obj":
        lines = [f"v {x:g} {y:g} {z:g}" for x, y, z in corners] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
        path.write_text("\n".join(lines) + "\n")
    elif path.suffix.lower() == ".stl":
        body = b"".join(struct.pack("<12fH", *np.cross(corners[b] - corners[a], corners[c] - corners[a]), *corners[a], *corners[b], *corners[c], 0) for a, b, c in faces)
        path.write_bytes(b"stand-in".ljust(80, b" ") + struct.pack("<I", len(faces)) + body)
    else:
        raise ValueError(f"no stand-in for a mesh of type '{path.suffix}': {path}")


def meshes(xml: pathlib.Path) -> list[pathlib.Path]:
    """The mesh files `xml` names, as MuJoCo resolves them: relative to the meshdir (or assetdir, which sets it)
    of the file that declares the mesh (an attached model has its own), itself relative to the model file's
    directory. A mesh of an included file that MuJoCo's parser cannot find comes with an absolute guess beside
    the included file: left out (the included file's own list has it)."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(xml))
    return [xml.parent / mesh.compiler.meshdir / mesh.file for mesh in spec.meshes if mesh.file and not os.path.isabs(mesh.file)]


def parsed_meshes(xml: pathlib.Path) -> list[pathlib.Path]:
    """meshes(xml), none for a fragment that does not parse alone (the files including it name its meshes)."""
    try:
        return meshes(xml)
    except ValueError:
        return []


def missing_meshes(robot_dir: pathlib.Path) -> set[pathlib.Path]:
    """The missing mesh files that the top-level XML files of robot_dir name."""
    return {mesh for xml in robot_dir.glob("*.xml") for mesh in parsed_meshes(xml) if not mesh.exists()}


def stand_in_mirror(robot_dir: pathlib.Path, missing: set[pathlib.Path], into: pathlib.Path) -> pathlib.Path:
    """A mirror of robot_dir under `into` (a link for each file) with a stand-in for each missing mesh."""
    mirror = into / robot_dir.name
    for source in robot_dir.rglob("*"):
        if source.is_file():
            target = mirror / source.relative_to(robot_dir)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.symlink_to(source.resolve())
    for mesh in missing:
        write_stand_in(mirror / mesh.relative_to(robot_dir))
    return mirror


# ------------------------------------------------------------------------------------------- entry points


@dataclasses.dataclass
class Candidate:
    """A top-level XML of a robot directory: where MuJoCo compiles it from (a stand-in mirror if meshes are
    missing), how many meshes were stood in, the top-level files it includes, and why it does not compile."""

    path: pathlib.Path
    compile_path: pathlib.Path
    stand_ins: int = 0
    includes: tuple = ()
    error: str | None = None
    signature: tuple = ()
    dynamics: tuple = ()


def _included(xml: pathlib.Path, top_level: set[str]) -> set[str]:
    """The top-level files of xml's directory that xml includes, directly or through other top-level files."""
    found, todo = set(), [xml.name]
    while todo:
        try:
            root = ET.parse(xml.parent / todo.pop()).getroot()
        except (ET.ParseError, OSError):
            continue
        for element in root.iter("include"):
            name = element.get("file", "")
            if name in top_level and name not in found:
                found.add(name)
                todo.append(name)
    return found


def _dynamics(m) -> tuple:
    """M, qfrc_bias and qfrc_passive + qfrc_actuator at a seeded random state, constraints disabled."""
    ref = mjcf_compare.reference(m)
    qpos, qvel = mjcf_compare.mjcf_models.random_state(m, np.random.default_rng(0))
    q = mjcf_compare.mujoco_quantities(ref, qpos, qvel)
    return q["M"], q["h"], q["forces"]


def candidates(menagerie: pathlib.Path, stand_in: bool, scratch: pathlib.Path) -> list[Candidate]:
    import mujoco

    found = []
    for robot_dir in sorted(d for d in menagerie.iterdir() if d.is_dir() and (d / "LICENSE").is_file()):
        files = sorted(robot_dir.glob("*.xml"))
        names = {f.name for f in files}
        missing = missing_meshes(robot_dir) if stand_in else set()
        mirror = stand_in_mirror(robot_dir, missing, scratch) if missing else robot_dir
        for xml in files:
            c = Candidate(xml, mirror / xml.name, includes=tuple(sorted(_included(xml, names))))
            try:
                m = mujoco.MjModel.from_xml_path(str(c.compile_path))
            except ValueError as error:  # a fragment, or a missing file
                c.error = str(error).strip().splitlines()[0]
            else:
                c.stand_ins = len({mesh for f in (xml.name, *c.includes) for mesh in parsed_meshes(robot_dir / f) if mesh in missing})
                c.signature = (m.nq, m.nv, m.nu, m.na)
                c.dynamics = _dynamics(m)
            found.append(c)
    return found


def wrapped(c: Candidate, by_name: dict[str, Candidate]) -> str | None:
    """The included file whose dynamics `c` has (c is then a scene wrapper), or None."""
    def same(a, b) -> bool:
        return np.allclose(a, b, rtol=0, atol=SAME_DYNAMICS_TOL * max(1.0, np.abs(b).max(initial=0)))

    for name in c.includes:
        other = by_name[name]
        if other.error is None and other.signature == c.signature and all(map(same, c.dynamics, other.dynamics)):
            return name
    return None


def entry_points(menagerie: pathlib.Path, stand_in: bool, scratch: pathlib.Path):
    """(entry points, wrappers {path: wrapped file name}, not compiling {path: error}) by the module's rule."""
    found = candidates(menagerie, stand_in, scratch)
    entries, wrappers, broken = [], {}, {}
    for c in found:
        by_name = {o.path.name: o for o in found if o.path.parent == c.path.parent}
        if c.error is not None:
            broken[c.path] = c.error
        elif (inner := wrapped(c, by_name)) is not None:
            wrappers[c.path] = inner
        else:
            entries.append(c)
    return entries, wrappers, broken


# ------------------------------------------------------------------------------------------- comparison


def _init_worker() -> None:
    import warp as wp

    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    wp.set_device("cpu")


def _compare(args):
    path, states, seed = args
    return mjcf_compare.compare_file(path, np.float64, states, seed)


UNMODELLED_FORCES = ("dropped actuators", "tendon springs", "fluid forces")
"""Force features of MuJoCo's that warpdyn does not model (each named in a NotModelledWarning at load) and
that act with constraints off and ctrl = 0: actuators warpdyn drops (tendon or site transmissions, muscles,
plugins) whose bias acts at ctrl = 0, tendon stiffness and damping, and fluid forces."""


def _present(feature: str, mj, kept_actuators) -> bool:
    if feature == "dropped actuators":
        return any(_actuator_name(mj, k) not in kept_actuators for k in range(mj.nu))
    if feature == "tendon springs":
        return bool(np.any(mj.tendon_stiffness != 0) or np.any(mj.tendon_damping != 0))
    return mj.opt.density > 0 or mj.opt.viscosity > 0


def _actuator_name(mj, k: int) -> str:
    import mujoco

    return mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_ACTUATOR, k) or f"actuator{k}"


def _switched_off(mj, features, kept_actuators):
    """A copy of `mj` without `features` (UNMODELLED_FORCES): dropped actuators get zero gain and bias (all
    actuation disabled when every actuator is dropped, since a plugin actuator computes its own force),
    tendons zero stiffness and damping, the medium zero density and viscosity."""
    import mujoco

    m = copy.copy(mj)
    if "dropped actuators" in features:
        dropped = [k for k in range(m.nu) if _actuator_name(m, k) not in kept_actuators]
        if len(dropped) == m.nu:
            m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ACTUATION
        for k in dropped:
            m.actuator_gaintype[k] = mujoco.mjtGain.mjGAIN_FIXED
            m.actuator_biastype[k] = mujoco.mjtBias.mjBIAS_NONE
            m.actuator_gainprm[k] = 0.0
            m.actuator_biasprm[k] = 0.0
    if "tendon springs" in features:
        m.tendon_stiffness[:] = 0.0
        m.tendon_damping[:] = 0.0
    if "fluid forces" in features:
        m.opt.density = 0.0
        m.opt.viscosity = 0.0
    return m


def _attribute(args):
    """{"present": the UNMODELLED_FORCES `path` has, each of them and "all": compare_model's errors with it
    switched off}."""
    import mujoco
    import warpdyn as wd

    path, states, seed = args
    mj = mujoco.MjModel.from_xml_path(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = wd.model.Model.build_from_model_description(path, dtype=np.float64)
    kept = set(model.actuator_names())
    present = [f for f in UNMODELLED_FORCES if _present(f, mj, kept)]
    found = {"present": present}
    for off in [(f,) for f in present] + ([tuple(present)] if len(present) > 1 else []):
        found[" + ".join(off)] = mjcf_compare.compare_model(model, _switched_off(mj, off, kept), states, seed)
    return found


def _revision(folder: pathlib.Path) -> str:
    """`git rev-parse HEAD` of the checkout holding `folder`, "+dirty" if its tracked files differ; else unknown."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=folder, capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=folder, capture_output=True, text=True).stdout.strip()
    return head + ("+dirty" if dirty else "")


def _fmt(x: float | None) -> str:
    return "" if x is None else f"{x:.1e}"


def report(menagerie, scratch, revision, entries, wrappers, broken, results, attributed, tol, states, seed) -> str:
    import warpdyn

    def rel(text: str) -> str:
        """Paths in the Menagerie (or in a stand-in mirror of it) relative to its root."""
        return text.replace(str(scratch) + os.sep, "").replace(str(menagerie) + os.sep, "")

    loads = [r for r in results if r.refused is None]
    matching = [r for r in results if r.matches(tol)]
    versions = ", ".join(f"{p} {md.version(p)}" for p in ("mujoco", "warp-lang", "numpy"))
    lines = [
        "# warpdyn against MuJoCo over MuJoCo Menagerie",
        "",
        f"{datetime.date.today()}; {platform.processor() or platform.machine()}, Warp on the CPU, float64; {versions}; "
        f"warpdyn {_revision(pathlib.Path(warpdyn.__file__).parent)}; Menagerie {revision}.",
        f"`benchmarks/menagerie.py`: {states} random states (seed {seed}) and qpos0; mjDSBL_CONSTRAINT; ctrl = 0; tolerance {tol:g}.",
        "",
        f"**{len(loads)} of {len(results)} entry points load; {len(matching)} match MuJoCo's M, h and qacc to {tol:g}.**",
        "",
        "| entry point | loads | nq | nv | nu | M | h | forces | qacc | start | constrained | time [s] |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    stand_ins = {str(c.compile_path): c.stand_ins for c in entries}
    for r in results:
        name = rel(r.path) + (f" ({stand_ins[r.path]} stand-in meshes)" if stand_ins[r.path] else "")
        loaded = "yes" if r.refused is None else f"refused: {rel(r.refused)}"
        if r.mapping:
            loaded += f"; not mapped: {rel(r.mapping)}"
        if r.failed:
            loaded += f"; failed: {rel(r.failed)}"
        e = r.errors
        lines.append(
            f"| {name} | {loaded} | {r.nq} | {r.nv} | {r.nu} | {_fmt(e.get('M'))} | {_fmt(e.get('h'))} | {_fmt(e.get('forces'))} "
            f"| {_fmt(e.get('qacc'))} | {_fmt(e.get('start'))} | {_fmt(e.get('constrained'))} | {r.seconds:.1f} |"
        )
    lines += ["", "## Warnings at load", ""]
    lines += [f"- {rel(r.path)}: {rel(w)}" for r in results for w in r.warnings] or ["none"]
    lines += ["", "## Scene wrappers (same dynamics as the file they include)", ""]
    lines += [f"- {rel(str(p))} wraps {name}" for p, name in sorted(wrappers.items())] or ["none"]
    lines += ["", "## Top-level files MuJoCo does not compile on their own", ""]
    lines += [f"- {rel(str(p))}: {rel(error)}" for p, error in sorted(broken.items())] or ["none"]
    lines += [
        "",
        "## The entry points that differ, with MuJoCo's unmodelled forces switched off",
        "",
        "The largest of the M, h and qacc errors with each feature switched off in MuJoCo's model (the module docstring says how); "
        "a feature the entry point does not have is blank.",
        "",
        "| entry point | " + " | ".join(UNMODELLED_FORCES) + " | all of them | accounted for |",
        "| --- | " + "---: | " * (len(UNMODELLED_FORCES) + 1) + "--- |",
    ]
    for path, found in attributed.items():
        worst = {key: max(e[name] for name in mjcf_compare.MATCHED) for key, e in found.items() if key != "present"}
        present = found["present"]
        every = worst.get(" + ".join(present)) if present else None
        cells = [_fmt(worst.get(f)) if f in present else "" for f in UNMODELLED_FORCES]
        verdict = "no unmodelled force found" if not present else ("yes" if every <= tol else "no")
        lines.append(f"| {rel(path)} | " + " | ".join(cells) + f" | {_fmt(every) if len(present) > 1 else ''} | {verdict} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--menagerie", required=True, type=pathlib.Path, help="a checkout of mujoco_menagerie")
    parser.add_argument("--output", type=pathlib.Path, help="the Markdown report (default: stdout)")
    parser.add_argument("--only", nargs="+", default=(), help="entry points whose relative path contains one of these")
    parser.add_argument("--states", type=int, default=3, help="random states besides qpos0 (default 3)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--tol", type=float, default=1e-8)
    parser.add_argument("--jobs", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--stand-in-missing-meshes", action="store_true", help="compile with a box for each missing mesh")
    parser.add_argument("--revision", help="the Menagerie's commit, when PATH is not a git checkout")
    args = parser.parse_args(argv)

    menagerie = args.menagerie.resolve()
    if not menagerie.is_dir():
        parser.error(f"{menagerie} is not a directory")
    revision = args.revision or _revision(menagerie)
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="menagerie-stand-ins-"))
    try:
        entries, wrappers, broken = entry_points(menagerie, args.stand_in_missing_meshes, scratch)
        entries = [c for c in entries if not args.only or any(word in str(c.path.relative_to(menagerie)) for word in args.only)]
        print(f"{len(entries)} entry points:", *(str(c.path.relative_to(menagerie)) for c in entries), sep="\n  ", file=sys.stderr)
        print(f"{len(wrappers)} scene wrappers, {len(broken)} files not compiling alone", file=sys.stderr)
        work = [(str(c.compile_path), args.states, args.seed) for c in entries]
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(args.jobs, mp_context=context, initializer=_init_worker) as pool:
            results = []
            for c, r in zip(entries, pool.map(_compare, work)):
                results.append(r)
                print(f"{c.path.relative_to(menagerie)}: {'refused' if r.refused else r.errors} {r.seconds:.1f} s", file=sys.stderr, flush=True)
            differing = [r.path for r in results if r.refused is None and r.errors and not r.matches(args.tol)]
            attributed = dict(zip(differing, pool.map(_attribute, [(p, args.states, args.seed) for p in differing])))
        text = report(menagerie, scratch, revision, entries, wrappers, broken, results, attributed, args.tol, args.states, args.seed)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    if args.output:
        args.output.write_text(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
