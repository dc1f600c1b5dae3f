"""CubeReorientEnv's physics under the policy's kind of actions, without a policy: how fast the cube goes and whether
any environment is flagged, at a time step and contact damping (issue 37: why CubeReorientConfig steps at 2 ms with
D = 2000 and implicit contacts).

    python benchmarks/reorient_stability.py [--num-envs 128] [--seconds 10] [--time-step 0.002] [--damping 2000]
                                            [--explicit] [--seed 7]

What runs (float32 on Warp's default device): --num-envs environments reset from the bank (seed --seed), then smooth
random actions (each policy step a = 0.8 a + 0.2 u, u uniform in [-1, 1]^16) for --seconds, episodes long enough not
to end; then, from Playground's raw reset draws (the bank's depth limit lifted to 5 cm: 8 in 10 penetrate by more than
2 mm), the cube's fastest speed over 10 policy steps of zero actions, for the draws deeper than 2 mm. Prints the
cube's largest and median speed [m/s] every second, the healthy environments, and the deep draws' median and largest
departure speed.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--num-envs", type=int, default=128)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--time-step", type=float, default=0.002)
    parser.add_argument("--damping", type=float, default=2000.0)
    parser.add_argument("--explicit", action="store_true", help="explicit contacts (implicit by default)")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    wp.config.quiet = True
    warnings.simplefilter("ignore", wd.model.NotModelledWarning)
    N = args.num_envs
    config = envs.CubeReorientConfig(time_step=args.time_step, contact_damping=args.damping, implicit_contacts=not args.explicit, episode_seconds=1e3)
    env = envs.CubeReorientEnv(N, config, seed=args.seed)
    env.reset(seed=args.seed)
    generator = torch.Generator().manual_seed(args.seed)
    actions = torch.zeros(N, 16)
    steps = int(round(args.seconds / config.policy_dt))
    per_second = int(round(1.0 / config.policy_dt))
    print(f"{N} environments, {config.time_step * 1e3:g} ms steps, D = {config.contact_damping:g}, {'explicit' if args.explicit else 'implicit'} contacts, {env.model.device}")
    fastest = 0.0
    for k in range(steps):
        actions = 0.8 * actions + 0.2 * (2 * torch.rand(N, 16, generator=generator) - 1)
        env.step(actions.to(env.device))
        speed = env._state()[4][:, :3].norm(dim=1).cpu().numpy()
        fastest = max(fastest, float(speed.max()))
        if (k + 1) % per_second == 0:
            healthy = int(wp.to_torch(env.stepper.data.valid_state).sum())
            print(f"  {(k + 1) * config.policy_dt:5.1f} s: cube speed max {speed.max():.3g} m/s, median {np.median(speed):.3g}; healthy {healthy} of {N}")
    print(f"random actions: the cube's fastest {fastest:.3g} m/s over {args.seconds:g} s")
    raw = envs.CubeReorientEnv(N, envs.CubeReorientConfig(**{**config.__dict__, "reset_depth": 0.05}), seed=args.seed)
    raw.reset(seed=args.seed)
    depth = np.maximum(0.0, -wd.contact.geom_contacts(raw.model, raw.stepper.data).distance.numpy()).max(axis=1)
    departure = np.zeros(N)
    for _ in range(10):
        raw.step(torch.zeros(N, 16, device=raw.device))
        departure = np.maximum(departure, raw._state()[4][:, :3].norm(dim=1).cpu().numpy())
    deep = depth > 0.002
    print(f"raw reset draws: {int(deep.sum())} of {N} deeper than 2 mm (at most {depth.max() * 1e3:.1f} mm); their cube leaves at a median "
          f"{np.median(departure[deep]):.3g} m/s, at most {departure[deep].max():.3g}")


if __name__ == "__main__":
    main()
