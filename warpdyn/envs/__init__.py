"""Batched RL environments on warpdyn (optional: `pip install -e ".[rl]"`, torch and gymnasium; rsl-rl-lib
for `warpdyn.envs.rsl_rl`).

    import warpdyn.envs as envs
    env = envs.LeggedEnv(model, num_envs=4096, cfg=envs.LeggedEnvConfig(push_velocity=0.5))
    obs, info = env.reset(seed=0)                        # torch (N, obs_dim) on the model's device
    obs, reward, terminated, truncated, info = env.step(actions)   # actions: torch (N, na)

`LeggedEnv` follows Gymnasium's vector API (SAME_STEP autoreset) with torch tensors sharing memory with
Warp: a step writes the actions into a `wd.simulation.Stepper`'s controls, runs its `decimation` simulation
steps, and computes observations, rewards and resets with torch ops on the device, without a host
synchronisation; on a GPU the whole step replays as one CUDA graph (eager while another warpdyn thread works
there; on the CPU the simulation steps replay a Warp CPU graph). Its terms (`warpdyn.envs.terms`) are functions of the state that a
configuration composes. `warpdyn.envs.rsl_rl.RslRlVecEnv` hands it to rsl-rl's PPO (examples/rl_locomotion.py).
`warpdyn.envs.terrain_generator` tiles rough sub-terrains of graded difficulty into a heightfield and moves
environments between its levels (Rudin et al.'s curriculum; LeggedEnvConfig.terrain). `warpdyn.envs.sensors` puts an
IMU on the base or a link (`ImuConfig`); `warpdyn.envs.actuators` turns actions into torques ("torque", `ActuatorNet`);
`warpdyn.envs.robots` sets a legged robot up from its description and a few names (`LeggedRobot`, the presets).
`PickCubeEnv` (`warpdyn.envs.manipulation`): the Franka Panda picking up a cube and bringing it to a target, after
MuJoCo Playground's PandaPickCube, on the same vector API (`warpdyn.envs.vector_env`). `CubeReorientEnv`
(`warpdyn.envs.reorient`): the LEAP hand turning a cube in its palm to goal orientations, after Playground's
LeapCubeReorient.
"""

from . import robots, terms
from .actuators import ActuatorNet
from .legged import DEFAULT_OBSERVATIONS, DEFAULT_REWARDS, LeggedEnv, LeggedEnvConfig
from .manipulation import PickCubeConfig, PickCubeEnv
from .reorient import CubeReorientConfig, CubeReorientEnv
from .robots import LeggedRobot
from .sensors import ImuConfig

__all__ = ["LeggedEnv", "LeggedEnvConfig", "PickCubeEnv", "PickCubeConfig", "CubeReorientEnv", "CubeReorientConfig", "LeggedRobot", "DEFAULT_OBSERVATIONS", "DEFAULT_REWARDS", "ImuConfig", "ActuatorNet", "terms", "robots"]
