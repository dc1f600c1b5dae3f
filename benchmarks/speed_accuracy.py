"""The speed/accuracy trade of a simulation: integrator x time step x dtype x contact model (and stiffness).

    python benchmarks/speed_accuracy.py [--device cuda:0] [--joints pd | passive | servo | servo-explicit]
                                        [--envs N] [--steps T] [--contacts soft,relaxed,rigid]
                                        [--repeats 11] [--ks 1e4,1e5,1e6,1e7] [--dts 1e-4,...]
                                        [--dtypes float32,float64] [--integrators SIE,RK4] [--d-scale 1]
                                        [--tag cpu] [--recompute-reference] [--no-throughput]

Needs matplotlib for the plot (a benchmark-only dependency, not one of warpdyn's: `pip install
matplotlib`); without it the table is still written.

Scene: the seed's ergoCub legs (benchmarks/common.py: 12 joints, 13 links, the 32 collidable points of
the ankle boxes) on flat ground (mu = 0.5, p = q = 0.5), dropped from rest with its lowest point 5 cm
above the ground; 4 drops (environments), each with the base tilted by up to 3 degrees about x and y and
the joints offset by up to 0.05 rad (seeded), so that a heel or a toe lands first (t ~ 0.1 s); then 0.3 s
of landing and settling (horizon 0.4 s). Errors are taken over the 4 drops. The joints are held by a PD
to s = 0 with fixed gains, Kp = 3000 N m/rad (as the standing test in tests/test_simulation.py) and
Kd = 7 N m s/rad, realised inside the step's actuation kernel so that a whole rollout is one graph: the
joint-limit spring with both limits at 0 (spring Kp, limit damper 0) and the viscous joint friction Kd;
Coulomb joint friction off. Like every joint torque of
`wd.model.step`, the PD torque is computed once per step from the state at its start and held during
the step (also across RK4's stages), as a controller running at the simulation rate would be: a
zero-order hold, which makes every integrator first order in the actuation, and which bounds dt: with
scalar gains the joint modes decouple along the eigenvectors of (M^-1)_ss (the joint block of the inverse
free-floating mass matrix), and the stiffest, inertia I = 1 / lambda_max((M^-1)_ss) (7.6e-3 kg m^2 at the
initial pose, printed), is stable for semi-implicit Euler while dt^2 Kp / I + 2 dt Kd / I < 4 and, with the
torque held over RK4's stages (exact integration of a constant force), while dt < 2 I / Kd and
dt < 2 Kd / Kp. Both limits are printed (1.61 and 2.16 ms here; a probe at other dt found SIE stable at
1.5 ms and flagged in flight at 1.7 ms, RK4 stable at 2.0 ms and flagged at 2.25 ms).
`--joints passive`: no joint torque at all (no PD, Coulomb and viscous friction off): every force is then
evaluated at each RK4 stage, which isolates the integrators; the legs fold after landing.
`--joints servo`: the same gains as MuJoCo writes a servo: a position actuator per joint (`wd.model.add_actuators`,
kp = Kp, ctrl = 0) and the joint damper `damping` = Kd, which the semi-implicit Euler integrates implicitly
(model.implicit_damping, MuJoCo's Euler: (M + dt Kd) nu_dot = f); both are evaluated at each RK4 stage.
With the damping implicit the held-spring mode is stable while dt^2 Kp/I - 2 dt Kd/I < 4 (the damping now
widens the range, printed); `--joints servo-explicit`: the same with the damping explicit (model.implicit_damping
= False), stable while dt^2 Kp/I + 2 dt Kd/I < 4 as the held PD. Both servo modes share one reference.

Contact models (--contacts): `soft` (JaxSim's soft contacts, at each stiffness of --ks, below), `relaxed`
(JaxSim's RelaxedRigidContacts with its default parameters) and `rigid` (JaxSim's RigidContacts: mu = 0.5, its
default Baumgarte K = D = 0, and its impact after each step); each setting is compared with a reference of the
same model. The soft law's stiffness K in {1e4, 1e5, 1e6 (JaxSim's default), 1e7} N/m^1.5 with D = 2000 (K / 1e6)^(2/3)
N s/m^1.5: JaxSim's default pair at K = 1e6, and the same damping ratio at every K. (Hunt/Crossley with
p = q = 1/2 linearised about a static sink delta* = (F / K)^(2/3) has stiffness 1.5 K delta*^(1/2) and
damping D delta*^(1/2), so its damping ratio scales as D K^(-2/3) for any load F.) `--d-scale c` multiplies
every D by c (a probe of the damping's role; results tagged _D<c>x). K changes the physics
itself (how deep and how long the feet sink and bounce), so every setting is compared with the reference
of the same K.

Reference: RK4 in float64 at dt = 1e-5 s on the CPU, per contact setting; computed once and cached in
results/speed_accuracy_reference[_passive].npz (with the scene's parameters, checked on load), which a GPU
run reuses. Its own error, estimated by the same comparison at dt = 2e-5 s, is printed and written down:
errors of that size (~1e-5 m) are the reference's, not the setting's.

Sweep: integrator {SemiImplicitEuler, RungeKutta4} x dt {0.1, 0.2, 0.5, 1, 2, 4 ms} x dtype {float32,
float64} x K. Outcomes:
- refused: `step` raises ValueError because dt K / D reaches the tangential deformation's stability limit
  (2 for semi-implicit Euler, 2.785 for RK4: warpdyn/_simulation.py DEFORMATION_STABILITY);
- flagged: some drop's state became non-finite and data.healthy went to 0 (how many, and the first time);
- ok: the errors, against the reference sampled every 4 ms (a multiple of every dt):
  base [m]: max over drops and time of |p_B - p_B,ref| (and the median over drops of each drop's max);
  tilt [deg]: max over drops and time of the angle between the base orientations; joints [rad]: RMS over
  drops, time and joints of s - s_ref.
The accuracy runs simulate the 4 drops as one batch (N = 4); an environment's numbers do not depend on N.

Throughput: `wd.simulation.Rollout.run` of --steps steps (graph-replayed: CUDA graph on GPUs, Warp's CPU
graph on the CPU) for --envs environments standing in contact (the drops' poses, cycled, lowered so the
lowest point is 2 +- 1 mm deep), the median over --repeats runs after a warm-up, divided by the steps;
env-steps/s = N / (seconds per step); sim-s/s = env-steps/s x dt is the simulated time per wall-clock
second summed over the environments: what a fixed amount of simulated experience costs. A step launches
the same kernels whatever dt (dt is a scalar argument), so the step time is measured once per
(integrator, dtype, contact setting), at the smallest dt, and used for every dt. CPU: N = 256, 32 steps, 11 repeats by
default; GPU: N = 16384, 100 steps.

Writes results/speed_accuracy_<tag>[_passive][_D<c>x][_<contacts>].md (header, table, summary) and .png (error
against sim-s/s, one panel per contact setting; not with --no-throughput; _<contacts> unless --contacts soft), tag = cpu or the GPU's name (e.g.
nvidia_h100_80gb_hbm3), or --tag. The reference is always computed on the CPU (float64), wherever the
sweep runs; commit the .npz so that a GPU machine only loads it.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import re
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, median_time, seed_model

RESULTS = pathlib.Path(__file__).resolve().parent / "results"

SIE = wd.model.IntegratorType.SemiImplicitEuler
RK4 = wd.model.IntegratorType.RungeKutta4
SHORT = {SIE: "SIE", RK4: "RK4"}

SCENE = {
    "drop": 0.05,  # [m] lowest collidable point above the ground at t = 0
    "drops": 4,  # environments, each its own tilt and joint offsets
    "tilt_deg": 3.0,  # base rotation about x, then y, uniform in +- this [deg] (seeded)
    "joint_offset": 0.05,  # [rad] joints uniform in +- this (seeded)
    "seed": 0,
    "kp": 3000.0,  # [N m/rad]
    "kd": 7.0,  # [N m s/rad]
    "mu": 0.5,
    "horizon": 0.4,  # [s]
    "sample": 4e-3,  # [s] comparison grid
    "reference_dt": 1e-5,  # [s] float64 RK4
    "joints": "pd",  # or "passive" (--joints)
    "d_scale": 1.0,  # D multiplied by this (--d-scale)
}
K_VALUES = (1e4, 1e5, 1e6, 1e7)
DTS = (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 4e-3)


def contact_settings(contacts: list[str], ks: list[float]) -> list[dict]:
    """The contact settings of --contacts: {label, kind, K, D} (K and D the soft law's; nan for the others)."""
    out = []
    for kind in contacts:
        if kind == "soft":
            out += [{"label": f"soft K={K:g}", "kind": "soft", "K": K, "D": damping(K)} for K in ks]
        elif kind in ("relaxed", "rigid"):
            out.append({"label": kind, "kind": kind, "K": np.nan, "D": np.nan})
        else:
            raise ValueError(f"--contacts: unknown model {kind!r} (soft, relaxed, rigid)")
    return out


def damping(K: float) -> float:
    """D [N s/m^1.5] for stiffness K: JaxSim's default (K, D) = (1e6, 2000) and its damping ratio at any K,
    times SCENE["d_scale"] (--d-scale)."""
    return SCENE["d_scale"] * 2000.0 * (K / 1e6) ** (2.0 / 3.0)


# ------------------------------------------------------------------------------------------------ scene


def scene_model(base, integrator, dt: float, setting: dict):
    """A fresh copy of `base` (the legs) with the scene's joints (PD or passive), the contact setting (model and
    parameters) and the integrator."""
    model = wd.model.reduce(base, base.joint_names())
    n = model.dofs()
    if SCENE["joints"].startswith("servo"):
        model = wd.model.add_actuators(model, "position", kp=SCENE["kp"])
        model.set_joint_parameters(friction_static=np.zeros(n), friction_viscous=np.zeros(n), damping=np.full(n, SCENE["kd"]))
        model.implicit_damping = SCENE["joints"] == "servo"
    elif SCENE["joints"] == "pd":
        model.set_joint_parameters(
            position_limits=np.zeros((n, 2)),
            limit_spring=np.full(n, SCENE["kp"]),
            limit_damper=np.zeros(n),
            friction_static=np.zeros(n),
            friction_viscous=np.full(n, SCENE["kd"]),
        )
    else:
        model.set_joint_parameters(friction_static=np.zeros(n), friction_viscous=np.zeros(n))
    contacts = wd.rbda.contacts
    if setting["kind"] == "soft":
        model.contact_params = wd.model.SoftContactsParams(K=setting["K"], D=setting["D"], mu=SCENE["mu"])
    elif setting["kind"] == "relaxed":
        model.apply_settings(contact_model=contacts.RelaxedRigidContacts.build(), contact_params=contacts.RelaxedRigidContactsParams())
    else:
        model.apply_settings(contact_model=contacts.RigidContacts.build(), contact_params=contacts.RigidContactsParams(mu=SCENE["mu"]))
    model.integrator = integrator
    model.time_step = float(dt)
    return model


def _quaternion(rx_deg: float, ry_deg: float) -> np.ndarray:
    """(w, x, y, z) of R = R_x(rx) R_y(ry)."""
    ax, ay = np.radians(rx_deg) / 2, np.radians(ry_deg) / 2
    qx = np.array([np.cos(ax), np.sin(ax), 0.0, 0.0])
    qy = np.array([np.cos(ay), 0.0, np.sin(ay), 0.0])
    w1, x1, y1, z1 = qx
    w2, x2, y2, z2 = qy
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def initial_state(base) -> dict:
    """The drops' initial states (NumPy, float64, leading axis: the drops): base pose and joint positions,
    at rest, the lowest collidable point SCENE["drop"] above the ground."""
    n, count = base.dofs(), SCENE["drops"]
    rng = np.random.default_rng(SCENE["seed"])
    s0 = rng.uniform(-SCENE["joint_offset"], SCENE["joint_offset"], (count, n))
    tilts = rng.uniform(-SCENE["tilt_deg"], SCENE["tilt_deg"], (count, 2))
    q0 = np.array([_quaternion(*t) for t in tilts])
    p0 = np.zeros((count, 3))
    for i in range(count):
        data = wd.data.Data.build(base, base_quaternion=q0[i], joint_positions=s0[i])
        p0[i, 2] = SCENE["drop"] - float(wd.contact.collidable_point_positions(base, data).numpy()[:, 2].min())
    return {"base_position": p0, "base_quaternion": q0, "joint_positions": s0}


def pd_limits(base, init: dict) -> tuple[float, float, float]:
    """(I [kg m^2], SIE's dt limit [s], RK4's dt limit [s]) of the held joint PD (see the module docstring),
    at the first drop's initial pose."""
    data = wd.data.Data.build(base, **{k: v[0] for k, v in init.items()})
    M = np.asarray(wd.model.free_floating_mass_matrix(base, data).numpy(), dtype=np.float64)
    lam = float(np.linalg.eigvalsh(np.linalg.inv(M)[6:, 6:]).max())
    kp, kd = SCENE["kp"] * lam, SCENE["kd"] * lam  # omega^2 and c of the stiffest mode
    sie = (-2.0 * kd + np.sqrt(4.0 * kd**2 + 16.0 * kp)) / (2.0 * kp)  # dt^2 kp + 2 dt kd = 4
    rk4 = min(2.0 / kd, 2.0 * kd / kp)
    if SCENE["joints"] == "servo":  # damping implicit: dt^2 kp - 2 dt kd = 4
        sie = (2.0 * kd + np.sqrt(4.0 * kd**2 + 16.0 * kp)) / (2.0 * kp)
    if SCENE["joints"].startswith("servo"):  # RK4 on x'' = -kp x - kd x' (forces at each stage): |R(dt lambda)| <= 1
        lam_ = np.roots([1.0, kd, kp])
        stable = lambda dt: all(abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) <= 1.0 for z in dt * lam_)  # noqa: E731
        lo, hi = 0.0, 1.0
        for _ in range(60):
            lo, hi = ((lo + hi) / 2, hi) if stable((lo + hi) / 2) else (lo, (lo + hi) / 2)
        rk4 = lo
    return 1.0 / lam, float(sie), float(rk4)


def trajectory(model, init: dict) -> dict:
    """The drops' trajectories sampled every SCENE["sample"] s (arrays (samples, drops, ...)): one batch, a
    graph-replayed Rollout of sample / dt steps per sample, restarted from its own final state. Raises
    ValueError where `step` refuses the setting."""
    dt = model.time_step
    k = int(round(SCENE["sample"] / dt))
    if abs(k * dt - SCENE["sample"]) > 1e-9 * SCENE["sample"]:
        raise ValueError(f"dt = {dt} does not divide the sample interval {SCENE['sample']}")
    chunks = int(round(SCENE["horizon"] / SCENE["sample"]))
    roll = wd.simulation.Rollout(model, steps=k, record=("valid",))
    count = SCENE["drops"]
    data = wd.data.Data.build(model, num_envs=count, **init)
    out = {
        "t": np.arange(chunks + 1) * SCENE["sample"],
        "base_position": np.empty((chunks + 1, count, 3)),
        "base_quaternion": np.empty((chunks + 1, count, 4)),
        "joint_positions": np.empty((chunks + 1, count, model.dofs())),
        "valid": np.empty((chunks + 1, count), dtype=np.int32),
    }

    def keep(i, d):
        out["base_position"][i] = d.base_position.numpy()
        out["base_quaternion"][i] = d.base_quaternion.numpy()
        out["joint_positions"][i] = d.joint_positions.numpy()
        out["valid"][i] = d.healthy.numpy()

    keep(0, data)
    for i in range(1, chunks + 1):
        data, _ = roll.run(data)
        keep(i, data)
    return out


def errors(run: dict, ref: dict) -> dict:
    """Errors of a trajectory against the reference on the common grid (see the module docstring)."""
    base = np.linalg.norm(run["base_position"] - ref["base_position"], axis=-1)  # (samples, drops)
    dot = np.abs(np.sum(run["base_quaternion"] * ref["base_quaternion"], axis=-1))
    dot /= np.linalg.norm(run["base_quaternion"], axis=-1) * np.linalg.norm(ref["base_quaternion"], axis=-1)
    tilt = np.degrees(2.0 * np.arccos(np.clip(dot, 0.0, 1.0)))
    joints = run["joint_positions"] - ref["joint_positions"]
    return {
        "base": float(base.max()),
        "base_median": float(np.median(base.max(axis=0))),
        "tilt": float(tilt.max()),
        "joints": float(np.sqrt(np.mean(joints**2))),
    }


# -------------------------------------------------------------------------------------------- reference


def _reference_joints() -> str:
    """The joints of the reference: the servo modes differ only in how the Euler integrates the damping."""
    return "servo" if SCENE["joints"].startswith("servo") else SCENE["joints"]


def reference_path() -> pathlib.Path:
    joints = _reference_joints()
    return RESULTS / ("speed_accuracy_reference.npz" if joints == "pd" else f"speed_accuracy_reference_{joints}.npz")


def reference(base64, init: dict, settings: list, recompute: bool, device) -> tuple[dict, str, bool]:
    """({label: trajectory}, note, computed) of float64 RK4 at SCENE["reference_dt"] per contact setting, from the
    cache file when it matches the scene."""
    path = reference_path()
    scene = {k: v for k, v in SCENE.items() if k != "d_scale"}  # D is in each trajectory's key
    scene["joints"] = _reference_joints()
    meta = {"scene": scene, "robot": base64.name(), "dofs": base64.dofs()}
    names = ("t", "base_position", "base_quaternion", "joint_positions", "valid")
    key = lambda s: f"K{s['K']:g}_D{s['D']:.6g}" if s["kind"] == "soft" else s["kind"]  # noqa: E731
    cached: dict = {}
    kept: dict = {}  # the file's arrays, kept when it is rewritten
    notes_by_key: dict = {}
    if path.exists():
        with np.load(path, allow_pickle=False) as f:
            stored = json.loads(str(f["meta"]))
            if stored.get("scene") == scene and stored.get("robot") == meta["robot"]:
                kept = {name: f[name] for name in f.files if name != "meta"}
                notes_by_key = stored.get("notes", {})
    for s in settings:
        if not recompute and f"{key(s)}_t" in kept:
            cached[s["label"]] = {name: kept[f"{key(s)}_{name}"] for name in names}
    missing = [s for s in settings if s["label"] not in cached]
    if missing:
        for s in missing:
            t0 = time.perf_counter()
            model = scene_model(base64, RK4, SCENE["reference_dt"], s)
            cached[s["label"]] = trajectory(model, init)
            wall = time.perf_counter() - t0
            # the reference's own error: the same comparison at twice its step
            coarse = trajectory(scene_model(base64, RK4, 2 * SCENE["reference_dt"], s), init)
            e = errors(coarse, cached[s["label"]])
            steps = int(round(SCENE["horizon"] / SCENE["reference_dt"]))
            what = f"K = {s['K']:g}, D = {s['D']:.4g}" if s["kind"] == "soft" else s["label"]
            line = (
                f"{what}: {steps} RK4 steps of {SCENE['reference_dt']:g} s in {wall:.1f} s on {wp.get_device(device).name}; "
                f"dt = {2 * SCENE['reference_dt']:g} vs it: base {e['base']:.2g} m, tilt {e['tilt']:.2g} deg, joints {e['joints']:.2g} rad"
            )
            print(line, flush=True)
            notes_by_key[key(s)] = line
            for name in names:
                kept[f"{key(s)}_{name}"] = cached[s["label"]][name]
        meta["notes"] = notes_by_key
        RESULTS.mkdir(exist_ok=True)
        np.savez_compressed(path, meta=json.dumps(meta), **kept)
    note = "\n".join(notes_by_key.get(key(s), "") for s in settings)
    return cached, note, bool(missing)


# ------------------------------------------------------------------------------------------- throughput


def batch_data(model, init: dict, N: int):
    """N environments of the drops' poses (cycled), lowered so the lowest point is 2 +- 1 mm deep (in contact)."""
    rng = np.random.default_rng(1)
    pick = np.arange(N) % SCENE["drops"]
    p = init["base_position"][pick].copy()
    p[:, 2] += -SCENE["drop"] - 0.002 + rng.uniform(-1e-3, 1e-3, N)
    return wd.data.Data.build(
        model, num_envs=N, base_position=p, base_quaternion=init["base_quaternion"][pick], joint_positions=init["joint_positions"][pick]
    )


def throughput(model, init: dict, N: int, steps: int, repeats: int) -> float:
    """Seconds per step of a graph-replayed rollout of N environments (median over repeats)."""
    data = batch_data(model, init, N)
    roll = wd.simulation.Rollout(model, steps=steps, record=("valid",))
    roll.run(data)  # compile, capture
    return median_time(lambda: roll.run(data), model.device, repeats, min_seconds=0.0) / steps


# ---------------------------------------------------------------------------------------------- report


def device_tag(device) -> str:
    d = wp.get_device(device)
    if not d.is_cuda:
        return "cpu"
    return re.sub(r"[^a-z0-9]+", "_", d.name.lower()).strip("_")


def fmt(x: float) -> str:
    return f"{x:.2g}" if x < 1e-2 or x >= 1e3 else f"{x:.3g}"


def plot(rows: list, path: pathlib.Path, title: str) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
        return False
    labels = list(dict.fromkeys(r["contact"] for r in rows))
    fig, axes = plt.subplots(2, len(labels), figsize=(4.2 * len(labels), 7.6), sharex=True, squeeze=False)
    styles = {
        ("SIE", "float32"): ("tab:orange", "o"),
        ("SIE", "float64"): ("tab:red", "s"),
        ("RK4", "float32"): ("tab:cyan", "^"),
        ("RK4", "float64"): ("tab:blue", "D"),
    }
    for col, label_ in enumerate(labels):
        for row, (metric, label) in enumerate((("base", "base position error, max [m]"), ("joints", "joint position error, RMS [rad]"))):
            ax = axes[row][col]
            broken = {}
            for (integ, dtype), (colour, marker) in styles.items():
                sel = [r for r in rows if r["contact"] == label_ and r["integrator"] == integ and r["dtype"] == dtype]
                ok = sorted([r for r in sel if r["outcome"] == "ok"], key=lambda r: r["dt"])
                if ok:
                    x = [r["sim_per_s"] for r in ok]
                    y = [max(r[metric], 1e-12) for r in ok]
                    ax.plot(x, y, color=colour, marker=marker, ms=5, lw=1, label=f"{integ} {dtype}")
                    if dtype == "float64":
                        for r, xi, yi in zip(ok, x, y):
                            ax.annotate(f"{r['dt'] * 1e3:g}", (xi, yi), textcoords="offset points", xytext=(3, 3), fontsize=6, color=colour)
                for r in sel:
                    if r["outcome"] != "ok":
                        broken.setdefault((integ, r["outcome"].split(" ")[0]), set()).add(r["dt"] * 1e3)
                        if r.get("sim_per_s"):
                            ax.scatter([r["sim_per_s"]], [1.0], marker="x", color=colour, s=30, clip_on=False)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.3)
            if row == 0:
                first = next(r for r in rows if r["contact"] == label_)
                ax.set_title(f"soft K = {first['K']:.0e}, D = {first['D']:.3g}" if first["kind"] == "soft" else label_)
            if row == 1:
                ax.set_xlabel("simulated env-seconds per wall second")
            if col == 0:
                ax.set_ylabel(label)
            if broken and row == 0:
                text = "\n".join(f"{i} {o}: {', '.join(f'{d:g}' for d in sorted(v))} ms" for (i, o), v in sorted(broken.items()))
                ax.text(0.98, 0.02, text, transform=ax.transAxes, fontsize=6.5, va="bottom", ha="right", family="monospace",
                        bbox=dict(facecolor="white", alpha=0.8, lw=0))
    axes[0][0].legend(fontsize=7, loc="upper left")
    fig.suptitle(title, fontsize=9)
    fig.text(0.5, 0.005, "labels: dt [ms] (float64 points); x at the top: diverged and flagged (valid = 0); lower right: flagged and refused dt (either dtype)", ha="center", fontsize=7)
    fig.tight_layout(rect=(0, 0.015, 1, 0.96))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--joints", default="pd", choices=("pd", "passive", "servo", "servo-explicit"))
    parser.add_argument("--d-scale", type=float, default=1.0, help="multiply every D by this (a probe of the damping's role)")
    parser.add_argument("--envs", type=int, default=None, help="batch size of the throughput runs (CPU 256, GPU 16384)")
    parser.add_argument("--steps", type=int, default=None, help="steps per throughput run (CPU 32, GPU 100)")
    parser.add_argument("--repeats", type=int, default=11)
    parser.add_argument("--ks", default=",".join(f"{k:g}" for k in K_VALUES))
    parser.add_argument("--contacts", default="soft", help="contact models: soft (at each K of --ks), relaxed, rigid")
    parser.add_argument("--dts", default=",".join(f"{d:g}" for d in DTS))
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--integrators", default="SIE,RK4")
    parser.add_argument("--tag", default=None)
    parser.add_argument("--recompute-reference", action="store_true")
    parser.add_argument("--no-throughput", action="store_true")
    args = parser.parse_args()
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    device = wp.get_device(args.device)
    N = args.envs or (16384 if device.is_cuda else 256)
    T = args.steps or (100 if device.is_cuda else 32)
    ks = [float(k) for k in args.ks.split(",")]
    settings = contact_settings(args.contacts.split(","), ks)
    dts = sorted(float(d) for d in args.dts.split(","))
    integrators = [{"SIE": SIE, "RK4": RK4}[i] for i in args.integrators.split(",")]
    dtypes = args.dtypes.split(",")
    SCENE["joints"] = args.joints
    SCENE["d_scale"] = args.d_scale
    tag = (args.tag or device_tag(device)) + ("" if args.joints == "pd" else f"_{args.joints}")
    tag += "" if args.d_scale == 1.0 else f"_D{args.d_scale:g}x"
    tag += "" if args.contacts == "soft" else "_" + args.contacts.replace(",", "_")
    started = time.perf_counter()
    print(header(device), flush=True)

    base64 = seed_model(np.float64, device)  # the run's device: a GPU machine's Warp may not compile for its CPU
    init = initial_state(base64)
    inertia, sie_limit, rk4_limit = pd_limits(base64, init)
    t0 = time.perf_counter()
    refs, ref_note, computed = reference(base64, init, settings, args.recompute_reference, str(device))
    ref_wall = time.perf_counter() - t0
    print(f"reference ready in {ref_wall:.1f} s", flush=True)

    bases = {name: seed_model({"float32": np.float32, "float64": np.float64}[name], device) for name in dtypes}
    rows = []
    for setting in settings:
        K, D = setting["K"], setting["D"]
        for integrator in integrators:
            for dtype in dtypes:
                step_s = None  # measured once per (integrator, dtype, setting): the launches do not depend on dt
                for dt in dts:
                    r = {"contact": setting["label"], "kind": setting["kind"], "K": K, "D": D, "integrator": SHORT[integrator], "dtype": dtype, "dt": dt, "ratio": dt * K / D}
                    nan = dict(base=np.nan, base_median=np.nan, tilt=np.nan, joints=np.nan)
                    try:
                        model = scene_model(bases[dtype], integrator, dt, setting)
                        run = trajectory(model, init)
                    except ValueError as error:
                        if "stability limit" not in str(error):
                            raise
                        r.update(outcome="refused (dt K/D)", step_s=np.nan, sim_per_s=np.nan, **nan)
                        rows.append(r)
                        print(r, flush=True)
                        continue
                    r.update(errors(run, refs[setting["label"]]))
                    flagged = run["valid"] == 0
                    if flagged.any():
                        first = run["t"][np.flatnonzero(flagged.any(axis=1))[0]]
                        r["outcome"] = f"flagged {int(flagged[-1].sum())}/{flagged.shape[1]} (t = {first:.3g} s)"
                    else:
                        r["outcome"] = "ok"
                    if step_s is None:
                        step_s = np.nan if args.no_throughput else throughput(model, init, N, T, args.repeats)
                    r["step_s"] = step_s
                    r["sim_per_s"] = N / step_s * dt
                    rows.append(r)
                    print({k: (f"{v:.3g}" if isinstance(v, float) else v) for k, v in r.items()}, flush=True)
    total = time.perf_counter() - started

    RESULTS.mkdir(exist_ok=True)
    md = RESULTS / f"speed_accuracy_{tag}.md"
    png = RESULTS / f"speed_accuracy_{tag}.png"
    command = "python benchmarks/speed_accuracy.py" + (f" --device {args.device}" if args.device else "")
    command += f" --joints {args.joints}" if args.joints != "pd" else ""
    command += f" --d-scale {args.d_scale:g}" if args.d_scale != 1.0 else ""
    for flag, value, default in (("--contacts", args.contacts, "soft"), ("--ks", args.ks, parser.get_default("ks")), ("--dts", args.dts, parser.get_default("dts")),
                                 ("--dtypes", args.dtypes, "float32,float64"), ("--integrators", args.integrators, "SIE,RK4")):
        command += f" {flag} {value}" if value != default else ""
    command += " --no-throughput" if args.no_throughput else ""
    if args.joints == "pd":
        joints_text = [
            f"joint PD to 0 (Kp = {SCENE['kp']:g} N m/rad, Kd = {SCENE['kd']:g} N m s/rad) in the step's actuation, so held during each",
            f"step: its stiffest mode (I = {inertia:.2g} kg m^2) is stable for SIE while dt^2 Kp/I + 2 dt Kd/I < 4, i.e. dt < {sie_limit * 1e3:.2f} ms,",
            f"and for RK4 (torque held over the stages) while dt < min(2 I/Kd, 2 Kd/Kp) = {rk4_limit * 1e3:.2f} ms, at every K (in flight).",
        ]
    elif args.joints.startswith("servo"):
        how = "implicitly" if args.joints == "servo" else "explicitly"
        bound = "dt^2 Kp/I - 2 dt Kd/I < 4" if args.joints == "servo" else "dt^2 Kp/I + 2 dt Kd/I < 4"
        joints_text = [
            f"MuJoCo-style servos: a position actuator per joint (kp = {SCENE['kp']:g} N m/rad, ctrl = 0) and the joint damper",
            f"damping = {SCENE['kd']:g} N m s/rad, which the semi-implicit Euler integrates {how}; both evaluated at each RK4 stage.",
            f"Stiffest mode (I = {inertia:.2g} kg m^2) stable for SIE while {bound}, i.e. dt < {sie_limit * 1e3:.2f} ms, and for RK4",
            f"while dt < {rk4_limit * 1e3:.2f} ms (its stability region), in flight.",
        ]
    else:
        joints_text = ["passive joints: no torque, no friction (every force evaluated at each RK4 stage); the legs fold after landing."]
    lines = [
        "# Speed and accuracy: integrator x time step x dtype x contact model (benchmarks/speed_accuracy.py)",
        "",
        f"`{command}`; {header(device)}.",
        "",
        f"Scene: the seed's ergoCub legs dropped from {SCENE['drop'] * 100:g} cm, {SCENE['drops']} drops (base tilted up to "
        f"{SCENE['tilt_deg']:g} deg about x and y, joints offset up to {SCENE['joint_offset']:g} rad, seeded),",
        *joints_text,
        f"Flat ground, mu = {SCENE['mu']:g}, horizon {SCENE['horizon']:g} s (landing at ~0.1 s). Soft contacts: D = 2000 (K/1e6)^(2/3) (JaxSim's",
        "default at K = 1e6, the same damping ratio at every K)" + (f", times {args.d_scale:g}." if args.d_scale != 1.0 else ".") + " relaxed: JaxSim's RelaxedRigidContacts, its defaults;",
        "rigid: JaxSim's RigidContacts, mu 0.5, K = D = 0 (its defaults), the impact after each step. Errors against float64 RK4 at dt = 1e-5 s with the same contact setting,",
        "sampled every 4 ms: base = max over drops and time of |p_B - p_B,ref| [m] (median: the median over drops of each",
        "drop's max), tilt = max angle between base orientations [deg], joints = RMS of s - s_ref [rad].",
        f"Throughput: graph-replayed `Rollout.run` of {T} steps, N = {N} environments in contact, median of {args.repeats} runs,",
        "measured once per (integrator, dtype, contact setting) (a step's launches do not depend on dt); sim-s/s = env-steps/s x dt.",
        "Outcomes: refused = `step` raises ValueError (dt K/D beyond 2 for SIE, 2.785 for RK4); flagged = some drops' states",
        "went non-finite and data.healthy = 0 (how many at the end, and the first time).",
        "",
        "Reference (and its own error, by the same comparison at dt = 2e-5 s; errors of that size are the reference's):",
        *[f"- {line}" for line in ref_note.splitlines() if line],
        "",
        f"Wall time of this run: {total:.0f} s (reference {ref_wall:.1f} s, {'computed' if computed else 'loaded from ' + reference_path().name}).",
        "",
        "| contact | integrator | dtype | dt [ms] | dt K/D | outcome | base [m] | base median [m] | tilt [deg] | joints [rad] | step [ms] | env-steps/s | sim-s/s |",
        "| --- | --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        num = lambda x: fmt(x) if np.isfinite(x) else "-"  # noqa: E731
        lines.append(
            f"| {r['contact']} | {r['integrator']} | {r['dtype']} | {r['dt'] * 1e3:g} | {num(r['ratio'])} | {r['outcome']} | "
            f"{num(r['base'])} | {num(r['base_median'])} | {num(r['tilt'])} | {num(r['joints'])} | {num(r['step_s'] * 1e3)} | "
            f"{num(N / r['step_s'])} | {num(r['sim_per_s'])} |"
        )
    if not args.no_throughput:
        lines += ["", *summary(rows)]
    md.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    joints = {"pd": "joint PD", "passive": "passive joints", "servo": "servos, implicit damping", "servo-explicit": "servos, explicit damping"}[args.joints]
    title = (
        f"ergoCub legs landing ({joints}): error vs throughput ({wp.get_device(device).name}, N = {N}); "
        "reference float64 RK4, dt = 1e-5 s"
    )
    if not args.no_throughput and plot(rows, png, title):
        print(f"wrote {md} and {png}")
    else:
        print(f"wrote {md}")


def summary(rows: list) -> list:
    """Per contact setting: the fastest setting (most sim-s/s) whose base error stays under each budget, and the
    largest dt that ran without a flag."""
    out = ["Fastest setting (most sim-s/s) whose base error (max over drops) stays within a budget, per contact setting;", "largest dt that ran unflagged (either integrator and dtype):", ""]
    out.append("| contact | budget [m] | integrator | dtype | dt [ms] | base [m] | joints [rad] | sim-s/s |")
    out.append("| --- | ---: | --- | --- | ---: | ---: | ---: | ---: |")
    for label in dict.fromkeys(r["contact"] for r in rows):
        for budget in (1e-2, 1e-3, 1e-4):
            good = [r for r in rows if r["contact"] == label and r["outcome"] == "ok" and r["base"] <= budget and np.isfinite(r["sim_per_s"])]
            if not good:
                out.append(f"| {label} | {budget:g} | none | | | | | |")
                continue
            b = max(good, key=lambda r: r["sim_per_s"])
            out.append(
                f"| {label} | {budget:g} | {b['integrator']} | {b['dtype']} | {b['dt'] * 1e3:g} | {fmt(b['base'])} | {fmt(b['joints'])} | {fmt(b['sim_per_s'])} |"
            )
        ran = [r["dt"] for r in rows if r["contact"] == label and r["outcome"] == "ok"]
        out.append(f"| {label} | largest unflagged dt | | | {max(ran) * 1e3:g} | | | |" if ran else f"| {label} | largest unflagged dt | none | | | | | |")
    return out


if __name__ == "__main__":
    main()
